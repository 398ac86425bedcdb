// The profile: per-kernel device times from every labelled launch's
// profiling event, host stages, and the counters that explain the times
// (wavefront occupancy, events by kind, records, sphere tests). It only
// listens: nothing that computes an image depends on it.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "device/device.h"
#include "render/error_model.h"
#include "spm_streams.h"

namespace spm {

struct KernelTimes {
  size_t launches = 0;
  double total_ms = 0.0;   // device time, START to END
  double min_ms = 0.0;
  double max_ms = 0.0;
  double queued_ms = 0.0;  // QUEUED to START, summed
  size_t work_items = 0;   // launched (padded to whole work-groups)
  size_t items = 0;        // that had work (live streams, photons, pixels)
};

// What one pass of one device reports besides its image.
struct PassCounters {
  std::vector<uint32_t> live;                          // live streams per wavefront iteration
  std::array<uint64_t, SPM_COUNTERS> stream_counters{};  // SPM_COUNT_*
  uint64_t volume_records = 0;
  uint64_t surface_records = 0;
  uint64_t camera_samples = 0;
  uint64_t sphere_tests = 0;
  uint64_t map_parts = 1;   // parts the maps were gathered in to fit the device memory
  uint64_t host_parts = 1;  // parts the pass's streams were gathered in to fit the host memory
};

class Profiler {
 public:
  // `trace`: keep every event for write_trace (memory grows with the launches).
  explicit Profiler(bool trace);

  double now() const;  // seconds since the profiler started

  // A host stage on `track` (0: the main thread, d + 1: device d's worker).
  void stage(const std::string& name, double start, double end, int track = 0);

  // Folds a device's launches in (waits for them); thread-safe.
  void add_launches(int device, std::vector<Launch> launches);
  void add_pass(int device, int pass, const PassCounters& counters);
  void add_device(int device, const std::string& name);
  void add_value(const std::string& key, double value);  // host figures: build times, ...
  // The render's estimated error after each pass summed, at `seconds` on this clock.
  void add_estimate(const ErrorEstimate& e, double seconds);

  std::map<std::string, KernelTimes> kernels() const;
  nlohmann::json json() const;
  // Chrome trace event format: one process per device queue plus the host.
  void write_trace(const std::string& path) const;

 private:
  struct Event {
    std::string name;
    int pid, tid;
    double start_us, dur_us;
  };
  mutable std::mutex mutex_;
  bool trace_;
  std::chrono::steady_clock::time_point start_;
  std::map<std::string, KernelTimes> kernels_;
  std::map<int, std::string> devices_;
  std::map<int, double> device_offset_us_;  // device clock to profiler clock
  std::vector<Event> events_;
  nlohmann::json passes_ = nlohmann::json::array();
  nlohmann::json estimates_ = nlohmann::json::array();  // add_estimate
  std::array<uint64_t, SPM_COUNTERS> stream_counters_{};
  uint64_t iterations_ = 0, volume_records_ = 0, surface_records_ = 0, camera_samples_ = 0, sphere_tests_ = 0;
  std::map<std::string, double> values_;
};

void print_kernel_table(std::ostream& out, const std::map<std::string, KernelTimes>& times);

}  // namespace spm
