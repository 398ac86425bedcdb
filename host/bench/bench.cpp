#include "bench/bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "render/render.h"
#include "scene/loader.h"
#include "util/errors.h"
#include "util/text_file.h"

namespace spm {

namespace {

struct Case {
  const char* name;
  int streams;
  int associated;
};

// The paper's Fig. 3 configurations (METHOD.md 8).
constexpr Case kSuite[] = {{"fig3a", 1000, 10}, {"fig3b", 10000, 100}};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

std::vector<BenchRow> run_bench(Device& device, const BenchOptions& o) {
  if (o.repeat < 1) throw InputError("--repeat", "must be at least 1");
  const std::string path = o.scenes_dir + "/cornell_fog.xml";
  std::vector<BenchRow> rows;
  for (const Case& c : kSuite) {
    Scene scene = load_scene(path, {{"res", std::to_string(o.resolution)}, {"spp", std::to_string(o.spp)}});
    scene.integrator.streams = c.streams;
    scene.integrator.associated = c.associated;
    RenderSettings settings;
    settings.passes = 1;
    std::vector<double> propagate, grid, gather, total;
    for (int i = 0; i <= o.repeat; ++i) {
      RenderStats st;
      render(scene, settings, device, &st);
      if (i == 0) continue;  // warm-up: programs loaded, caches filled
      propagate.push_back(st.propagate_seconds);
      grid.push_back(st.grid_seconds);
      gather.push_back(st.gather_seconds);
      total.push_back(st.seconds);
    }
    BenchRow row;
    row.name = c.name;
    row.streams = c.streams;
    row.associated = c.associated;
    row.propagate = median(propagate);
    row.grid = median(grid);
    row.gather = median(gather);
    row.total = median(total);
    rows.push_back(row);
  }
  std::printf("%-8s %8s %10s %12s %12s %12s %12s\n", "case", "streams", "associated", "propagate s", "grid s",
              "gather s", "total s");
  for (const auto& r : rows) {
    std::printf("%-8s %8d %10d %12.3f %12.3f %12.3f %12.3f\n", r.name.c_str(), r.streams, r.associated, r.propagate,
                r.grid, r.gather, r.total);
  }
  if (!o.csv.empty()) {
    std::ostringstream csv;
    csv << "case,streams,associated,propagate_s,grid_s,gather_s,total_s\n";
    for (const auto& r : rows) {
      csv << r.name << "," << r.streams << "," << r.associated << "," << r.propagate << "," << r.grid << ","
          << r.gather << "," << r.total << "\n";
    }
    write_text(o.csv, csv.str());
  }
  return rows;
}

}  // namespace spm
