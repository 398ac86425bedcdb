// spm bench: a fixed suite of renders of the paper's scene, timed stage by
// stage and kernel by kernel: medians of several in-process repetitions after
// a warm-up (programs loaded, caches filled).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "device/device.h"

namespace spm {

struct BenchOptions {
  std::string scenes_dir = "scenes";
  int repeat = 5;
  int resolution = 512;
  int spp = 4;
  bool quick = false;     // Fig. 3 (a) and (b) only
  std::vector<std::string> cases;  // only these cases; empty: all
  std::string csv, json;  // also write the results here when not empty
};

struct BenchCase {
  std::string name;
  int streams = 0, associated = 0;
  // Medians over the repetitions, seconds.
  double propagate = 0, grid = 0, gather = 0, total = 0;
  std::map<std::string, double> kernel_ms;  // median device time per kernel label
  std::map<std::string, double> kernel_occupancy;  // items with work / launched work-items, last repetition
  std::vector<uint32_t> live;               // wavefront occupancy of the last repetition
  uint64_t volume_records = 0, surface_records = 0;
};

std::vector<BenchCase> run_bench(Device& device, const BenchOptions& options);

}  // namespace spm
