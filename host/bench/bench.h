// spm bench: a fixed suite of renders timed stage by stage, medians of
// several in-process repetitions after a warm-up (kernel programs loaded).
#pragma once

#include <string>
#include <vector>

#include "device/device.h"

namespace spm {

struct BenchOptions {
  std::string scenes_dir = "scenes";
  int repeat = 5;
  int resolution = 512;
  int spp = 4;
  std::string csv;  // write the rows here too when not empty
};

struct BenchRow {
  std::string name;
  int streams = 0, associated = 0;
  double propagate = 0, grid = 0, gather = 0, total = 0;  // medians, seconds
  size_t volume_records = 0, surface_records = 0;
};

std::vector<BenchRow> run_bench(Device& device, const BenchOptions& options);

}  // namespace spm
