#include "spm/streams.h"

#include <algorithm>
#include <utility>

#include "util/errors.h"
#include "util/radix_sort.h"

namespace spm {

namespace {

// Device memory of one stream slot: its state, two queue entries, and room for one iteration's worth of
// surface records and eight volume records, so that flushes stay rare.
size_t bytes_per_stream(uint32_t associated) {
  return StreamState::bytes_per_slot() + 2 * sizeof(cl_uint) + associated * sizeof(SpmSurfaceRecord) +
         8 * sizeof(SpmVolumeRecord);
}

// A batch takes `memory_budget` bytes when set, else half the device memory
// still free, at most 1 GiB.
uint32_t batch_size(const Device& device, const StreamSettings& s) {
  const DeviceInfo& info = device.info();
  const size_t budget =
      s.memory_budget ? s.memory_budget : std::min<size_t>(device.memory_free() / 2, size_t(1) << 30);
  size_t n = budget / bytes_per_stream(s.associated);
  // The largest single buffer, the surface records, must fit one allocation.
  n = std::min<size_t>(n, info.max_alloc / (s.associated * sizeof(SpmSurfaceRecord)));
  // Per-photon kernels index (stream, photon) with 32-bit global ids.
  n = std::min<size_t>(n, (size_t(1) << 31) / s.associated);
  n = std::min<size_t>(n, s.streams);
  if (n == 0) {
    throw RuntimeError("one stream of " + std::to_string(s.associated) + " associated photons (" +
                       std::to_string(bytes_per_stream(s.associated)) + " bytes) does not fit the " +
                       std::to_string(budget) + " bytes left for stream batches of the device memory budget of " +
                       std::to_string(device.memory_budget()) + " bytes (--device-memory)");
  }
  return static_cast<uint32_t>(n);
}

}  // namespace

StreamTracer::StreamTracer(Device& device, const GpuScene& scene, const StreamSettings& settings)
    : device_(device), scene_(scene), settings_(settings) {
  if (settings_.streams == 0 || settings_.associated == 0) throw InputError("", "streams and associated must be >= 1");
  if (settings_.associated > 65535) throw InputError("", "associated photons per stream must be at most 65535");
  capacity_ = batch_size(device, settings_);
  volume_capacity_ = 8 * capacity_;
  surface_capacity_ = capacity_ * settings_.associated;
  state_ = StreamState(device, capacity_);
  queue_ = device.buffer(sizeof(cl_uint) * capacity_, "the stream queue");
  queue_next_ = device.buffer(sizeof(cl_uint) * capacity_, "the stream queue");
  counters_buffer_ = device.buffer(sizeof(cl_uint) * SPM_COUNTERS, "the stream counters");
  volume_ = device.buffer(sizeof(SpmVolumeRecord) * volume_capacity_, "the volume map buffer");
  surface_ = device.buffer(sizeof(SpmSurfaceRecord) * surface_capacity_, "the surface map buffer");
  emit_ = device.kernel("spm_emit", "spm_emit");
  march_ = device.kernel("spm_march", "spm_march");
  interact_ = device.kernel("spm_interact", "spm_interact");
  deposit_ = device.kernel("spm_deposit", "spm_deposit");
  absorb_ = device.kernel("spm_absorb", "spm_absorb");
  respawn_ = device.kernel("spm_respawn", "spm_respawn");
  compact_ = device.kernel("spm_compact", "spm_compact");
  counters_.fill(0);
  device_.queue().enqueueWriteBuffer(counters_buffer_, CL_TRUE, 0, sizeof(cl_uint) * SPM_COUNTERS, counters_.data());
}

size_t StreamTracer::bytes() const {
  return size_t(capacity_) * bytes_per_stream(settings_.associated) + sizeof(cl_uint) * SPM_COUNTERS;
}

void StreamTracer::launch_photons(const char* label, cl::Kernel& kernel) {
  device_.launch(label, kernel, size_t(live_) * settings_.associated);
}

void StreamTracer::emit(uint32_t first, uint32_t count) {
  if (count == 0 || count > capacity_) throw RuntimeError("emit: batch of " + std::to_string(count) + " streams");
  const StreamSettings& s = settings_;
  live_ = count;
  set_args(emit_, scene_, arg("queue", queue_), arg("count", cl_uint(count)), state_, arg("first_stream", cl_uint(first)),
           arg("pass_streams", cl_uint(s.streams)), arg("associated", cl_uint(s.associated)),
           arg("seed", cl_uint(s.seed)), arg("pass", cl_uint(s.pass)));
  device_.launch("emit", emit_, count);
  set_args(respawn_, arg("queue", queue_), arg("count", cl_uint(count)), state_);
  device_.launch("respawn", respawn_, count);
}

uint32_t StreamTracer::step() {
  const StreamSettings& s = settings_;
  const cl_uint n = live_;
  if (n == 0) return 0;
  live_log_.push_back(n);
  // The loop of METHOD.md 3 over the live queue. Interact appends at most one
  // volume record and n <= N_a surface records per stream; flush() made room.
  set_args(march_, scene_, arg("queue", queue_), arg("count", n), state_, arg("march_step", s.march_step),
           arg("seed", cl_uint(s.seed)), arg("pass", cl_uint(s.pass)));
  device_.launch("march", march_, n);
  set_args(interact_, scene_, arg("queue", queue_), arg("count", n), state_, arg("volume", volume_),
           arg("volume_capacity", volume_capacity_), arg("surface_capacity", surface_capacity_),
           arg("counters", counters_buffer_), arg("max_bounces", cl_uint(s.max_bounces)),
           arg("max_depth", cl_uint(s.max_depth)), arg("rr_depth", cl_uint(s.rr_depth)), arg("seed", cl_uint(s.seed)),
           arg("pass", cl_uint(s.pass)));
  device_.launch("interact", interact_, n);
  set_args(deposit_, arg("queue", queue_), arg("count", n), state_, arg("associated", cl_uint(s.associated)),
           arg("width", s.width), arg("surface", surface_), arg("surface_capacity", surface_capacity_),
           arg("seed", cl_uint(s.seed)), arg("pass", cl_uint(s.pass)));
  launch_photons("deposit", deposit_);
  set_args(absorb_, arg("queue", queue_), arg("count", n), state_, arg("associated", cl_uint(s.associated)),
           arg("seed", cl_uint(s.seed)), arg("pass", cl_uint(s.pass)));
  launch_photons("absorb", absorb_);
  set_args(respawn_, arg("queue", queue_), arg("count", n), state_);
  device_.launch("respawn", respawn_, n);
  const cl_uint zero = 0;
  device_.queue().enqueueWriteBuffer(counters_buffer_, CL_FALSE, sizeof(cl_uint) * SPM_COUNT_LIVE, sizeof(cl_uint),
                                     &zero);
  set_args(compact_, arg("queue", queue_), arg("count", n), state_, arg("queue_next", queue_next_),
           arg("counters", counters_buffer_));
  device_.launch("compact", compact_, n);
  std::swap(queue_, queue_next_);
  read_counters();
  const cl_uint errors = counters_[SPM_COUNT_ERRORS];
  if (errors & SPM_ERROR_NONFINITE) {
    throw RuntimeError("stream propagation, pass " + std::to_string(settings_.pass) +
                       ": a stream's flux became NaN or infinite");
  }
  if (errors != 0) {
    throw RuntimeError("stream map overflow (error bits " + std::to_string(errors) +
                       "): the host's capacity check failed");
  }
  live_ = counters_[SPM_COUNT_LIVE];
  return live_;
}

void StreamTracer::make_room(PhotonMaps& maps) {
  const size_t volume = size_t(counters_[SPM_COUNT_VOLUME]) + live_;
  const size_t surface = size_t(counters_[SPM_COUNT_SURFACE]) + size_t(live_) * settings_.associated;
  if (volume > volume_capacity_ || surface > surface_capacity_) {
    flush(maps);
    ++maps.stats.flushes;
  }
}

void StreamTracer::read_counters() {
  device_.queue().enqueueReadBuffer(counters_buffer_, CL_TRUE, 0, sizeof(cl_uint) * SPM_COUNTERS, counters_.data());
}


void StreamTracer::flush(PhotonMaps& maps) {
  read_counters();
  const auto volume = device_.download<SpmVolumeRecord>(volume_, counters_[SPM_COUNT_VOLUME]);
  const auto surface = device_.download<SpmSurfaceRecord>(surface_, counters_[SPM_COUNT_SURFACE]);
  maps.volume.insert(maps.volume.end(), volume.begin(), volume.end());
  maps.surface.insert(maps.surface.end(), surface.begin(), surface.end());
  for (int k = 0; k < SPM_COUNTERS; ++k) {
    if (k != SPM_COUNT_LIVE) maps.stats.counters[k] += counters_[k];
  }
  maps.stats.live.insert(maps.stats.live.end(), live_log_.begin(), live_log_.end());
  live_log_.clear();
  counters_.fill(0);
  counters_[SPM_COUNT_LIVE] = live_;
  device_.queue().enqueueWriteBuffer(counters_buffer_, CL_TRUE, 0, sizeof(cl_uint) * SPM_COUNTERS, counters_.data());
}

PhotonMaps StreamTracer::trace(uint32_t pass, float width) { return trace(pass, width, 0, settings_.streams); }

PhotonMaps StreamTracer::trace(uint32_t pass, float width, uint32_t begin, uint32_t streams) {
  settings_.pass = pass;
  settings_.width = width;
  PhotonMaps maps;
  maps.stats.batch_size = capacity_;
  const uint32_t end = std::min(settings_.streams, begin + streams);
  for (uint32_t first = begin; first < end; first += capacity_) {
    const uint32_t count = std::min(capacity_, end - first);
    emit(first, count);
    maps.stats.counters[SPM_COUNT_STREAMS] += count;
    ++maps.stats.batches;
    while (live_ > 0) {
      make_room(maps);
      step();
    }
    flush(maps);
  }
  // Appends raced on the device; (stream, event[, photon]) is a total order
  // independent of it, so the maps and every sum over them are deterministic.
  sort_by_key(maps.volume, [](const SpmVolumeRecord& r) { return uint64_t(r.stream) << 32 | r.depth; });
  sort_by_key(maps.surface, [](const SpmSurfaceRecord& r) { return uint64_t(r.stream) << 32 | r.depth_photon; });
  return maps;
}

PhotonMaps trace_streams(Device& device, const GpuScene& scene, const StreamSettings& settings) {
  return StreamTracer(device, scene, settings).trace(settings.pass, settings.width);
}

}  // namespace spm
