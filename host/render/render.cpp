#include "render/render.h"

#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>

#include "render/defaults.h"
#include "render/pass_renderer.h"
#include "render/planner.h"
#include "scene/integrator_options.h"
#include "scene/settings.h"
#include "scene/gpu_scene.h"
#include "util/errors.h"
#include "util/timer.h"

namespace spm {

RenderSettings resolve_settings(const Scene& scene, RenderSettings s) {
  if (s.width == 0) s.width = scene.camera.width;
  if (s.height == 0) s.height = scene.camera.height;
  if (s.width < 1 || s.height < 1 || s.width > 16384 || s.height > 16384) {
    throw InputError("--res", "resolution " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                                  " is outside 1x1 .. 16384x16384");
  }
  const IntegratorSettings& in = scene.integrator;
  check_settings(in, scene.path);
  if (s.spp < 0 || s.spp > 1 << 20) throw InputError("--spp", "samples per pixel must be in 1 .. 1048576");
  if (s.passes < 0) throw InputError("--passes", "the number of passes must be at least 1");
  if (s.spp == 0) s.spp = in.spp;
  if (s.seed == 0) s.seed = uint32_t(in.seed);
  // A pass count on the command line wins over a time budget; the scene's
  // own yields to it (below).
  if (s.passes == 0 && in.source("passes") == SettingSource::CommandLine) s.passes = in.passes;
  if (s.spp == 0) {
    s.spp = samples_per_pass(scene, s.width, s.height);
    s.spp_derived = true;
  }
  // A render for a time budget (integrator `time`, no pass count) or a
  // target error keeps passes = 0: it renders passes until the budget is
  // spent or the estimated error is below the target, whichever comes
  // first. Without a pass count or a budget, the sampler's sample_count is
  // the render's total samples per pixel (SCENES.md), spread over passes of
  // at most spp each.
  if (s.passes == 0 && !(in.time > 0.0f) && !(in.target_error > 0.0f)) {
    if (in.passes > 0) {
      s.passes = in.passes;
    } else {
      const int total = scene.camera.spp;
      s.spp = std::min(s.spp, total);
      s.passes = (total + s.spp - 1) / s.spp;
      s.spp = (total + s.passes - 1) / s.passes;
    }
  }
  return s;
}

StreamSettings stream_settings(const Scene& scene, const RenderSettings& s, int pass) {
  const IntegratorSettings& in = scene.integrator;
  const auto limit = [](int v) { return v < 0 ? SPM_NONE : static_cast<uint32_t>(v); };
  StreamSettings out;
  out.streams = static_cast<uint32_t>(derived_streams(in));
  out.associated = static_cast<uint32_t>(derived_associated(in));
  out.stream_width = in.stream_width;
  out.max_bounces = limit(in.max_bounces);
  out.max_depth = limit(in.max_depth);
  out.rr_depth = static_cast<uint32_t>(in.rr_depth);
  out.march_step = in.march_step;
  out.beams = kEstimatorOption.code(in.estimator) == SPM_ESTIMATOR_BEAMS;
  out.beam_streams = static_cast<uint32_t>(derived_beam_streams(in));
  out.seed = s.seed;
  out.pass = static_cast<uint32_t>(pass);
  return out;
}

float pass_radius(float r0, float alpha, int pass) {
  // r_{k+1}^2 = r_k^2 (k + alpha) / (k + 1) for passes k = 1, 2, ... (Knaus &
  // Zwicker 2011); `pass` counts from 0.
  double r2 = double(r0) * r0;
  for (int k = 1; k <= pass; ++k) r2 *= (k + double(alpha)) / (k + 1);
  return static_cast<float>(std::sqrt(r2));
}

float pass_beam_radius(float r0, float alpha, int pass) {
  // A 1D kernel's variance grows as 1/r, not 1/r^2, so the progressive rule
  // shrinks r itself by (k + alpha) / (k + 1) (progressive photon beams,
  // Jarosz et al. 2011, 4.3): the square of the 2D schedule, relative to r0.
  const float s = pass_radius(1.0f, alpha, pass);
  return r0 * s * s;
}

Image render(const Scene& scene, const RenderSettings& settings, Device& device, RenderStats* stats,
             const Progress& progress) {
  return render(scene, settings, std::vector<Device*>{&device}, stats, progress, nullptr);
}

OrderedSum::OrderedSum(size_t values, bool estimate) : sum_(values, 0.0) {
  if (estimate) model_.emplace(values);
}

void OrderedSum::add(int pass, PassImage image) {
  waiting_.emplace(pass, std::move(image));
  for (auto it = waiting_.find(summed_); it != waiting_.end(); it = waiting_.find(summed_)) {
    const PassImage& p = it->second;
    for (size_t i = 0; i < sum_.size(); ++i) sum_[i] += p.rgb[i];
    if (model_) model_->add(it->first, p.rgb, p.radius, p.probe);
    waiting_.erase(it);
    ++summed_;
  }
}

Image OrderedSum::average(int width, int height) const {
  if (summed_ == 0) throw RuntimeError("the render stopped before its first pass finished");
  Image image;
  image.width = width;
  image.height = height;
  image.rgb.resize(sum_.size());
  for (size_t i = 0; i < sum_.size(); ++i) image.rgb[i] = static_cast<float>(sum_[i] / summed_);
  return image;
}

int balanced_spp(double photon_seconds, double gather_seconds, int spp, double budget) {
  const double per_sample = gather_seconds / std::max(1, spp);
  if (!(per_sample > 0.0) || !(photon_seconds > 0.0)) return spp;
  double want = kGatherShare / (1.0 - kGatherShare) * photon_seconds / per_sample;
  // The pass must still fit its share of the budget.
  want = std::min(want, (kPassShareOfBudget * budget - photon_seconds) / per_sample);
  return static_cast<int>(std::clamp(std::lround(want), 1L, long(kMaxPassSpp)));
}

double first_pass_estimate(const Scene& scene, double pilot_seconds) {
  return kPassPerPilot * pilot_seconds * (1.0 + derived_associated(scene.integrator) / kPilotAssociated);
}

Scene sized_for_budget(const Scene& scene, RenderSettings& s, double pilot_seconds) {
  Scene out = scene;
  const double budget = scene.integrator.time;
  const double predicted = first_pass_estimate(scene, pilot_seconds);
  if (!(budget > 0.0) || s.passes > 0 || !(predicted > kPassShareOfBudget * budget)) return out;
  const double f = kPassShareOfBudget * budget / predicted;
  IntegratorSettings& in = out.integrator;
  const int streams = std::max(1, static_cast<int>(derived_streams(in) * f));
  // Fewer streams spread their records thinner: a derived radius grows as
  // the surface records' spacing does, with the inverse square root.
  const float grow = std::sqrt(float(derived_streams(in)) / float(streams));
  if (in.source("radius") == SettingSource::Derived) in.radius *= grow;
  if (in.source("width") == SettingSource::Derived) in.stream_width *= grow;
  in.streams = streams;
  in.sources["streams"] = SettingSource::Derived;
  s.spp = std::max(1, static_cast<int>(std::lround(s.spp * f)));
  return out;
}

namespace {

// One device's pass loop between calls of its `work` (render_passes): its
// clock and what it has measured of its passes.
struct DeviceLoop {
  Timer clock;
  int done = 0;
  double elapsed = 0.0, longest = 0.0;
  int spp = 0;
  // Means over the device's passes (the first left out: it also pays for
  // its kernels' first launches) and the longest parts, which predict a
  // balanced pass's length.
  int measured = 0;  // passes in the means
  double photon_seconds = 0.0, gather_seconds = 0.0, samples = 0.0;
  double longest_rest = 0.0, longest_per_sample = 0.0;
};

// kReplanPasses, twice that, four times, ...
bool replans_after(int passes) {
  const int k = passes / kReplanPasses;
  return passes % kReplanPasses == 0 && k > 0 && (k & (k - 1)) == 0;
}

bool radius_derived(const IntegratorSettings& in) { return in.source("radius") == SettingSource::Derived; }

// The scene's derived radii times `scale` (a plan's, render/planner.h):
// the radius, the stream width and the volume radius that follow it.
void scale_radii(IntegratorSettings& in, float scale) {
  in.radius *= scale;
  if (in.source("width") == SettingSource::Derived) in.stream_width *= scale;
  if (in.source("volume_radius") == SettingSource::Derived) in.volume_radius *= scale;
}

}  // namespace

RenderStats render_passes(const Scene& scene_in, const RenderSettings& settings, const std::vector<Device*>& devices,
                          PassSlice slice, const PassSink& sink, Profiler* profiler, const TermsSource& terms) {
  RenderSettings s = resolve_settings(scene_in, settings);
  const bool timed = s.passes == 0;
  // A render to a target error alone has no time budget.
  const double budget = scene_in.integrator.time > 0.0f ? double(scene_in.integrator.time) : INFINITY;
  for (Device* d : devices) d->set_memory_budget(s.memory_budget);
  const SceneTables tables = flatten_scene(scene_in, s.width, s.height);
  // Device 0's renderer first: the scale pilot is a pass of its own streams
  // (defaults.h). A timed render always runs it, whose propagation time
  // sizes its passes; a render with a radius needs no other.
  std::vector<std::unique_ptr<PassRenderer>> renderers(devices.size());
  renderers[0] = std::make_unique<PassRenderer>(*devices[0], scene_in, tables, s);
  ScalePilot pilot;
  if (scene_in.integrator.radius <= 0.0f || timed) {
    const double start = profiler ? profiler->now() : 0.0;
    pilot = renderers[0]->pilot();
    // The pilot is a host stage of its own; its launches stay out of the
    // passes' kernel figures.
    devices[0]->take_launches();
    if (profiler) profiler->stage("pilot", start, profiler->now(), 1);
  }
  Scene scene = sized_for_budget(derive_scale(scene_in, pilot), s, pilot.seconds);
  fill_derived(scene, s);
  renderers[0]->set_scene(scene);
  // A derived radius is planned (render/planner.h): the first kTuningPasses
  // passes render on device 0 alone at the derived radius, with the error
  // probe, into an error model of their own, whose plan then sets the radius
  // of the passes after them. Every MPI rank renders them and plans alike,
  // keeping those of its own slice, so that the image depends on neither
  // the devices, the ranks nor their timing. A timed render plans from the
  // caller's model (`terms`, one process only), and with derived samples
  // plans each pass's samples too.
  const bool planned = terms && slice.stride == 1 && timed;
  const bool tunes = radius_derived(scene.integrator) && (timed ? planned : s.passes > kTuningPasses);
  if (s.announce && !tunes) s.announce(scene, pilot.seconds);
  // The passes before the plan: the tuning passes and a timed render's cost pass.
  const int tuning = tunes ? kTuningPasses + (timed ? 1 : 0) : 0;
  std::optional<ErrorModel> tuning_model;
  if (tunes) tuning_model.emplace(size_t(s.width) * s.height * 3);
  // This process's k-th pass: the tuning passes first, then its slice's
  // passes after them (slice.offset + j slice.stride, the j-th).
  const int first_after = tunes ? std::max(0, (tuning - slice.offset + slice.stride - 1) / slice.stride) : 0;
  const auto pass_of = [&](int k) { return k < tuning ? k : slice.offset + (first_after + k - tuning) * slice.stride; };
  const auto in_slice = [&](int pass) { return pass >= slice.offset && (pass - slice.offset) % slice.stride == 0; };

  std::mutex mutex;
  std::atomic<int> next{0};
  // A balanced render's passes differ in samples, so pass x spp would not
  // tile the pixels' scrambled sequence (stratify2): each pass claims the
  // next run of sample indices instead, one sequence per process, whose
  // ranks read sequences of their own.
  // One run per replicate (render/error_model.h).
  std::atomic<uint32_t> samples_claimed[kReplicates] = {};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  RenderStats st;
  st.devices.resize(devices.size());
  st.pilot_seconds = pilot.seconds;
  const auto stopping = [&] {
    return failed.load() || (s.stop && s.stop->load()) || (s.target_met && s.target_met->load());
  };
  // A timed render with derived samples per pass balances them from the
  // stage times of its passes so far; their count then depends on timing,
  // as the number of passes already does.
  const bool balance = timed && s.spp_derived;
  std::vector<DeviceLoop> loops(devices.size());
  // The derived radii's scale (render/planner.h), and what a timed render's
  // tuning measured of the costs at two scales, for its plans after.
  float scale = 1.0f;
  PlanInputs tuned;
  const auto rescale = [&](float to) {
    if (to == scale) return;
    scale_radii(scene.integrator, to / scale);
    scale = to;
    renderers[0]->set_scene(scene);
  };
  // With one device, a timed render plans its radius again after
  // kReplanPasses passes, twice that, ..., from the model's terms over more
  // probes; with several, the devices read the scene while they render, and
  // it stays.
  const bool replans = timed && devices.size() == 1;
  // What a plan reads of device `d`'s passes so far, for the passes from
  // `done` on; passes 0: the seconds left in `budget`.
  const auto model_terms = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    return terms ? terms() : ErrorTerms{};
  };
  const auto plan_inputs = [&](size_t d, int done, double left) {
    const DeviceLoop& l = loops[d];
    const double passes = std::max(1, l.measured);
    PlanInputs in;
    in.terms = model_terms();
    in.radius = pass_radius(scene.integrator.radius, scene.integrator.alpha, done);
    in.spp = l.samples > 0.0 ? l.samples / passes : double(l.spp);
    in.done = done;
    in.passes = timed ? 0 : s.passes;
    in.seconds = std::isfinite(budget) ? left : kTargetHorizon * l.elapsed;
    in.fixed_seconds = l.photon_seconds / passes;
    in.sample_seconds = l.gather_seconds / std::max(1.0, l.samples);
    in.max_spp = kMaxPassSpp;
    in.max_pass_seconds = kPassShareOfBudget * budget;
    in.choose_spp = balance;
    return in;
  };

  const auto work = [&](size_t d, int last) {
    try {
      Device& device = *devices[d];
      st.devices[d].name = device.info().name;
      if (profiler) profiler->add_device(int(d), device.info().name);
      if (!renderers[d]) renderers[d] = std::make_unique<PassRenderer>(device, scene, tables, s);
      PassRenderer& renderer = *renderers[d];
      DeviceLoop& l = loops[d];
      // The budget counts from a device's first pass: scene upload and
      // kernel builds are reported apart (RenderStats::build_seconds).
      if (l.done == 0) {
        l.clock = Timer();
        // A pass starts only when its predicted length, the longest pass so
        // far (at first the pilot's estimate; with balanced samples, from
        // its parts, below), still fits the budget; device 0 renders one
        // pass in any case.
        l.longest = std::min(first_pass_estimate(scene, pilot.seconds), kPassShareOfBudget * budget);
        l.spp = balance ? std::min(s.spp, kFirstBalancedSpp) : s.spp;
        if (balance) renderer.set_spp(l.spp);
      }
      for (;; ++l.done) {
        if (stopping() || next.load() >= last) break;
        if (timed && (d > 0 || l.done > 0) && l.elapsed + l.longest > budget) break;
        const int pass = pass_of(next++);
        if (!timed && pass >= s.passes) break;
        if (balance) {
          renderer.set_first_sample(samples_claimed[pass % kReplicates].fetch_add(uint32_t(l.spp)),
                                    1u + uint32_t(slice.offset));
        }
        Timer busy;
        PassOutput out = renderer.render(pass, profiler, int(d) + 1);
        if (profiler) {
          profiler->add_launches(int(d), device.take_launches());
          profiler->add_pass(int(d), pass, out.counters);
        } else {
          device.take_launches();
        }
        const double took = busy.lap();
        l.elapsed += l.clock.lap();
        l.longest = std::max(l.longest, took);
        // The tuning passes keep the probe's first rows, which the radius's
        // plan then does not take from timing.
        if (pass >= tuning) renderer.balance_probe(out, took);
        // The first pass also pays for its kernels' first launches (PoCL
        // compiles the gather for its work-group size then: cornell_fog at
        // 64x64 with a cold cache waited 1.06 s before a gather of 0.09 s),
        // which would starve later passes of samples, so the means and the
        // longest parts start again from the second pass.
        if (l.done == 1) {
          l.measured = 0;
          l.photon_seconds = l.gather_seconds = l.samples = l.longest_rest = l.longest_per_sample = 0.0;
        }
        ++l.measured;
        l.photon_seconds += out.propagate_seconds + out.grid_seconds + out.probe_seconds;
        l.gather_seconds += out.gather_seconds;
        l.samples += l.spp;
        if (balance) {
          int next_spp = balanced_spp(l.photon_seconds / l.measured,
                                      l.gather_seconds * l.spp / l.samples, l.spp, budget);
          // After the tuning passes the model plans the samples.
          if (planned && pass + 1 >= std::max(kTuningPasses, tuning + 1)) {
            const Plan plan = plan_passes([&] {
              PlanInputs in = plan_inputs(d, pass + 1, budget - l.elapsed);
              in.choose_scale = false;
              return in;
            }());
            if (plan.predicted >= 0.0) next_spp = plan.spp;
          }
          const int passes = pass + 1;
          if (tunes && replans && replans_after(passes)) {
            PlanInputs in = tuned;
            in.terms = model_terms();
            in.spp = l.samples / l.measured;
            in.done = passes;
            in.done_scale = scale;
            in.seconds = budget - l.elapsed;
            const Plan plan = plan_passes(in);
            if (plan.predicted >= 0.0) {
              if (plan.scale != scale && s.planned) s.planned(passes, plan, scene.integrator.radius * plan.scale / scale);
              rescale(plan.scale);
              next_spp = plan.spp;
              l.longest_rest = plan.fixed_seconds;
              l.longest_per_sample = plan.sample_seconds;
            }
          }
          l.longest_rest = std::max(l.longest_rest, took - out.gather_seconds);
          l.longest_per_sample = std::max(l.longest_per_sample, out.gather_seconds / l.spp);
          l.longest = l.longest_rest + l.longest_per_sample * next_spp;
          l.spp = next_spp;
          renderer.set_spp(l.spp);
        }
        if (pass < tuning) tuning_model->add(pass, out.rgb, out.radius, out.probe);
        if (!in_slice(pass)) continue;
        std::lock_guard<std::mutex> lock(mutex);
        st.devices[d].passes += 1;
        st.devices[d].busy_seconds += took;
        st.seconds = std::max(st.seconds, l.elapsed);
        st.propagate_seconds += out.propagate_seconds;
        st.grid_seconds += out.grid_seconds;
        st.gather_seconds += out.gather_seconds;
        st.probe_seconds += out.probe_seconds;
        st.camera_samples += out.counters.camera_samples;
        st.sphere_tests += out.counters.sphere_tests;
        ++st.passes;
        sink(pass, PassImage{std::move(out.rgb), std::move(out.probe), out.radius});
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex);
      if (!error) error = std::current_exception();
      failed = true;
    }
  };
  if (tunes) {
    renderers[0]->set_probe(true);
    work(0, kTuningPasses);
    if (error) std::rethrow_exception(error);
    DeviceLoop& l = loops[0];
    PlanInputs in = plan_inputs(0, next.load(), budget - l.elapsed);
    in.terms = tuning_model->terms();
    if (timed && !stopping()) {
      // A timed render weighs a radius's error against its cost: one more
      // pass, at kCostScale of the radius, measures how the pass's stages
      // grow with it (render/planner.h). It is the image's next pass.
      rescale(kCostScale);
      const DeviceLoop before = l;
      work(0, kTuningPasses + 1);
      if (error) std::rethrow_exception(error);
      in.fixed_seconds_scaled = l.photon_seconds - before.photon_seconds;
      in.sample_seconds_scaled = (l.gather_seconds - before.gather_seconds) / std::max(1.0, l.samples - before.samples);
      in.done = next.load();
      in.seconds = std::isfinite(budget) ? budget - l.elapsed : in.seconds;
      tuned = in;
    }
    renderers[0]->set_probe(estimates_error(s));
    tuning_model.reset();
    const Plan plan = plan_passes(in);
    if (plan.predicted >= 0.0) {
      rescale(plan.scale);
      if (s.planned) s.planned(in.done, plan, scene.integrator.radius);
    }
    if (balance && plan.predicted >= 0.0) {
      l.spp = plan.spp;
      renderers[0]->set_spp(l.spp);
      // The longest parts so far were at other radii.
      l.longest_rest = plan.fixed_seconds;
      l.longest_per_sample = plan.sample_seconds;
      l.longest = plan.fixed_seconds + plan.sample_seconds * l.spp;
    }
    if (s.announce) s.announce(scene, pilot.seconds);
  }
  std::vector<std::thread> threads;
  for (size_t d = 1; d < devices.size(); ++d) threads.emplace_back(work, d, std::numeric_limits<int>::max());
  work(0, std::numeric_limits<int>::max());
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  st.radius_scale = scale;
  st.interrupted = s.stop && s.stop->load();
  st.bvh_seconds = tables.bvh_seconds;
  for (Device* d : devices) st.build_seconds += d->build_seconds();
  return st;
}

void add_build_values(Profiler& profiler, const RenderStats& stats, const std::vector<Device*>& devices) {
  profiler.add_value("bvh_build_s", stats.bvh_seconds);
  for (size_t d = 0; d < devices.size(); ++d) {
    for (const auto& [program, build] : devices[d]->program_builds()) {
      profiler.add_value(std::string(build.from_binary ? "program_binary_s." : "program_build_s.") +
                             std::to_string(d) + "." + program,
                         build.seconds);
    }
  }
}

Image render(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
             RenderStats* stats, const Progress& progress, Profiler* profiler) {
  const RenderSettings s = resolve_settings(scene, settings);
  const bool timed = s.passes == 0;
  OrderedSum sum(size_t(s.width) * s.height * 3, estimates_error(s));
  // A target error stops the render once the passes summed so far reach it.
  std::atomic<bool> target_met{false};
  RenderSettings run = settings;
  run.target_met = &target_met;
  const RenderStats st = render_passes(
      scene, run, devices, PassSlice{},
      [&](int pass, PassImage&& image) {
        const int before = sum.summed();
        sum.add(pass, std::move(image));
        if (sum.summed() == before) return;
        const ErrorEstimate e = sum.estimate();
        if (profiler) profiler->add_estimate(e, profiler->now());
        const float target = scene.integrator.target_error;
        if (target > 0.0f && e.relmse >= 0.0 && e.relmse < target) target_met = true;
        if (progress) progress(sum.summed(), timed ? 0 : s.passes, e);
      },
      profiler, estimates_error(s) ? TermsSource([&] { return sum.terms(); }) : TermsSource());
  if (stats) {
    *stats = st;
    // With a time budget, only the passes before the first unfinished one count.
    stats->passes = sum.summed();
    stats->error = sum.estimate();
  }
  return sum.average(s.width, s.height);
}

}  // namespace spm
