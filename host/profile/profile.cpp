#include "profile/profile.h"

#include <algorithm>
#include <cstdio>
#include "util/text_file.h"

namespace spm {

Profiler::Profiler(bool trace) : trace_(trace), start_(std::chrono::steady_clock::now()) {}

double Profiler::now() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Profiler::stage(const std::string& name, double start, double end, int track) {
  std::lock_guard<std::mutex> lock(mutex_);
  values_[name + "_s"] += end - start;
  if (trace_) events_.push_back({name, 0, track, start * 1e6, (end - start) * 1e6});
}

void Profiler::add_device(int device, const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  devices_[device] = name;
}

void Profiler::add_value(const std::string& key, double value) {
  std::lock_guard<std::mutex> lock(mutex_);
  values_[key] = value;
}

void Profiler::add_launches(int device, std::vector<Launch> launches) {
  for (const Launch& l : launches) l.event.wait();
  std::lock_guard<std::mutex> lock(mutex_);
  for (const Launch& l : launches) {
    const double queued = l.event.getProfilingInfo<CL_PROFILING_COMMAND_QUEUED>() * 1e-3;  // us
    const double start = l.event.getProfilingInfo<CL_PROFILING_COMMAND_START>() * 1e-3;
    const double end = l.event.getProfilingInfo<CL_PROFILING_COMMAND_END>() * 1e-3;
    KernelTimes& t = kernels_[l.label];
    const double ms = (end - start) * 1e-3;
    t.min_ms = t.launches == 0 ? ms : std::min(t.min_ms, ms);
    t.max_ms = std::max(t.max_ms, ms);
    t.total_ms += ms;
    t.queued_ms += (start - queued) * 1e-3;
    t.work_items += l.global;
    t.items += l.items;
    ++t.launches;
    if (!trace_) continue;
    // The device clock is placed on the host's by the first command's enqueue
    // time, once per device, so that its events keep their order and spacing.
    const double enqueued_us = std::chrono::duration<double, std::micro>(l.enqueued - start_).count();
    const auto offset = device_offset_us_.emplace(device, enqueued_us - queued).first->second;
    events_.push_back({l.label, device + 1, 0, start + offset, end - start});
  }
}

void Profiler::add_pass(int device, int pass, const PassCounters& c) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (int k = 0; k < SPM_COUNTERS; ++k) stream_counters_[k] += c.stream_counters[k];
  iterations_ += c.live.size();
  volume_records_ += c.volume_records;
  surface_records_ += c.surface_records;
  camera_samples_ += c.camera_samples;
  sphere_tests_ += c.sphere_tests;
  passes_.push_back({{"pass", pass},
                     {"device", device},
                     {"live_per_iteration", c.live},
                     {"volume_records", c.volume_records},
                     {"surface_records", c.surface_records},
                     {"camera_samples", c.camera_samples},
                     {"map_parts", c.map_parts},
                     {"host_parts", c.host_parts}});
}

void Profiler::add_estimate(const ErrorEstimate& e, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json j = {{"passes", e.passes}, {"seconds", seconds}};
  if (e.relmse >= 0.0) {
    j["relmse"] = e.relmse;
    j["variance"] = e.variance;
    j["bias"] = e.bias;
  }
  estimates_.push_back(j);
}

std::map<std::string, KernelTimes> Profiler::kernels() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return kernels_;
}

nlohmann::json Profiler::json() const {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json j;
  j["schema"] = "spm-profile/1";
  j["devices"] = nlohmann::json::array();
  for (const auto& [index, name] : devices_) j["devices"].push_back({{"index", index}, {"name", name}});
  j["kernels"] = nlohmann::json::object();
  for (const auto& [label, t] : kernels_) {
    j["kernels"][label] = {{"launches", t.launches},
                           {"total_ms", t.total_ms},
                           {"mean_ms", t.launches ? t.total_ms / t.launches : 0.0},
                           {"min_ms", t.min_ms},
                           {"max_ms", t.max_ms},
                           {"queued_ms", t.queued_ms},
                           {"work_items", t.work_items},
                           {"items", t.items},
                           {"occupancy", t.work_items ? double(t.items) / t.work_items : 0.0},
                           {"items_per_second", t.total_ms > 0 ? t.items / (t.total_ms * 1e-3) : 0.0}};
  }
  j["host"] = values_;
  const auto& c = stream_counters_;
  j["counters"] = {
      {"wavefront_iterations", iterations_},
      {"events",
       {{"medium", c[SPM_COUNT_EV_MEDIUM]},
        {"diffuse", c[SPM_COUNT_EV_DIFFUSE]},
        {"specular", c[SPM_COUNT_EV_SPECULAR]},
        {"null", c[SPM_COUNT_EV_NULL]},
        {"escape", c[SPM_COUNT_EV_ESCAPE]},
        {"black", c[SPM_COUNT_EV_BLACK]},
        {"capped", c[SPM_COUNT_CAPPED]}}},
      {"streams",
       {{"emitted", c[SPM_COUNT_STREAMS]},
        {"events_per_stream",
         c[SPM_COUNT_STREAMS] ? double(c[SPM_COUNT_EV_MEDIUM] + c[SPM_COUNT_EV_DIFFUSE] + c[SPM_COUNT_EV_SPECULAR] +
                                       c[SPM_COUNT_EV_NULL] + c[SPM_COUNT_EV_ESCAPE] + c[SPM_COUNT_EV_BLACK]) /
                                    c[SPM_COUNT_STREAMS]
                              : 0.0},
        {"ended_by_roulette", c[SPM_COUNT_END_ROULETTE]},
        {"ended_by_max_depth", c[SPM_COUNT_END_DEPTH]},
        {"ended_by_max_bounces", c[SPM_COUNT_END_BOUNCES]},
        {"ended_by_cap", c[SPM_COUNT_CAPPED]}}},
      {"records", {{"volume", volume_records_}, {"surface", surface_records_}, {"beams", c[SPM_COUNT_BEAMS]}}},
      {"gather",
       {{"camera_samples", camera_samples_},
        {"sphere_tests", sphere_tests_},
        {"sphere_tests_per_sample", camera_samples_ ? double(sphere_tests_) / camera_samples_ : 0.0}}}};
  j["passes_detail"] = passes_;
  j["error_estimate"] = estimates_;
  return j;
}

void Profiler::write_trace(const std::string& path) const {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json events = nlohmann::json::array();
  events.push_back({{"ph", "M"}, {"name", "process_name"}, {"pid", 0}, {"tid", 0}, {"args", {{"name", "host"}}}});
  for (const auto& [index, name] : devices_) {
    events.push_back({{"ph", "M"},
                      {"name", "process_name"},
                      {"pid", index + 1},
                      {"tid", 0},
                      {"args", {{"name", "device " + std::to_string(index) + ": " + name}}}});
  }
  for (const Event& e : events_) {
    events.push_back({{"name", e.name}, {"ph", "X"}, {"pid", e.pid}, {"tid", e.tid}, {"ts", e.start_us},
                      {"dur", e.dur_us}});
  }
  write_text(path, nlohmann::json{{"traceEvents", events}, {"displayTimeUnit", "ms"}}.dump());
}

void print_kernel_table(std::ostream& out, const std::map<std::string, KernelTimes>& times) {
  char line[256];
  std::snprintf(line, sizeof line, "%-10s %8s %11s %10s %10s %10s %11s %12s %10s\n", "kernel", "launches",
                "total ms", "mean ms", "min ms", "max ms", "queued ms", "items", "items/s");
  out << line;
  for (const auto& [label, t] : times) {
    const double rate = t.total_ms > 0 ? t.items / (t.total_ms * 1e-3) : 0.0;
    std::snprintf(line, sizeof line, "%-10s %8zu %11.2f %10.3f %10.3f %10.3f %11.2f %12zu %10.3g\n", label.c_str(),
                  t.launches, t.total_ms, t.total_ms / t.launches, t.min_ms, t.max_ms, t.queued_ms, t.items, rate);
    out << line;
  }
}

}  // namespace spm
