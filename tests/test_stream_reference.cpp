// The stream kernels (spm_emit ... spm_respawn) against a sequential C++
// reference of each stream's life (tests/stream_reference.cpp) that draws the
// same Philox numbers: a few hundred streams in a small closed box with fog,
// a glass sphere, a mirror, a null medium boundary, an area light and a spot
// must give the same events and records, equal up to float rounding.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "scene/gpu_scene.h"
#include "scene/loader.h"
#include "spm/propagate.h"
#include "stream_reference.h"
#include "test_support.h"

namespace {

// A closed 10-unit box (one red wall) with a fog cube inside behind a null
// boundary (RGB sigma_t, RGB albedo, HG g = 0.5), a glass sphere in the fog,
// a one-sided mirror between the fog and the back wall, a square area light
// under the ceiling and a spot aimed at the sphere (volumetric caustic).
const char* kSceneXml = R"(<scene version="3.0.0">
  <medium type="homogeneous" id="fog">
    <rgb name="sigma_t" value="0.15, 0.25, 0.4"/>
    <rgb name="albedo" value="0.9, 0.7, 0.5"/>
    <phase type="hg"><float name="g" value="0.5"/></phase>
  </medium>
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="0, 0, 4.8" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>
  </sensor>
  <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
  <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.15, 0.1"/></bsdf>

  <shape type="rectangle">  <!-- floor -->
    <transform name="to_world"><scale value="5"/><rotate x="1" angle="-90"/><translate y="-5"/></transform>
    <ref id="white"/>
  </shape>
  <shape type="rectangle">  <!-- ceiling -->
    <transform name="to_world"><scale value="5"/><rotate x="1" angle="90"/><translate y="5"/></transform>
    <ref id="white"/>
  </shape>
  <shape type="rectangle">  <!-- back -->
    <transform name="to_world"><scale value="5"/><translate z="-5"/></transform>
    <ref id="white"/>
  </shape>
  <shape type="rectangle">  <!-- front -->
    <transform name="to_world"><scale value="5"/><rotate y="1" angle="180"/><translate z="5"/></transform>
    <ref id="white"/>
  </shape>
  <shape type="rectangle">  <!-- left, red -->
    <transform name="to_world"><scale value="5"/><rotate y="1" angle="90"/><translate x="-5"/></transform>
    <ref id="red"/>
  </shape>
  <shape type="rectangle">  <!-- right -->
    <transform name="to_world"><scale value="5"/><rotate y="1" angle="-90"/><translate x="5"/></transform>
    <ref id="white"/>
  </shape>

  <shape type="cube">  <!-- the fog's boundary -->
    <transform name="to_world"><scale x="4" y="3.75" z="4"/><translate y="-0.75"/></transform>
    <bsdf type="null"/>
    <ref name="interior" id="fog"/>
  </shape>
  <shape type="sphere">
    <point name="center" x="1.5" y="-2.5" z="0.5"/>
    <float name="radius" value="1.2"/>
    <bsdf type="dielectric"><float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/></bsdf>
    <ref name="exterior" id="fog"/>
  </shape>
  <shape type="rectangle">  <!-- mirror facing the fog, its black back to the back wall -->
    <transform name="to_world"><scale value="2"/><translate z="-4.5"/></transform>
    <bsdf type="conductor"/>
  </shape>

  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="90"/><translate x="-1.5" y="4.9"/></transform>
    <emitter type="area"><rgb name="radiance" value="10, 10, 10"/></emitter>
  </shape>
  <emitter type="spot">
    <rgb name="intensity" value="400"/>
    <float name="cutoff_angle" value="15"/>
    <float name="beam_width" value="10"/>
    <transform name="to_world"><lookat origin="2, 4.5, 0.5" target="1.5, -2.5, 0.5" up="0, 0, 1"/></transform>
  </emitter>
</scene>)";

// Records and final states must agree up to float rounding. How far rounding
// can move a record depends on the stream: refraction at a grazing angle in
// the glass sphere amplifies direction errors, and a spot's falloff near its
// cutoff angle is a difference of nearly equal angles. So the reference runs
// every stream twice, plainly and with every sqrt/exp/log/sin/cos/acos result
// moved by kProbeUlps ulps (what another math library, such as the device's,
// may return), and each quantity's allowed deviation is
//   kFloor + kConditionFactor * |plain - moved| (relative, see *_error).
// Measured on PoCL over 13 seeds x 2 march steps x 300 streams: the largest
// deviations were 6.5e-4 (positions after grazing refractions) and 3.3e-3
// (the flux of a stream emitted at the spot's rim), both within 10x their
// probe's movement; streams the probe barely moved deviated by <= 4e-5; no
// quantity used more than 0.4 of its allowance. kFloor = 2e-4 and
// kConditionFactor = 10 leave room for a device with less accurate math
// (up to 4 ulps), yet a wrong formula, factor, lane or branch moves records
// by far more: making the deposit disk 1% wider fails most streams.
constexpr int kProbeUlps = 2;
constexpr double kFloor = 2e-4;
constexpr double kConditionFactor = 10.0;

// Streams with a decision within this of its threshold may legitimately
// branch differently on the device (see StreamResult::margin) and are set
// aside, as are streams whose probe run (above) branched differently; at
// most kMaxExcludedFraction of them.
constexpr float kDecisionMargin = 1e-5f;
constexpr double kMaxExcludedFraction = 0.02;

// |a - b| relative to the vector's magnitude (at least 1 scene unit):
// positions, unit directions and normals.
double vector_error(const float* a, const float* b) {
  double scale = 1.0, err = 0.0;
  for (int k = 0; k < 3; ++k) scale = std::max({scale, double(std::fabs(a[k])), double(std::fabs(b[k]))});
  for (int k = 0; k < 3; ++k) err = std::max(err, std::fabs(double(a[k]) - double(b[k])));
  return err / scale;
}

// |a - b| relative per channel: flux.
double flux_error(const float* a, const float* b) {
  double err = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double scale = std::max(std::fabs(a[k]), std::fabs(b[k]));
    if (scale > 0) err = std::max(err, std::fabs(double(a[k]) - double(b[k])) / scale);
  }
  return err;
}

std::string str3(const float* v) {
  std::ostringstream s;
  s.precision(9);
  s << "(" << v[0] << ", " << v[1] << ", " << v[2] << ")";
  return s.str();
}

// One stream's records and final state, from the device or the reference.
struct StreamView {
  const SpmVolumeRecord* volume = nullptr;
  size_t volume_count = 0;
  const SpmSurfaceRecord* surface = nullptr;
  size_t surface_count = 0;
  uint32_t alive = 0, events = 0, end = 0;
  float phi[3] = {0, 0, 0};
};

StreamView view(const spm::ref::StreamResult& r) {
  StreamView v{r.volume.data(), r.volume.size(), r.surface.data(), r.surface.size(), r.alive, r.events, spm::ref::end_code(r.end)};
  std::copy(r.phi, r.phi + 3, v.phi);
  return v;
}

// Same events in the same order with the same outcomes (everything discrete).
std::string branch_difference(const StreamView& a, const StreamView& b) {
  std::ostringstream why;
  if (a.volume_count != b.volume_count) why << "volume records " << a.volume_count << " vs " << b.volume_count << "; ";
  if (a.surface_count != b.surface_count)
    why << "surface records " << a.surface_count << " vs " << b.surface_count << "; ";
  for (size_t i = 0; i < std::min(a.volume_count, b.volume_count); ++i) {
    const SpmVolumeRecord &x = a.volume[i], &y = b.volume[i];
    if (x.stream != y.stream || x.depth != y.depth || x.medium != y.medium || x.flags != y.flags) {
      why << "volume record " << i << ": depth " << x.depth << " medium " << x.medium << " flags " << x.flags
          << " vs depth " << y.depth << " medium " << y.medium << " flags " << y.flags << "; ";
      break;
    }
  }
  for (size_t i = 0; i < std::min(a.surface_count, b.surface_count); ++i) {
    const SpmSurfaceRecord &x = a.surface[i], &y = b.surface[i];
    if (x.stream != y.stream || x.depth_photon != y.depth_photon || x.flags != y.flags) {
      why << "surface record " << i << ": depth " << (x.depth_photon >> 16) << " photon " << (x.depth_photon & 0xffff)
          << " flags " << x.flags << " vs depth " << (y.depth_photon >> 16) << " photon " << (y.depth_photon & 0xffff)
          << " flags " << y.flags << "; ";
      break;
    }
  }
  if (a.alive != b.alive || a.events != b.events || a.end != b.end) {
    why << "final alive " << a.alive << " events " << a.events << " end " << a.end << " vs alive " << b.alive
        << " events " << b.events << " end " << b.end << "; ";
  }
  return why.str();
}

// The continuous quantities of a stream, in a fixed order.
enum class Kind { Position, Direction, Flux };
struct Quantity {
  Kind kind;
  const float* v;
  std::string what;
};

std::vector<Quantity> quantities(const StreamView& s) {
  std::vector<Quantity> q;
  for (size_t i = 0; i < s.volume_count; ++i) {
    const SpmVolumeRecord& r = s.volume[i];
    const std::string at = "volume record of depth " + std::to_string(r.depth) + ": ";
    q.push_back({Kind::Position, r.position, at + "position"});
    q.push_back({Kind::Direction, r.direction, at + "direction"});
    q.push_back({Kind::Flux, r.flux, at + "flux"});
  }
  for (size_t i = 0; i < s.surface_count; ++i) {
    const SpmSurfaceRecord& r = s.surface[i];
    const std::string at = "surface record of depth " + std::to_string(r.depth_photon >> 16) + " photon " +
                           std::to_string(r.depth_photon & 0xffff) + ": ";
    q.push_back({Kind::Position, r.position, at + "position"});
    q.push_back({Kind::Direction, r.direction, at + "direction"});
    q.push_back({Kind::Direction, r.normal, at + "normal"});
    q.push_back({Kind::Flux, r.flux, at + "flux"});
  }
  q.push_back({Kind::Flux, s.phi, "final phi"});
  return q;
}

double error(Kind kind, const float* a, const float* b) {
  return kind == Kind::Flux ? flux_error(a, b) : vector_error(a, b);
}

struct Deviation {
  double largest[3] = {0, 0, 0};  // per Kind: device against the plain reference
  double worst_ratio = 0;         // largest deviation / allowed
};

// Compares the device's stream with the plain reference, each quantity within
// its allowance from the probe run; returns "" when they match.
std::string compare_stream(const StreamView& device, const StreamView& ref, const StreamView& probe, Deviation& dev) {
  const std::string branches = branch_difference(device, ref);
  if (!branches.empty()) return "device vs reference: " + branches;
  const std::vector<Quantity> d = quantities(device), r = quantities(ref), p = quantities(probe);
  for (size_t i = 0; i < d.size(); ++i) {
    const double e = error(d[i].kind, d[i].v, r[i].v);
    const double allowed = kFloor + kConditionFactor * error(r[i].kind, p[i].v, r[i].v);
    double& largest = dev.largest[static_cast<int>(d[i].kind)];
    largest = std::max(largest, e);
    dev.worst_ratio = std::max(dev.worst_ratio, e / allowed);
    if (e > allowed) {
      std::ostringstream why;
      why << d[i].what << ": device " << str3(d[i].v) << ", reference " << str3(r[i].v) << ", probe " << str3(p[i].v)
          << " (deviation " << e << ", allowed " << allowed << ")";
      return why.str();
    }
  }
  return "";
}

// The device's final state of every stream of the (single) batch.
struct DeviceState {
  std::vector<cl_uint> id, alive, events, end;
  std::vector<cl_float4> phi;
};

struct DeviceRun {
  spm::PhotonMaps maps;
  DeviceState state;
};

DeviceRun run_device(const spm::SceneTables& tables, const spm::StreamSettings& settings) {
  spm::Device& device = spm::test::device();
  const spm::GpuScene gpu(device, tables);
  DeviceRun run;
  run.maps = spm::propagate_streams(device, gpu, settings);

  // The same pass again step by step, to read the streams' final state.
  spm::StreamPropagator propagator(device, gpu, settings);
  if (propagator.batch_capacity() < settings.streams) {
    ADD_FAILURE() << "the test expects one batch; capacity " << propagator.batch_capacity();
    return run;
  }
  spm::PhotonMaps again;
  propagator.run_batch(0, settings.streams, again);
  const spm::StreamState& st = propagator.state();
  const size_t n = settings.streams;
  run.state.id = device.download<cl_uint>(st.id, n);
  run.state.alive = device.download<cl_uint>(st.alive, n);
  run.state.events = device.download<cl_uint>(st.events, n);
  run.state.end = device.download<cl_uint>(st.end, n);
  run.state.phi = device.download<cl_float4>(st.phi, n);

  // Same seed, same device: the two runs are bit-identical (METHOD.md 7).
  EXPECT_EQ(again.volume.size(), run.maps.volume.size());
  EXPECT_EQ(again.surface.size(), run.maps.surface.size());
  std::sort(again.volume.begin(), again.volume.end(), [](const SpmVolumeRecord& a, const SpmVolumeRecord& b) {
    return std::tie(a.stream, a.depth) < std::tie(b.stream, b.depth);
  });
  std::sort(again.surface.begin(), again.surface.end(), [](const SpmSurfaceRecord& a, const SpmSurfaceRecord& b) {
    return std::tie(a.stream, a.depth_photon) < std::tie(b.stream, b.depth_photon);
  });
  if (again.volume.size() == run.maps.volume.size()) {
    EXPECT_EQ(0,
              std::memcmp(again.volume.data(), run.maps.volume.data(), sizeof(SpmVolumeRecord) * again.volume.size()));
  }
  if (again.surface.size() == run.maps.surface.size()) {
    EXPECT_EQ(
        0, std::memcmp(again.surface.data(), run.maps.surface.data(), sizeof(SpmSurfaceRecord) * again.surface.size()));
  }
  return run;
}

// What the compared (not excluded) streams exercised.
struct Coverage {
  size_t streams = 0, volume = 0, surface_first = 0, surface_later = 0;
  size_t collapsed = 0, collapsed_deposits = 0, collapsed_medium = 0;
  size_t null_crossings = 0, mirror = 0, fresnel_reflect = 0, fresnel_refract = 0, black = 0, escaped = 0, capped = 0;
  size_t max_bounces = 0, absorbed = 0, roulette = 0, refills = 0;
  size_t light[2] = {0, 0};
};

void compare_pass(float march_step) {
  const spm::Scene scene = spm::load_scene_string(kSceneXml, "stream_reference.xml");
  const spm::SceneTables tables = spm::flatten_scene(scene, 8, 8);
  ASSERT_EQ(tables.lights.size(), 2u);
  ASSERT_EQ(tables.media.size(), 1u);

  spm::StreamSettings settings;
  settings.streams = 300;
  settings.associated = 8;
  settings.stream_width = 0.5f;
  settings.max_bounces = 4;
  settings.rr_depth = 2;  // roulette, and its refills, within the four bounces
  settings.march_step = march_step;
  settings.seed = 1234;
  settings.pass = 3;

  const DeviceRun run = run_device(tables, settings);
  if (::testing::Test::HasFatalFailure()) return;
  const auto& maps = run.maps;
  ASSERT_EQ(run.state.id.size(), settings.streams);
  for (uint32_t i = 0; i < settings.streams; ++i) ASSERT_EQ(run.state.id[i], i);  // slot = stream id

  Deviation dev;
  Coverage cov;
  std::vector<std::string> mismatches;
  std::vector<std::string> excluded;
  uint64_t ref_counts[SPM_COUNTERS] = {};
  uint64_t slack = 0;  // events and records of excluded streams, for the counter totals
  size_t v = 0, s = 0;
  for (uint32_t id = 0; id < settings.streams; ++id) {
    StreamView device;
    device.volume = maps.volume.data() + v;
    device.surface = maps.surface.data() + s;
    while (v < maps.volume.size() && maps.volume[v].stream == id) ++v, ++device.volume_count;
    while (s < maps.surface.size() && maps.surface[s].stream == id) ++s, ++device.surface_count;
    device.alive = run.state.alive[id];
    device.events = run.state.events[id];
    device.end = run.state.end[id];
    std::copy(run.state.phi[id].s, run.state.phi[id].s + 3, device.phi);

    const spm::ref::StreamResult ref = spm::ref::trace_stream(tables, settings, id);
    const spm::ref::StreamResult probe = spm::ref::trace_stream(tables, settings, id, kProbeUlps);
    ref_counts[SPM_COUNT_VOLUME] += ref.volume.size();
    ref_counts[SPM_COUNT_SURFACE] += ref.surface.size();
    ref_counts[SPM_COUNT_EV_MEDIUM] += ref.medium_events;
    ref_counts[SPM_COUNT_EV_DIFFUSE] += ref.diffuse_events;
    ref_counts[SPM_COUNT_EV_SPECULAR] += ref.specular_events;
    ref_counts[SPM_COUNT_EV_NULL] += ref.null_events;
    ref_counts[SPM_COUNT_EV_ESCAPE] += ref.escape_events;
    ref_counts[SPM_COUNT_EV_BLACK] += ref.black_events;
    ref_counts[SPM_COUNT_CAPPED] += ref.capped;

    // A close decision: the device may legitimately have branched otherwise.
    std::string close;
    if (ref.margin < kDecisionMargin) {
      std::ostringstream e;
      e << ref.margin_what << " at event " << ref.margin_event << ", margin " << ref.margin;
      close = e.str();
    } else if (const std::string b = branch_difference(view(probe), view(ref)); !b.empty()) {
      close = "the probe run branched otherwise: " + b;
    }
    Deviation stream_dev;
    const std::string why = compare_stream(device, view(ref), view(probe), stream_dev);
    if (!close.empty()) {
      excluded.push_back("stream " + std::to_string(id) + ": " + close +
                         (why.empty() ? " (matched anyway)" : " (differs: " + why + ")"));
      slack += std::max<uint64_t>(ref.events, device.events) * (settings.associated + 1);
      continue;
    }
    if (!why.empty()) {
      std::ostringstream e;
      e << "stream " << id << " (smallest margin " << ref.margin << ": " << ref.margin_what << " at event "
        << ref.margin_event << "): " << why;
      mismatches.push_back(e.str());
      continue;
    }
    for (int k = 0; k < 3; ++k) dev.largest[k] = std::max(dev.largest[k], stream_dev.largest[k]);
    dev.worst_ratio = std::max(dev.worst_ratio, stream_dev.worst_ratio);
    ++cov.streams;
    cov.volume += ref.volume.size();
    for (const SpmSurfaceRecord& r : ref.surface) {
      ++((r.flags & SPM_RECORD_HAD_EVENT) ? cov.surface_later : cov.surface_first);
    }
    cov.collapsed += ref.collapsed;
    cov.collapsed_deposits += ref.collapsed_deposits;
    cov.collapsed_medium += ref.collapsed_medium_events;
    cov.null_crossings += ref.null_events;
    cov.mirror += ref.specular_events - ref.fresnel_reflections - ref.fresnel_refractions;
    cov.fresnel_reflect += ref.fresnel_reflections;
    cov.fresnel_refract += ref.fresnel_refractions;
    cov.black += ref.black_events;
    cov.escaped += ref.escape_events;
    cov.capped += ref.capped;
    cov.max_bounces += ref.end == spm::ref::StreamEnd::MaxBounces;
    cov.absorbed += ref.end == spm::ref::StreamEnd::Absorbed;
    cov.roulette += ref.roulette;
    cov.refills += ref.refills;
    ++cov.light[std::min(ref.light, 1u)];
  }
  EXPECT_EQ(v, maps.volume.size()) << "volume records of streams outside the pass";
  EXPECT_EQ(s, maps.surface.size()) << "surface records of streams outside the pass";

  std::cout << "march_step " << march_step << ": " << settings.streams << " streams, " << maps.volume.size()
            << " volume and " << maps.surface.size() << " surface records, " << excluded.size()
            << " excluded; largest deviation: position " << dev.largest[0] << ", direction " << dev.largest[1]
            << ", flux " << dev.largest[2] << "; at most " << dev.worst_ratio << " of the allowance\n";
  for (const std::string& e : excluded) std::cout << "  excluded " << e << "\n";
  std::cout << "  compared " << cov.streams << " streams: " << cov.volume << " volume records, " << cov.surface_first
            << " + " << cov.surface_later << " surface records (first event / later), " << cov.collapsed
            << " collapsed streams (" << cov.collapsed_deposits << " deposits, " << cov.collapsed_medium
            << " medium events after the collapse), " << cov.null_crossings << " null crossings, " << cov.mirror
            << " mirror and " << cov.fresnel_reflect << " + " << cov.fresnel_refract
            << " glass reflections + refractions, " << cov.black << " black ends, " << cov.escaped << " escapes, "
            << cov.capped << " capped, " << cov.max_bounces << " at max_bounces, " << cov.absorbed
            << " absorbed, " << cov.roulette << " ended by roulette, " << cov.refills
            << " refilled; from the area light " << cov.light[0] << ", the spot " << cov.light[1] << "\n";

  EXPECT_TRUE(mismatches.empty()) << mismatches.size() << " streams differ, first: " << mismatches.front()
                                  << (mismatches.size() > 1 ? "\nsecond: " + mismatches[1] : std::string());
  EXPECT_LT(double(excluded.size()), kMaxExcludedFraction * settings.streams);

  // The device's event counters agree with the reference's (exactly when no
  // stream was set aside).
  for (int k : {SPM_COUNT_VOLUME, SPM_COUNT_SURFACE, SPM_COUNT_EV_MEDIUM, SPM_COUNT_EV_DIFFUSE, SPM_COUNT_EV_SPECULAR,
                SPM_COUNT_EV_NULL, SPM_COUNT_EV_ESCAPE, SPM_COUNT_EV_BLACK, SPM_COUNT_CAPPED}) {
    const uint64_t d = maps.stats.counters[k], r = ref_counts[k];
    EXPECT_LE(d > r ? d - r : r - d, slack) << "counter " << k << ": device " << d << ", reference " << r;
  }
  EXPECT_EQ(maps.stats.counters[SPM_COUNT_ERRORS], 0u);

  // Every kind of event took part in the comparison.
  EXPECT_GT(cov.streams, settings.streams * 9 / 10);
  EXPECT_GT(cov.volume, 0u) << "no medium records";
  EXPECT_GT(cov.surface_first, 0u) << "no surface records of streams without a previous event";
  EXPECT_GT(cov.surface_later, 0u) << "no surface records of streams with a previous event";
  EXPECT_GT(cov.collapsed, 0u) << "no collapsed streams";
  EXPECT_GT(cov.collapsed_deposits, 0u) << "no collapsed stream deposited";
  EXPECT_GT(cov.collapsed_medium, 0u) << "no collapsed stream scattered in the medium";
  EXPECT_GT(cov.null_crossings, 0u);
  EXPECT_GT(cov.mirror, 0u);
  EXPECT_GT(cov.fresnel_reflect, 0u);
  EXPECT_GT(cov.fresnel_refract, 0u);
  EXPECT_GT(cov.max_bounces, 0u);
  EXPECT_GT(cov.absorbed, 0u);
  EXPECT_GT(cov.roulette, 0u);
  EXPECT_GT(cov.refills, 0u);
  EXPECT_GT(cov.light[0], 0u);
  EXPECT_GT(cov.light[1], 0u);
}

TEST(StreamReference, ExactFreeFlight) { compare_pass(0.0f); }

TEST(StreamReference, MarchedFreeFlight) { compare_pass(0.7f); }

}  // namespace
