#include "profile/profile.h"

#include <algorithm>
#include <cstdio>

namespace spm {

std::map<std::string, KernelTimes> kernel_times(const std::vector<Launch>& launches) {
  std::map<std::string, KernelTimes> out;
  for (const Launch& l : launches) {
    l.event.wait();
    const double queued = l.event.getProfilingInfo<CL_PROFILING_COMMAND_QUEUED>() * 1e-6;
    const double start = l.event.getProfilingInfo<CL_PROFILING_COMMAND_START>() * 1e-6;
    const double end = l.event.getProfilingInfo<CL_PROFILING_COMMAND_END>() * 1e-6;
    KernelTimes& t = out[l.label];
    const double ms = end - start;
    t.min_ms = t.launches == 0 ? ms : std::min(t.min_ms, ms);
    t.max_ms = std::max(t.max_ms, ms);
    t.total_ms += ms;
    t.queued_ms += start - queued;
    t.work_items += l.global;
    t.items += l.items;
    ++t.launches;
  }
  return out;
}

void print_kernel_table(std::ostream& out, const std::map<std::string, KernelTimes>& times) {
  char line[256];
  std::snprintf(line, sizeof line, "%-12s %8s %11s %10s %10s %10s %12s %12s\n", "kernel", "launches", "total ms",
                "mean ms", "min ms", "max ms", "queued ms", "items/s");
  out << line;
  for (const auto& [label, t] : times) {
    const double rate = t.total_ms > 0 ? t.items / (t.total_ms * 1e-3) : 0.0;
    std::snprintf(line, sizeof line, "%-12s %8zu %11.2f %10.3f %10.3f %10.3f %12.2f %12.3g\n", label.c_str(),
                  t.launches, t.total_ms, t.total_ms / t.launches, t.min_ms, t.max_ms, t.queued_ms, rate);
    out << line;
  }
}

}  // namespace spm
