// A progressive render: independent passes (METHOD.md 6), each keyed only by
// (seed, pass), averaged in pass order into the image.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "device/device.h"
#include "film/image_io.h"
#include "scene/scene.h"
#include "profile/profile.h"
#include "render/error_model.h"
#include "render/planner.h"
#include "spm/propagate.h"

namespace spm {

struct RenderSettings {
  int width = 0;  // 0: the scene's film size
  int height = 0;
  // Camera samples per pixel in each pass; 0: samples_per_pass (defaults.h).
  int spp = 0;
  // Set by resolve_settings when it derived spp: a timed render then
  // balances each pass's samples from its passes' times (balanced_spp).
  bool spp_derived = false;
  // 0: the integrator's `passes`, or as many as its `time` allows, or enough
  // passes of `spp` for the sampler's sample_count (SCENES.md).
  int passes = 0;
  uint32_t seed = 0;
  std::string dump_maps;     // PLY prefix for the first pass's photon maps; empty: none
  uint32_t terms = SPM_TERMS_ALL;  // the gather's terms to add (SPM_TERM_*, render/terms.h)
  size_t memory_budget = 0;  // device bytes all of a render's buffers may hold at once; 0: the device's memory
  // When set, no new pass starts; the passes in flight finish (SIGINT).
  const std::atomic<bool>* stop = nullptr;
  // Whether passes run the error probe (render/error_model.h) when the
  // render has more than one; off where nothing reads the estimate.
  bool error_probe = true;
  // Set by render() once the integrator's target_error is met: no new pass starts.
  const std::atomic<bool>* target_met = nullptr;
  // Called once with the scene as it renders, every setting derived
  // (defaults.h, fill_derived), and the scale pilot's seconds: before the
  // first pass, or where the radius is planned, after the tuning passes
  // with the planned radii (render_passes).
  std::function<void(const Scene&, double)> announce;
  // Called when the error model's plan (render/planner.h) sets the radius's
  // scale: after the tuning passes, and when a later plan changes it, with
  // the passes done, the plan and the radius it gives.
  std::function<void(int, const Plan&, float)> planned;
};

struct DeviceStats {
  std::string name;
  int passes = 0;
  double busy_seconds = 0.0;  // wall clock of its passes
};

struct RenderStats {
  int passes = 0;
  bool interrupted = false;     // stopped early by RenderSettings::stop
  double seconds = 0.0;         // wall clock of the passes
  double bvh_seconds = 0.0;
  double build_seconds = 0.0;   // kernel program builds, all devices
  double pilot_seconds = 0.0;   // the scale pilot (defaults.h), before the passes
  // Summed over passes (and devices: with several, more than `seconds`).
  double propagate_seconds = 0.0;  // stream propagation incl. map downloads and sorting
  double grid_seconds = 0.0;       // record grid builds and uploads
  double gather_seconds = 0.0;     // gather kernel and film download
  double probe_seconds = 0.0;      // the error probe's gathers (render/error_model.h)
  float radius_scale = 1.0f;       // the plan's scale of the derived radii (render/planner.h)
  uint64_t camera_samples = 0;
  uint64_t sphere_tests = 0;       // volume records examined by the beam estimates
  std::vector<DeviceStats> devices;
  ErrorEstimate error;  // of the image render() returns (relmse -1: unknown)
};

// Called after each finished pass with (passes done, passes in total, the
// estimated error of the image so far), the total 0 when the render runs for
// a time budget or a target error; the estimate's relmse is -1 where unknown.
using Progress = std::function<void(int, int, const ErrorEstimate&)>;

// Validates settings and the scene's integrator (command-line overrides
// already applied to it) and fills the zeros from the scene; throws
// InputError for values out of range.
RenderSettings resolve_settings(const Scene& scene, RenderSettings s);

// Whether a render with resolved settings `s` estimates its error: it runs
// the error probe and keeps an ErrorModel (render/error_model.h). A render
// of one pass has no spread to measure.
inline bool estimates_error(const RenderSettings& s) { return s.error_probe && s.passes != 1; }

// Search radius of pass `pass` (from 0) for initial radius r0 (METHOD.md 6).
float pass_radius(float r0, float alpha, int pass);

// The stream beams' 1D kernel radius of pass `pass` for initial radius r0.
float pass_beam_radius(float r0, float alpha, int pass);

// The stream propagation settings of pass `pass`.
StreamSettings stream_settings(const Scene& scene, const RenderSettings& settings, int pass);

// A coarse estimate of a pass's length from the scale pilot's (one photon
// per stream): propagation grows with the associated photons, and the
// gather takes about twice the propagation here.
double first_pass_estimate(const Scene& scene, double pilot_seconds);

// Camera samples per pixel for a timed render's next pass, from a pass's
// photon stages (propagate and grid build) and gather seconds, the gather
// measured at `spp` samples: the gather's share of the pass at the
// measured optimum (2/3), within the pass's share of the budget, 1 to 64.
int balanced_spp(double photon_seconds, double gather_seconds, int spp, double budget);

// A timed render (settings.passes 0) whose pass would take more than a tenth
// of the budget by first_pass_estimate: the scene with fewer streams per
// pass (a derived radius grown to match) and `settings` with fewer samples
// per pass, in proportion. Any other render: the scene unchanged.
Scene sized_for_budget(const Scene& scene, RenderSettings& settings, double pilot_seconds);

// A finished pass: its image (pixels x 3), and what the error model reads
// of it (PassOutput).
struct PassImage {
  std::vector<float> rgb;
  std::vector<float> probe;
  float radius = 0.0f;
};

// Sums pass images in pass order, whatever order they arrive in, in double
// precision: the image then does not depend on which device or process
// rendered which pass (METHOD.md 6). With `estimate`, the passes summed also
// feed an ErrorModel in the same order. Not thread-safe.
class OrderedSum {
 public:
  OrderedSum(size_t values, bool estimate);
  void add(int pass, PassImage image);
  int summed() const { return summed_; }  // passes 0 .. summed - 1 are in
  Image average(int width, int height) const;
  ErrorEstimate estimate() const { return model_ ? model_->estimate() : ErrorEstimate{}; }
  ErrorTerms terms() const { return model_ ? model_->terms() : ErrorTerms{}; }

 private:
  std::vector<double> sum_;
  std::map<int, PassImage> waiting_;
  std::optional<ErrorModel> model_;
  int summed_ = 0;
};

// The passes one process renders: offset, offset + stride, ... (MPI ranks).
struct PassSlice {
  int offset = 0;
  int stride = 1;
};

// Receives each finished pass's image (pixels x 3), one call at a time, in
// no particular order.
using PassSink = std::function<void(int pass, PassImage&& image)>;

// The error model's terms of the passes sunk so far; called under the lock
// that serialises the sink's calls.
using TermsSource = std::function<ErrorTerms()>;

// Renders the passes of `slice` on every device of `devices` at once, the next
// pass going to whichever device is free; stats.passes counts the passes done.
// With `terms` (one process, an error model), the passes after the tuning
// passes follow the model's plan (render/planner.h).
RenderStats render_passes(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
                          PassSlice slice, const PassSink& sink, Profiler* profiler = nullptr,
                          const TermsSource& terms = {});

// Renders on every device of `devices` at once: the next pass goes to
// whichever device is free, and passes are summed in pass order, so the image
// does not depend on the split (METHOD.md 6-7). `profiler` may be null.
// The profile's host figures that are not timed stages: the BVH build and
// each device's program builds, program_build_s.<device>.<program> from the
// source and program_binary_s.<device>.<program> from another device's binary.
void add_build_values(Profiler& profiler, const RenderStats& stats, const std::vector<Device*>& devices);

Image render(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
             RenderStats* stats = nullptr, const Progress& progress = {}, Profiler* profiler = nullptr);

Image render(const Scene& scene, const RenderSettings& settings, Device& device, RenderStats* stats = nullptr,
             const Progress& progress = {});

}  // namespace spm
