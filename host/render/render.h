// A progressive render: independent passes (METHOD.md 6), each keyed only by
// (seed, pass), averaged in pass order into the image.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "device/device.h"
#include "film/image_io.h"
#include "scene/scene.h"
#include "spm/streams.h"

namespace spm {

struct RenderSettings {
  int width = 0;  // 0: the scene's film size
  int height = 0;
  int spp = 0;     // 0: the scene's sampler sample_count
  int passes = 0;  // 0: the integrator's `passes`, or as many as its `time` allows
  uint32_t seed = 0;
  int max_depth = 0;  // 0: the integrator's `max_depth`
  std::string dump_maps;     // PLY prefix for the first pass's photon maps; empty: none
  size_t memory_budget = 0;  // device bytes for a batch of streams; 0: from the device
};

struct RenderStats {
  int passes = 0;
  double seconds = 0.0;         // wall clock of the passes
  double bvh_seconds = 0.0;
  double build_seconds = 0.0;   // kernel program builds
  double propagate_seconds = 0.0;  // stream propagation incl. map downloads and sorting, all passes
  double grid_seconds = 0.0;       // sphere grid builds on the host, all passes
  double gather_seconds = 0.0;     // grid uploads, gather kernel and film download, all passes
  uint64_t camera_samples = 0;  // gather samples, all passes
  uint64_t sphere_tests = 0;    // volume records examined by the beam estimates
};

// Called after each finished pass with (passes done, passes in total), the
// total 0 when the render runs for a time budget.
using Progress = std::function<void(int, int)>;

// Largest max_depth a camera path may use: its events must fit the 256 the
// gather kernel gives each sample (kernels/spm_gather.cl).
constexpr int kMaxDepthLimit = 60;

// Validates settings and the scene's integrator (command-line overrides
// already applied to it) and fills the zeros from the scene; throws
// InputError for values out of range.
RenderSettings resolve_settings(const Scene& scene, RenderSettings s);

// Search radius of pass `pass` (from 0) for initial radius r0 (METHOD.md 6).
float pass_radius(float r0, float alpha, int pass);

// The stream propagation settings of pass `pass`.
StreamSettings stream_settings(const Scene& scene, const RenderSettings& settings, int pass);

Image render(const Scene& scene, const RenderSettings& settings, Device& device, RenderStats* stats = nullptr,
             const Progress& progress = {});

}  // namespace spm
