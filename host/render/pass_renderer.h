// One device's share of a render: the scene uploaded once, the stream propagator
// and gather kernel kept across passes, and one pass at a time rendered to a
// float image (METHOD.md 6: a pass is a full emit, propagate, grid, gather).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "device/device.h"
#include "profile/profile.h"
#include "render/defaults.h"
#include "render/error_model.h"
#include "render/render.h"
#include "scene/gpu_scene.h"
#include "spm/gather.h"
#include "spm/propagate.h"
#include "spm/wall_images.h"
#include "util/timer.h"

namespace spm {

struct PassOutput {
  std::vector<float> rgb;  // pixels x 3, mean of the pass's samples
  // The error probe's difference, pixels x 3 (render/error_model.h); empty
  // when the pass has none.
  std::vector<float> probe;
  float radius = 0.0f;  // the pass's radius
  PassCounters counters;
  double propagate_seconds = 0.0, grid_seconds = 0.0, gather_seconds = 0.0, probe_seconds = 0.0;
};

class PassRenderer {
 public:
  // `settings` as resolve_settings returned them. `scene` may have no
  // radius yet: then pilot(), derive_scale and set_scene come first.
  PassRenderer(Device& device, const Scene& scene, const SceneTables& tables, const RenderSettings& settings);

  // The scale pilot, a pass of the leaders alone on this renderer's scene
  // upload and propagator (render/defaults.h, ScalePilot).
  ScalePilot pilot();

  // The scene the passes render from now on: `scene` as derive_scale and
  // sized_for_budget made it from the one the renderer was made with (the
  // same but for its radius, width and streams). Kept by reference.
  void set_scene(const Scene& scene);

  // Renders pass `pass`; host stages go to `profiler` (if any) on `track`.
  PassOutput render(int pass, Profiler* profiler, int track);

  // Camera samples per pixel of the passes rendered from now on.
  void set_spp(int spp) { settings_.spp = spp; }

  // Sets the error probe's rows for the passes from now on from the time
  // the probe of `out` took in a pass of `pass_seconds` (kProbeShare).
  void balance_probe(const PassOutput& out, double pass_seconds);

  // Whether the passes from now on run the error probe (at first:
  // estimates_error); the tuning passes run it wherever they render.
  void set_probe(bool on) { probe_ = on; }

  // The next passes' camera samples are the pixels' samples first,
  // first + 1, ... of the scrambled sequence `strata` (kernels/lib/rng.h,
  // stratify2). Without it pass p's are (p / kReplicates) x spp onwards of
  // its replicate's sequence, p mod kReplicates (render/error_model.h), which
  // tiles each sequence when every pass has the same samples.
  void set_first_sample(uint32_t first, uint32_t strata) {
    first_sample_ = first;
    strata_seed_ = strata;
  }

 private:
  // Where the host stages of a pass go, and their clock.
  struct Stages {
    Profiler* profiler;
    int track;
    Timer* timer;
    double now() const;
    double lap() const;  // seconds since the last lap
    void stage(const char* name, double start) const;
  };

  // Gathers `maps` into out.rgb (added), in parts that fit the device;
  // `direct_terms`: this gather adds emission and next-event estimation;
  // `beam_radius`: the stream beams' kernel radius (METHOD.md 11).
  void gather(const PhotonMaps& maps, int pass, float radius, float volume_radius, float beam_radius, bool direct_terms,
              PassOutput& out, const Stages& stages);

  // The error probe of gather part `params`, added to `full` and `scaled` (pixels x 3).
  void run_probe(const MapGrids& grids, const SpmGatherParams& params, std::vector<float>& full,
                 std::vector<float>& scaled, PassOutput& out, const Stages& stages);

  Device& device_;
  const Scene* scene_;
  const SceneTables& tables_;
  RenderSettings settings_;
  // Whether each pass runs the error probe (estimates_error).
  bool probe_;
  int probe_rows_ = kProbeRows;  // the probe gathers every probe_rows_-th row of blocks
  GpuScene gpu_;
  StreamPropagator propagator_;
  Gather gather_;
  size_t maps_budget_ = 0;  // device bytes the maps' grids of a pass (or of each part) may take
  glm::vec3 scene_lo_{-INFINITY}, scene_hi_{INFINITY};  // the BVH's bounds: where surface queries can be
  size_t host_budget_ = 0;  // host bytes a pass's maps may hold before they are gathered (SPM_HOST_MEMORY)
  int64_t first_sample_ = -1;  // set_first_sample; -1: pass x spp
  uint32_t strata_seed_ = 0;
  cl_uint density_kernel_, estimator_, direct_;
  bool final_gather_;
  // Whether the scene has mirrors or glass, where emission chains start (spm_chain_pixels).
  bool specular_;
  float volume_radius0_ = 0.0f;  // the first pass's volume radius (derived_volume_radius)
  float caustic_volume_radius0_ = 0.0f;  // and its caustic volume radius (derived_caustic_volume_radius)
  // Whether final-gather rays aim at lights (SpmLight::aim, kGatherAim).
  bool aimed_;
  // The caustic volume radius of the pass whose radius is `radius`: it shrinks as the radius does.
  float caustic_volume_radius(float radius) const { return caustic_volume_radius0_ * radius / scene_->integrator.radius; }
  // The walls the volume records are mirrored across (the bre estimate only).
  WallImages walls_;
  bool wall_images_;
};

}  // namespace spm
