// Per-kernel device times from the profiling events of every labelled launch.
#pragma once

#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "device/device.h"

namespace spm {

struct KernelTimes {
  size_t launches = 0;
  double total_ms = 0.0;  // device time, START to END
  double min_ms = 0.0;
  double max_ms = 0.0;
  double queued_ms = 0.0;  // QUEUED to START, summed
  size_t work_items = 0;   // launched (padded)
  size_t items = 0;        // that had work
};

// Waits for the launches and sums them by label.
std::map<std::string, KernelTimes> kernel_times(const std::vector<Launch>& launches);

void print_kernel_table(std::ostream& out, const std::map<std::string, KernelTimes>& times);

}  // namespace spm
