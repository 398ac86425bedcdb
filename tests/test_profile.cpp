// The profile (--profile-json, --trace) describes the render it came from:
// valid against its schema, consistent with itself and with the maps.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "cli_support.h"

namespace {

using Profile = spm::test::CliTest;
using nlohmann::json;

using spm::test::kFogGlassScene;

json read_json(const std::string& path) {
  std::ifstream in(path);
  return json::parse(in);
}

long ply_vertices(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  std::string line;
  while (std::getline(in, line) && line != "end_header") {
    if (line.rfind("element vertex ", 0) == 0) return std::stol(line.substr(15));
  }
  return -1;
}

class ProfiledRender : public Profile {
 protected:
  void render(const std::string& extra, const std::string& streams = "--streams 300 --associated 8") {
    const std::string scene = write("s.xml", kFogGlassScene);
    const auto r = run("render " + scene + " -o " + path("o.exr") + " --res 24x16 --spp 2 " + streams + " " +
                       "--profile-json " + path("p.json") + " --trace " + path("t.json") + " " + extra);
    ASSERT_EQ(r.code, 0) << r.err;
    profile_ = read_json(path("p.json"));
  }
  json profile_;
};

TEST_F(ProfiledRender, ValidatesAgainstItsSchema) {
  render("--passes 2");
  const std::string cmd = "/usr/bin/python3 -c \"import json, jsonschema, sys; "
                          "jsonschema.validate(json.load(open(sys.argv[1])), json.load(open(sys.argv[2])))\" " +
                          path("p.json") + " " + SPM_SOURCE_DIR "/tools/profile.schema.json 2>" + path("v.txt");
  EXPECT_EQ(std::system(cmd.c_str()), 0) << std::ifstream(path("v.txt")).rdbuf();
  // And the validator does reject a profile that breaks the schema.
  json broken = profile_;
  broken["kernels"]["march"]["launches"] = -1;
  std::ofstream(path("b.json")) << broken.dump();
  const std::string bad = "/usr/bin/python3 -c \"import json, jsonschema, sys; "
                          "jsonschema.validate(json.load(open(sys.argv[1])), json.load(open(sys.argv[2])))\" " +
                          path("b.json") + " " + SPM_SOURCE_DIR "/tools/profile.schema.json 2>/dev/null";
  EXPECT_NE(std::system(bad.c_str()), 0);
}

TEST_F(ProfiledRender, KernelFiguresAreConsistent) {
  render("--passes 3");
  const json& k = profile_["kernels"];
  const json& c = profile_["counters"];
  // One march per wavefront iteration, and every step of METHOD.md 3 with
  // it; respawn also runs once after each batch's emit.
  EXPECT_EQ(k["march"]["launches"], c["wavefront_iterations"]);
  for (const char* step : {"interact", "deposit", "absorb"}) {
    EXPECT_EQ(k[step]["launches"], c["wavefront_iterations"]) << step;
  }
  EXPECT_EQ(k["emit"]["launches"], 3);  // one batch per pass here
  EXPECT_EQ(k["respawn"]["launches"], c["wavefront_iterations"].get<uint64_t>() + 3);
  // The per-photon kernels ran over one entry per record or photon.
  EXPECT_EQ(k["deposit"]["items"], c["records"]["surface"]);
  EXPECT_EQ(k["march"]["items"], k["interact"]["items"]);
  EXPECT_EQ(k["gather"]["launches"], 3);
  double kernel_ms = 0.0;
  for (const auto& [label, t] : k.items()) {
    EXPECT_LE(t["items"].get<uint64_t>(), t["work_items"].get<uint64_t>()) << label;
    EXPECT_LE(t["min_ms"].get<double>(), t["mean_ms"].get<double>()) << label;
    EXPECT_LE(t["mean_ms"].get<double>(), t["max_ms"].get<double>()) << label;
    kernel_ms += t["total_ms"].get<double>();
  }
  // One in-order queue: its commands never overlap, so they fit in the time
  // the device was busy.
  EXPECT_LE(kernel_ms, profile_["devices"][0]["busy_seconds"].get<double>() * 1e3);
  // Live streams per iteration: as many as the iterations, never growing.
  uint64_t iterations = 0;
  for (const auto& p : profile_["passes_detail"]) {
    const auto live = p["live_per_iteration"].get<std::vector<uint64_t>>();
    iterations += live.size();
    ASSERT_FALSE(live.empty());
    EXPECT_EQ(live.front(), 300u);
    for (size_t i = 1; i < live.size(); ++i) EXPECT_LE(live[i], live[i - 1]);
  }
  EXPECT_EQ(iterations, c["wavefront_iterations"].get<uint64_t>());
  EXPECT_EQ(c["gather"]["camera_samples"], 3 * 24 * 16 * 2);
}

// Each stream kernel launches over its own queue (METHOD.md 3): on a scene
// with enough streams that padding to whole work-groups is small, at least
// 90% of the work-items of deposit, absorb and respawn have a photon or a
// stream to work on, where launching over every live stream times N_a (as
// before the queues) idles deposit for every medium event and dead photon.
TEST_F(ProfiledRender, StreamKernelsLaunchOverTheirQueues) {
  render("--passes 1", "--streams 20000 --associated 32");
  const json& k = profile_["kernels"];
  for (const char* step : {"deposit", "absorb", "respawn"}) {
    const double items = k[step]["items"].get<double>(), launched = k[step]["work_items"].get<double>();
    EXPECT_GE(items, 0.9 * launched) << step << ": " << items << " of " << launched;
    EXPECT_NEAR(k[step]["occupancy"].get<double>(), items / launched, 1e-9) << step;
  }
}

TEST_F(ProfiledRender, CountersAgreeWithTheMaps) {
  render("--passes 1 --dump-maps " + path("m"));
  const json& c = profile_["counters"];
  EXPECT_EQ(c["records"]["volume"].get<long>(), ply_vertices(path("m_volume.ply")));
  EXPECT_EQ(c["records"]["surface"].get<long>(), ply_vertices(path("m_surface.ply")));
  EXPECT_EQ(c["events"]["medium"], c["records"]["volume"]);  // one record per medium event
  EXPECT_GT(c["events"]["specular"].get<long>(), 0);         // the glass sphere collapses streams
}

TEST_F(ProfiledRender, TraceIsValidAndNestsPerTrack) {
  render("--passes 2");
  const json trace = read_json(path("t.json"));
  ASSERT_TRUE(trace.contains("traceEvents"));
  std::map<std::pair<int, int>, std::vector<std::pair<double, double>>> tracks;
  std::map<int, std::string> process_names;
  for (const auto& e : trace["traceEvents"]) {
    if (e["ph"] == "M") {
      process_names[e["pid"]] = e["args"]["name"];
      continue;
    }
    ASSERT_EQ(e["ph"], "X");
    ASSERT_GE(e["dur"].get<double>(), 0.0);
    tracks[{e["pid"], e["tid"]}].push_back({e["ts"].get<double>(), e["ts"].get<double>() + e["dur"].get<double>()});
  }
  EXPECT_EQ(process_names[0], "host");
  EXPECT_EQ(process_names.count(1), 1u);  // the device queue
  EXPECT_GT(tracks[std::make_pair(1, 0)].size(), 10u);
  // Per track, an event either lies inside the enclosing open one or starts
  // after it ends (1 us of slack for rounding).
  for (auto& [track, events] : tracks) {
    std::sort(events.begin(), events.end(),
              [](const auto& a, const auto& b) { return a.first < b.first || (a.first == b.first && a.second > b.second); });
    std::vector<double> open;
    for (const auto& [start, end] : events) {
      while (!open.empty() && start >= open.back() - 1.0) open.pop_back();
      if (!open.empty()) {
        EXPECT_LE(end, open.back() + 1.0) << "track " << track.first << ":" << track.second << " overlaps";
      }
      open.push_back(end);
    }
  }
}

}  // namespace
