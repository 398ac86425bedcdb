#include "render/pass_renderer.h"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>

#include "render/defaults.h"
#include "render/error_model.h"
#include "scene/integrator_options.h"
#include "spm/map_grids.h"
#include "spm/maps_io.h"
#include "util/errors.h"
#include "util/timer.h"

namespace spm {

namespace {


// The device memory budget, shared out by sizes alone (render/tuning.h,
// kStreamBatchShare).
size_t after_scene(const Device& device, const GpuScene& gpu) {
  const size_t budget = device.memory_budget();
  return budget > gpu.bytes() ? budget - gpu.bytes() : 0;
}

StreamSettings batch_settings(const Device& device, const GpuScene& gpu, const Scene& scene,
                              const RenderSettings& s) {
  StreamSettings out = stream_settings(scene, s, 0);
  out.memory_budget = std::max<size_t>(
      1, std::min<size_t>(size_t(kStreamBatchShare * double(after_scene(device, gpu))), kStreamBatchBytes));
  return out;
}

// Host bytes of the maps' records.
size_t map_bytes(const PhotonMaps& m) {
  return m.volume.size() * sizeof(SpmVolumeRecord) + m.surface.size() * sizeof(SpmSurfaceRecord) +
         m.beams.size() * sizeof(SpmBeam);
}

// Appends the maps of the next streams: both stay ordered by (stream,
// depth), and the statistics add up.
void append(PhotonMaps& to, PhotonMaps&& from) {
  if (to.stats.batches == 0) {  // nothing yet: take the maps without copying them
    to = std::move(from);
    return;
  }
  to.volume.insert(to.volume.end(), from.volume.begin(), from.volume.end());
  to.surface.insert(to.surface.end(), from.surface.begin(), from.surface.end());
  to.beams.insert(to.beams.end(), from.beams.begin(), from.beams.end());
  to.stats.batches += from.stats.batches;
  to.stats.flushes += from.stats.flushes;
  to.stats.live.insert(to.stats.live.end(), from.stats.live.begin(), from.stats.live.end());
  for (int k = 0; k < SPM_COUNTERS; ++k) to.stats.counters[k] += from.stats.counters[k];
}

// Host memory the maps of a pass may hold before they are gathered:
// SPM_HOST_MEMORY bytes, else a quarter of the machine's memory.
size_t host_map_budget() {
  if (const char* env = std::getenv("SPM_HOST_MEMORY")) {
    char* end = nullptr;
    const unsigned long long v = std::strtoull(env, &end, 10);
    if (*env == 0 || *end != 0 || v == 0) {
      throw InputError("SPM_HOST_MEMORY", std::string("expected bytes, got '") + env + "'");
    }
    return static_cast<size_t>(v);
  }
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? size_t(kHostMapShare * double(pages) * double(page)) : size_t(1) << 30;
}

// The maps' records in `parts` contiguous ranges of each map, the k-th.
template <class Record>
std::vector<Record> part_of(const std::vector<Record>& records, size_t k, size_t parts) {
  return std::vector<Record>(records.begin() + records.size() * k / parts,
                             records.begin() + records.size() * (k + 1) / parts);
}

}  // namespace

PassRenderer::PassRenderer(Device& device, const Scene& scene, const SceneTables& tables,
                           const RenderSettings& settings)
    : device_(device),
      scene_(&scene),
      tables_(tables),
      settings_(settings),
      probe_(estimates_error(settings)),
      gpu_(device, tables),
      propagator_(device, gpu_, batch_settings(device, gpu_, scene, settings)),
      gather_(device, gpu_, size_t(settings.width), size_t(settings.width) * settings.height,
              size_t(kFilmShare *
                     double(after_scene(device, gpu_) - std::min(after_scene(device, gpu_), propagator_.bytes())))),
      density_kernel_(kDensityKernelOption.code(scene.integrator.density_kernel)),
      estimator_(kEstimatorOption.code(scene.integrator.estimator)),
      direct_(kDirectOption.code(scene.integrator.direct)),
      final_gather_(scene.integrator.final_gather && direct_ == SPM_DIRECT_NEE),
      specular_(std::any_of(scene.materials.begin(), scene.materials.end(),
                            [](const Material& m) { return m.delta_only(); })),
      aimed_(final_gather_ && std::any_of(tables.lights.begin(), tables.lights.end(),
                                          [](const SpmLight& l) { return l.aim > 0.0f; })),
      wall_images_(scene.integrator.wall_images && estimator_ == SPM_ESTIMATOR_BRE) {
  // A stream beam in a medium whose sigma_t varies per channel would need its
  // own optical depth per channel (estimate.h); grey ones need none.
  for (const Medium& m : scene.media) {
    const bool grey = m.sigma_t.x == m.sigma_t.y && m.sigma_t.y == m.sigma_t.z &&
                      (m.sigma_t_grid < 0 || scene.volumes[m.sigma_t_grid].grid.channels == 1);
    if (estimator_ == SPM_ESTIMATOR_BEAMS && m.heterogeneous() && !grey)
      throw InputError(m.where, "the stream beams (estimator beams) read heterogeneous media with grey sigma_t only; "
                                "use bre");
  }
  const size_t used = propagator_.bytes() + gather_.bytes();
  maps_budget_ = after_scene(device, gpu_) > used ? after_scene(device, gpu_) - used : 0;
  host_budget_ = host_map_budget();
  if (!tables.nodes.empty() && !tables.prims.empty()) {
    scene_lo_ = glm::vec3(tables.nodes[0].lo[0], tables.nodes[0].lo[1], tables.nodes[0].lo[2]);
    scene_hi_ = glm::vec3(tables.nodes[0].hi[0], tables.nodes[0].hi[1], tables.nodes[0].hi[2]);
  }
  if (scene.integrator.radius > 0.0f) set_scene(scene);
}

void PassRenderer::set_scene(const Scene& scene) {
  scene_ = &scene;
  propagator_.set_settings(batch_settings(device_, gpu_, scene, settings_));
  volume_radius0_ = derived_volume_radius(scene);
  caustic_volume_radius0_ = derived_caustic_volume_radius(scene);
  walls_ = WallImages(tables_, volume_radius0_);
}

ScalePilot PassRenderer::pilot() {
  // Some drivers (PoCL among them) compile a kernel for its work-group size
  // at its first launch, which would time the compiler rather than the
  // streams (2 s against 0.08 s on the fog box with a cold cache) and size
  // a timed render's passes ten times too small: a few streams first,
  // untimed, launch every stage once.
  const uint32_t streams = propagator_.settings().streams;
  propagator_.propagate_leaders(0, std::min(streams, kPilotWarmStreams));
  ScalePilot pilot;
  Timer timer;
  const PhotonMaps maps = propagator_.propagate_leaders(0, streams);
  pilot.seconds = timer.lap();
  for (const auto& r : maps.volume) pilot.volume.emplace_back(r.position[0], r.position[1], r.position[2]);
  for (const auto& r : maps.surface) pilot.surface.emplace_back(r.position[0], r.position[1], r.position[2]);
  return pilot;
}

double PassRenderer::Stages::now() const { return profiler ? profiler->now() : 0.0; }

double PassRenderer::Stages::lap() const { return timer->lap(); }

void PassRenderer::Stages::stage(const char* name, double start) const {
  if (profiler) profiler->stage(name, start, profiler->now(), track);
}

void PassRenderer::gather(const PhotonMaps& maps, int pass, float radius, float volume_radius, float beam_radius,
                          bool direct_terms, PassOutput& out, const Stages& stages) {
  // The estimates are sums over records, so maps whose grids do not fit the
  // device memory left are gathered in parts, each part's grids built,
  // uploaded and gathered along the same camera paths (same random
  // numbers), the parts' films summed; emission and next-event estimation
  // come with the first part only.
  const IntegratorSettings& in = scene_->integrator;
  const RenderSettings& s = settings_;
  const size_t pixels = size_t(s.width) * s.height;
  const bool skip_direct = direct_ == SPM_DIRECT_NEE;
  const cl_uint max_depth = in.max_depth < 0 ? SPM_NONE : cl_uint(in.max_depth);
  const bool beams = estimator_ == SPM_ESTIMATOR_BEAMS;
  const size_t records = (beams ? maps.beams.size() : maps.volume.size()) + maps.surface.size();
  std::vector<float> rgb(pixels * 3, 0.0f), probe_full, probe_scaled;
  if (probe_) probe_full = probe_scaled = rgb;
  uint64_t tests = 0;
  size_t parts = 1;
  for (size_t k = 0; k < parts;) {
    double t = stages.now();
    QueryBounds reach;
    reach.lo = scene_lo_ - glm::vec3(std::max(radius, volume_radius));
    reach.hi = scene_hi_ + glm::vec3(std::max(radius, volume_radius));
    // The gather reads the volume records or the beams, never both.
    MapParts part;
    if (beams) {
      part.beams = part_of(maps.beams, k, parts);
    } else {
      part.volume = part_of(maps.volume, k, parts);
    }
    // The surface records are read in place: a million in Fig. 3 (b).
    const size_t first = maps.surface.size() * k / parts;
    part.surface = maps.surface.data() + first;
    part.surface_count = maps.surface.size() * (k + 1) / parts - first;
    PassRadii radii;
    radii.radius = radius;
    radii.volume_radius = volume_radius;
    radii.caustic_volume_radius = caustic_volume_radius(radius);
    radii.beam_radius = beam_radius;
    radii.final_gather = final_gather_;
    radii.beams = beams;
    MapGridData data = map_grid_data(std::move(part), radii, skip_direct, reach, wall_images_ ? &walls_ : nullptr);
    if (data.bytes() > maps_budget_) {
      if (parts == 1 && maps_budget_ > 0) {
        // The whole maps' size says about how many parts they need; a part
        // that still does not fit halves them all again below.
        parts = std::max<size_t>(2, size_t(kMapPartsMargin * double(data.bytes()) / double(maps_budget_)) + 1);
        continue;
      }
      if (parts >= std::max<size_t>(1, records)) {
        throw RuntimeError("gather, pass " + std::to_string(pass) + ": the photon maps' grids need " +
                           std::to_string(data.bytes()) + " bytes even in " + std::to_string(parts) +
                           " parts; " + std::to_string(maps_budget_) +
                           " bytes of the device memory budget are left for them (--device-memory)");
      }
      parts *= 2;  // start again with smaller parts
      k = 0;
      rgb.assign(pixels * 3, 0.0f);
      if (probe_) probe_full = probe_scaled = rgb;
      tests = 0;
      continue;
    }
    const MapGrids grids(device_, data);
    const cl_uint rows = cl_uint(data.grids.size());
    data = MapGridData{};
    out.grid_seconds += stages.lap();
    stages.stage("grid", t);
    t = stages.now();
    SpmGatherParams params{};
    params.seed = s.seed;
    params.pass = cl_uint(pass);
    params.spp = cl_uint(s.spp);
    params.max_depth = max_depth;
    params.radius = radius;
    params.volume_radius = volume_radius;
    params.gather_aim = aimed_ ? kGatherAim : 0.0f;
    params.grids = rows;
    params.density_kernel = density_kernel_;
    params.estimator = estimator_;
    params.direct = direct_;
    params.final_gather = final_gather_ ? 1u : 0u;
    params.march_step = scene_->integrator.march_step;
    params.direct_terms = direct_terms && k == 0;
    // The passes alternate between kReplicates sequences (error_model.h);
    // without set_first_sample, pass p reads its replicate's samples
    // (p / kReplicates) x spp onwards.
    params.first_sample =
        first_sample_ >= 0 ? cl_uint(first_sample_) : cl_uint(uint64_t(pass / kReplicates) * s.spp);
    params.strata_seed = strata_seed_ * kReplicates + cl_uint(pass % kReplicates);
    params.terms = s.terms;
    params.emission_chains = specular_ ? cl_uint(in.emission_chains) : 0u;
    params.volume_samples = cl_uint((s.spp + in.volume_every - 1) / in.volume_every);
    params.radius_scale = 1.0f;
    tests += gather_.run(grids, params, rgb);
    out.gather_seconds += stages.lap();
    stages.stage("gather", t);
    if (probe_) run_probe(grids, params, probe_full, probe_scaled, out, stages);
    ++k;
  }
  for (size_t i = 0; i < rgb.size(); ++i) out.rgb[i] += rgb[i];
  if (probe_) {
    // Summed over the pass's host parts as out.rgb is; NaN off the probe's rows.
    out.probe.resize(rgb.size(), 0.0f);
    const size_t row = size_t(SPM_GATHER_BLOCK) * s.width * 3;
    for (size_t i = 0; i < rgb.size(); ++i) {
      out.probe[i] = (i / row) % probe_rows_ == 0 ? out.probe[i] + probe_full[i] - probe_scaled[i] : NAN;
    }
  }
  out.counters.sphere_tests += tests;
  out.counters.map_parts += parts;
}

void PassRenderer::run_probe(const MapGrids& grids, const SpmGatherParams& params, std::vector<float>& full,
                             std::vector<float>& scaled, PassOutput& out, const Stages& stages) {
  // The photon terms of the pass's first camera sample per pixel, at the
  // pass's radii and at kProbeScale of them, on every probe_rows_-th row
  // of blocks (error_model.h).
  const double t = stages.now();
  const RenderSettings& s = settings_;
  SpmGatherParams p = params;
  p.spp = 1u;
  p.volume_samples = 1u;
  p.terms = s.terms & SPM_TERMS_PHOTONS;
  p.direct_terms = 0u;
  p.emission_chains = 0u;
  const size_t row = size_t(SPM_GATHER_BLOCK) * s.width, pixels = size_t(s.width) * s.height;
  for (const float scale : {1.0f, kProbeScale}) {
    p.radius_scale = scale;
    p.radius = params.radius * scale;
    p.volume_radius = params.volume_radius * scale;
    for (size_t first = 0; first < pixels; first += row * probe_rows_) {
      gather_.run(grids, p, scale == 1.0f ? full : scaled, first, std::min(row, pixels - first), "probe");
    }
  }
  out.probe_seconds += stages.lap();
  stages.stage("probe", t);
}

void PassRenderer::balance_probe(const PassOutput& out, double pass_seconds) {
  if (!probe_ || !(out.probe_seconds > 0.0) || !(pass_seconds > 0.0)) return;
  // Rows in powers of two, so that the rows probed from now on are among
  // those probed before or contain them; at least kMinProbeRows rows of
  // blocks, since a few rows give too few pixels to stand for the image.
  const int block_rows = (settings_.height + SPM_GATHER_BLOCK - 1) / SPM_GATHER_BLOCK;
  const int most = std::max(1, std::min(kMaxProbeRows, block_rows / kMinProbeRows));
  const double want = probe_rows_ * out.probe_seconds / (kProbeShare * pass_seconds);
  while (probe_rows_ < most && probe_rows_ < want / 1.5) probe_rows_ *= 2;
  while (probe_rows_ > 1 && (probe_rows_ > 1.5 * want || probe_rows_ > most)) probe_rows_ /= 2;
}

PassOutput PassRenderer::render(int pass, Profiler* profiler, int track) {
  const IntegratorSettings& in = scene_->integrator;
  const RenderSettings& s = settings_;
  const size_t pixels = size_t(s.width) * s.height;
  PassOutput out;
  out.rgb.assign(pixels * 3, 0.0f);
  out.counters.map_parts = 0;
  out.counters.host_parts = 0;
  Timer timer;
  const Stages stages{profiler, track, &timer};

  // Progressive radius (METHOD.md 6), the stream width shrinking with it.
  const float radius = pass_radius(in.radius, in.alpha, pass);
  const float width = in.stream_width * radius / in.radius;
  const float beam_radius = pass_beam_radius(in.radius, in.alpha, pass);
  const float volume_radius = volume_radius0_ * radius / in.radius;
  out.radius = radius;
  // The pass's streams batch by batch; their maps wait on the host until
  // they pass the host budget or the streams run out, and are then gathered
  // and dropped (the estimates are sums over records, so the parts add up
  // to the pass), which bounds the host's memory for any stream count.
  // Terms that read no photon map (--terms emission,direct,...) need no
  // streams: the pass is then one gather over empty maps.
  const uint32_t streams = (s.terms & SPM_TERMS_PHOTONS) ? propagator_.settings().streams : 0u;
  PhotonMaps maps;
  bool first_part = true;
  uint32_t first = 0;
  do {
    if (first < streams) {
      const double t = stages.now();
      const uint32_t count = std::min(propagator_.batch_capacity(), streams - first);
      append(maps, propagator_.propagate(static_cast<uint32_t>(pass), width, first, count));
      first += count;
      out.propagate_seconds += stages.lap();
      stages.stage("propagate", t);
      if (first < streams && map_bytes(maps) < host_budget_) continue;
    }
    if (pass == 0 && first_part && !s.dump_maps.empty()) write_maps_ply(s.dump_maps, maps);
    stages.lap();
    gather(maps, pass, radius, volume_radius, beam_radius, first_part, out, stages);
    out.counters.live.insert(out.counters.live.end(), maps.stats.live.begin(), maps.stats.live.end());
    for (int k = 0; k < SPM_COUNTERS; ++k) out.counters.stream_counters[k] += maps.stats.counters[k];
    out.counters.volume_records += maps.volume.size();
    out.counters.surface_records += maps.surface.size();
    ++out.counters.host_parts;
    maps = PhotonMaps{};
    first_part = false;
  } while (first < streams);
  if (gather_.nonfinite()) {
    throw RuntimeError("gather, pass " + std::to_string(pass) + ": a pixel's radiance is NaN or infinite");
  }
  out.counters.camera_samples = uint64_t(pixels) * s.spp;
  return out;
}

}  // namespace spm
