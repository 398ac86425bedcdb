// Stream propagation (METHOD.md 2-4): batches of streams run as wavefront
// kernels over queues (kernels/spm_streams.h), emit and respawn, then march,
// interact, deposit, absorb and respawn until no stream lives; the records land in the two photon maps.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "device/device.h"
#include "scene/gpu_scene.h"
#include "spm/stream_state.h"
#include "spm_streams.h"
#include "spm_types.h"

namespace spm {

struct StreamSettings {
  uint32_t streams = 10000;    // N_s in the pass
  uint32_t associated = 100;   // N_a per stream
  float stream_width = 2.5f;   // w: radius of the ball and disk of offsets (METHOD.md 1)
  uint32_t max_bounces = 4;    // diffuse bounces before a stream ends; SPM_NONE: unlimited
  uint32_t max_depth = SPM_NONE;  // METHOD.md 10: longest path in segments; SPM_NONE: unlimited
  uint32_t rr_depth = 5;       // Russian roulette from this path vertex on
  float march_step = 0.0f;     // 0: exact free-flight sampling
  bool beams = false;          // march appends stream beams (METHOD.md 11) for a gather that reads them
  uint32_t beam_streams = 0;   // with beams: streams [0, beam_streams) of the pass write them
  uint32_t seed = 0;
  uint32_t pass = 0;
  size_t memory_budget = 0;    // bytes of device memory for a batch; 0: half the device's free memory
};

struct StreamStats {
  uint32_t batches = 0;
  uint32_t batch_size = 0;
  uint32_t flushes = 0;             // map downloads forced by full buffers
  std::vector<uint32_t> live;       // live streams at the start of each iteration
  std::array<uint64_t, SPM_COUNTERS> counters{};  // SPM_COUNT_* summed over batches
};

struct PhotonMaps {
  std::vector<SpmVolumeRecord> volume;    // ordered by (stream, event)
  std::vector<SpmSurfaceRecord> surface;  // ordered by (stream, event, photon)
  std::vector<SpmBeam> beams;             // ordered by (stream, event); empty unless settings.beams
  StreamStats stats;
};

// Stream propagation on one device, batch by batch; propagate() runs a whole
// pass, tests drive emit/make_room/step/flush themselves to look inside.
class StreamPropagator {
 public:
  StreamPropagator(Device& device, const GpuScene& scene, const StreamSettings& settings);

  uint32_t batch_capacity() const { return capacity_; }

  // Device memory of the batch's buffers.
  size_t bytes() const;

  // All N_s streams of pass `pass` with stream width `width`, batch by batch;
  // the maps come back ordered. The propagator's buffers serve every pass.
  PhotonMaps propagate(uint32_t pass, float width);

  // Streams [first, first + count) of the pass alone: the maps of
  // consecutive ranges, concatenated, are those of the whole pass.
  PhotonMaps propagate(uint32_t pass, float width, uint32_t first, uint32_t count);

  const StreamSettings& settings() const { return settings_; }

  // The settings of the passes from now on: the same associated photons
  // and beams as the propagator was made for, and at most as many streams,
  // so that its buffers still fit (a timed render's fewer streams per pass).
  void set_settings(const StreamSettings& settings);

  // The scale pilot's propagation (render/defaults.h): streams [first,
  // first + count) of pass 0 with one photon each, at the leader, and no
  // width or beams: the positions of the leaders' events, which the width
  // does not change, on the passes' own buffers.
  PhotonMaps propagate_leaders(uint32_t first, uint32_t count);

  // Emits streams [first, first + count) of the pass (count <= capacity) and
  // gives their associated photons offsets in the disk around the origin
  // (respawn: the offset frame deposit draws them from).
  void emit(uint32_t first, uint32_t count);

  // Before step(): downloads the maps into `maps` when the coming iteration's
  // worst case (one volume record, one beam and N_a surface records per live stream)
  // might not fit, so that nothing is ever dropped.
  void make_room(PhotonMaps& maps);

  // One wavefront iteration over the live streams; returns at most how
  // many live on (the exact number is on the device until the next step).
  uint32_t step();

  // Streams [first, first + count) of the pass (count <= capacity) from
  // emission until none lives, their records appended to `maps` in device
  // order (propagate() then orders them by stream).
  void run_batch(uint32_t first, uint32_t count, PhotonMaps& maps);

  // Moves the records written so far, and the counters, to `maps` (records
  // in device order; propagate() orders them by stream).
  void flush(PhotonMaps& maps);

  // For tests: the batch's buffers as they are now.
  const StreamState& state() const { return state_; }
  const std::array<cl_uint, SPM_COUNTERS>& counters() const { return counters_; }

 private:
  void read_counters();
  SpmStreamParams params() const;

  Device& device_;
  const GpuScene& scene_;
  StreamSettings settings_;
  uint32_t capacity_ = 0;
  uint32_t live_bound_ = 0;
  cl_uint volume_capacity_ = 0, surface_capacity_ = 0, beam_capacity_ = 0;
  StreamState state_;
  DeviceBuffer live_, live_next_, respawn_queue_, deposit_list_, absorb_list_, counts_, volume_, surface_, beams_;
  std::array<cl_uint, SPM_COUNTERS> counters_{};
  std::vector<uint32_t> live_log_;
  cl::Kernel emit_, march_, interact_, deposit_, absorb_, respawn_;
};

// All N_s streams of pass settings.pass, in batches sized to the device's memory.
PhotonMaps propagate_streams(Device& device, const GpuScene& scene, const StreamSettings& settings);

}  // namespace spm
