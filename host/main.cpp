// spm: streamed photon mapping in participating media, on OpenCL.
// Command line only: parse, then call the library.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <memory>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>

#include "bench/bench.h"
#include "device/device.h"
#include "film/compare.h"
#include "film/image_io.h"
#include "mpi/cluster.h"
#include "profile/profile.h"
#include "util/text_file.h"
#include "render/render.h"
#include "render/terms.h"
#include "scene/integrator_options.h"
#include "scene/loader.h"
#include "scene/volume_grid.h"
#include "util/errors.h"

namespace {

std::string gib(cl_ulong bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return buf;
}

int cmd_devices() {
  const auto devices = spm::list_devices();
  if (devices.empty()) {
    std::cout << "no OpenCL device found\n";
    return 0;
  }
  for (const auto& d : devices) {
    std::cout << d.platform << ":" << d.index << "  " << d.name << "  [" << d.type << ", " << d.version << ", "
              << d.compute_units << " compute units, " << gib(d.global_memory) << "]  platform: " << d.platform_name
              << "\n";
  }
  return 0;
}

struct RenderArgs {
  std::string scene, output, png, device, res, kernel_dir;
  std::vector<std::string> defines;
  spm::RenderSettings settings;
  bool profile = false;
  std::string profile_json, trace;
  std::optional<size_t> device_memory;
  // Overrides of the scene's <integrator type="spm"> properties.
  std::optional<int> streams, associated, beam_streams, bounces, max_depth, rr_depth, emission_chains, volume_every;
  std::optional<float> stream_width, march_step, radius, volume_radius, alpha, time;
  std::optional<std::string> estimator, density_kernel, direct;
  bool final_gather = false, no_final_gather = false, no_wall_images = false;
  std::vector<std::string> terms;
};

void apply_overrides(const RenderArgs& a, spm::IntegratorSettings& in) {
  // Given on the command line, these must be positive; left out, the scene
  // or the derived defaults decide (render/defaults.h).
  const auto positive = [](const auto& v, const char* flag) {
    if (v && !(*v > 0)) throw spm::InputError(flag, "must be positive");
  };
  positive(a.streams, "--streams");
  positive(a.associated, "--associated");
  positive(a.beam_streams, "--beam-streams");
  positive(a.stream_width, "--stream-width");
  positive(a.radius, "--radius");
  positive(a.volume_radius, "--volume-radius");
  if (a.streams) in.streams = *a.streams;
  if (a.associated) in.associated = *a.associated;
  if (a.beam_streams) in.beam_streams = *a.beam_streams;
  if (a.bounces) in.max_bounces = *a.bounces;
  if (a.max_depth) in.max_depth = *a.max_depth;
  if (a.rr_depth) in.rr_depth = *a.rr_depth;
  if (a.emission_chains) in.emission_chains = *a.emission_chains;
  if (a.volume_every) in.volume_every = *a.volume_every;
  if (a.stream_width) in.stream_width = *a.stream_width;
  if (a.march_step) in.march_step = *a.march_step;
  if (a.radius) in.radius = *a.radius;
  if (a.volume_radius) in.volume_radius = *a.volume_radius;
  if (a.alpha) in.alpha = *a.alpha;
  if (a.time) in.time = *a.time;
  if (a.estimator) in.estimator = *a.estimator;
  if (a.density_kernel) in.density_kernel = *a.density_kernel;
  if (a.direct) in.direct = *a.direct;
  if (a.final_gather && a.no_final_gather) throw spm::InputError("--final-gather", "and --no-final-gather both given");
  if (a.final_gather) in.final_gather = true;
  if (a.no_final_gather) in.final_gather = false;
  if (a.no_wall_images) in.wall_images = false;
}

std::map<std::string, std::string> parse_defines(const std::vector<std::string>& defines) {
  std::map<std::string, std::string> out;
  for (const auto& d : defines) {
    const auto eq = d.find('=');
    if (eq == std::string::npos || eq == 0) throw spm::InputError("-D", "expected name=value, got '" + d + "'");
    out[d.substr(0, eq)] = d.substr(eq + 1);
  }
  return out;
}

void parse_res(const std::string& res, spm::RenderSettings& s) {
  if (res.empty()) return;
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(res.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 1 || h < 1) {
    throw spm::InputError("--res", "expected WIDTHxHEIGHT, got '" + res + "'");
  }
  s.width = w;
  s.height = h;
}

// SIGINT during a render: the passes in flight finish, no new one starts, and
// the image of the completed passes is written.
std::atomic<bool> g_interrupted{false};

extern "C" void on_sigint(int) { g_interrupted = true; }

size_t device_memory_budget(const std::optional<size_t>& flag) {
  if (flag) return *flag;
  const char* env = std::getenv("SPM_DEVICE_MEMORY");
  if (!env || !*env) return 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(env, &end, 10);
  if (*end != 0 || v == 0) throw spm::InputError("SPM_DEVICE_MEMORY", std::string("expected bytes, got '") + env + "'");
  return static_cast<size_t>(v);
}

int cmd_render(const RenderArgs& a) {
  spm::Profiler profiler(!a.trace.empty());
  double t = profiler.now();
  spm::RenderSettings settings = a.settings;
  parse_res(a.res, settings);
  if (!a.terms.empty()) settings.terms = spm::gather_terms(a.terms, "--terms");
  spm::Scene scene = spm::load_scene(a.scene, parse_defines(a.defines));
  apply_overrides(a, scene.integrator);
  settings = spm::resolve_settings(scene, settings);
  settings.memory_budget = device_memory_budget(a.device_memory);
  profiler.stage("scene_load", t, profiler.now());

  std::vector<std::unique_ptr<spm::Device>> owned;
  std::vector<spm::Device*> devices;
  std::string names;
  for (const auto& info : spm::select_devices(a.device)) {
    owned.push_back(std::make_unique<spm::Device>(info, a.kernel_dir));
    devices.push_back(owned.back().get());
    names += (names.empty() ? "" : ", ") + info.name;
  }

  // With several MPI ranks, only rank 0 prints (the other ranks, errors only)
  // and writes the image, profile and trace.
  const spm::Cluster& cluster = spm::Cluster::get();
  const bool tty = ::isatty(STDERR_FILENO);
  // The settings in use, derived ones included (render/defaults.h), printed
  // before the first pass and kept for the profile.
  nlohmann::json used_json;
  const bool timed = settings.passes == 0;
  if (cluster.root()) {
    settings.announce = [&](const spm::RenderUsed& u) {
      const spm::IntegratorSettings& in = scene.integrator;
      const auto src = [](bool given) { return given ? "" : " (derived)"; };
      std::fprintf(stderr,
                   "spm: rendering %s at %dx%d, %s x %d spp on %s%s\n"
                   "spm: streams %d%s x associated %d%s, radius %.6g%s, stream width %.6g%s, volume radius %.6g%s "
                   "(caustic records %.6g), max_depth %d, rr_depth %d, max_bounces %d\n",
                   a.scene.c_str(), settings.width, settings.height,
                   timed ? ("passes for " + std::to_string(in.time) + " s").c_str()
                         : (std::to_string(u.passes) + " pass(es)").c_str(),
                   u.spp, names.c_str(),
                   cluster.size() > 1 ? (" (rank 0 of " + std::to_string(cluster.size()) + " MPI ranks)").c_str() : "",
                   u.streams, src(in.streams > 0 && u.streams == in.streams), u.associated, src(in.associated > 0),
                   u.radius, src(in.radius > 0), u.stream_width, src(in.stream_width > 0), u.volume_radius,
                   src(in.volume_radius > 0), u.caustic_volume_radius, in.max_depth, in.rr_depth, in.max_bounces);
      used_json = {{"streams", u.streams},
                   {"associated", u.associated},
                   {"radius", u.radius},
                   {"stream_width", u.stream_width},
                   {"volume_radius", u.volume_radius},
                   {"caustic_volume_radius", u.caustic_volume_radius},
                   {"spp_per_pass", u.spp},
                   {"passes", u.passes},
                   {"max_depth", in.max_depth},
                   {"rr_depth", in.rr_depth},
                   {"max_bounces", in.max_bounces},
                   {"pilot_s", u.pilot_seconds},
                   {"time_budget_s", in.time}};
    };
  }
  const auto started = std::chrono::steady_clock::now();
  const float budget = scene.integrator.time;
  const auto progress = [tty, started, budget](int done, int total) {
    if (total == 0) {
      const double left =
          std::max(0.0, budget - std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
      std::cerr << (tty ? "\r" : "") << "spm: " << done << " pass(es) done, " << static_cast<int>(std::ceil(left))
                << " s left" << (tty ? "   " : "\n") << std::flush;
    } else if (tty) {
      const int width = 40, filled = width * done / total;
      std::cerr << "\r[" << std::string(filled, '#') << std::string(width - filled, ' ') << "] " << done << "/"
                << total << std::flush;
    } else {
      std::cerr << "spm: pass " << done << "/" << total << " done\n";
    }
  };
  settings.stop = &g_interrupted;
  std::signal(SIGINT, on_sigint);
  spm::RenderStats stats;
  t = profiler.now();
  nlohmann::json rank_profiles;  // several MPI ranks: one profile per rank
  const spm::Image image = spm::render_cluster(scene, settings, devices, &stats, progress, &profiler, &rank_profiles);
  profiler.stage("render", t, profiler.now());
  if (!cluster.root()) return 0;
  std::signal(SIGINT, SIG_DFL);
  if (tty) std::cerr << "\n";
  if (stats.interrupted) {
    std::cerr << "spm: interrupted: writing the image of the " << stats.passes << " completed pass(es)\n";
  }

  t = profiler.now();
  spm::write_exr(a.output, image);
  const std::string png =
      a.png.empty() ? std::filesystem::path(a.output).replace_extension(".png").string() : a.png;
  spm::write_png(png, image);
  profiler.stage("image_write", t, profiler.now());

  spm::add_build_values(profiler, stats, devices);
  if (a.profile) {
    spm::print_kernel_table(std::cout, profiler.kernels());
    std::printf("stages: propagate %.3f s, grid build %.3f s, gather %.3f s; passes %.3f s in all\n",
                stats.propagate_seconds, stats.grid_seconds, stats.gather_seconds, stats.seconds);
    std::printf("host: BVH %.3f s, kernel builds %.3f s\n", stats.bvh_seconds, stats.build_seconds);
    std::printf("gather: %llu camera samples, %.1f sphere tests per sample\n",
                static_cast<unsigned long long>(stats.camera_samples),
                double(stats.sphere_tests) / std::max<uint64_t>(1, stats.camera_samples));
  }
  if (!a.profile_json.empty()) {
    nlohmann::json j = profiler.json();
    j["scene"] = a.scene;
    j["resolution"] = {settings.width, settings.height};
    j["passes"] = stats.passes;
    j["seconds"] = stats.seconds;
    j["pilot_seconds"] = stats.pilot_seconds;
    j["settings"] = used_json;
    for (size_t d = 0; d < devices.size(); ++d) {  // this process's (rank 0's) devices come first
      j["devices"][d]["passes"] = stats.devices[d].passes;
      j["devices"][d]["busy_seconds"] = stats.devices[d].busy_seconds;
    }
    if (!rank_profiles.is_null()) j["ranks"] = rank_profiles;
    spm::write_text(a.profile_json, j.dump(2) + "\n");
  }
  if (!a.trace.empty()) profiler.write_trace(a.trace);
  for (size_t d = 0; d < stats.devices.size(); ++d) {
    if (cluster.size() > 1) {  // named "rank R device D (name)"
      std::fprintf(stderr, "spm: %s: %d passes, busy %.2f s\n", stats.devices[d].name.c_str(),
                   stats.devices[d].passes, stats.devices[d].busy_seconds);
    } else {
      std::fprintf(stderr, "spm: device %zu (%s): %d passes, busy %.2f s\n", d, stats.devices[d].name.c_str(),
                   stats.devices[d].passes, stats.devices[d].busy_seconds);
    }
  }
  std::fprintf(stderr, "spm: wrote %s and %s (%d passes in %.2f s; kernel build %.2f s, BVH %.3f s)\n",
               a.output.c_str(), png.c_str(), stats.passes, stats.seconds, stats.build_seconds, stats.bvh_seconds);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Under mpirun: MPI is initialised here; a failure on any rank ends every rank.
  spm::Cluster& cluster = spm::Cluster::get(&argc, &argv);
  CLI::App app{"spm: streamed photon mapping in participating media, on OpenCL"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Help for every subcommand");

  auto* devices = app.add_subcommand("devices", "List every OpenCL platform and device as P:D");

  RenderArgs r;
  auto* render = app.add_subcommand("render", "Render a scene file (Mitsuba 3 XML subset) to OpenEXR");
  render->add_option("scene", r.scene, "Scene file")->required();
  render->add_option("-o,--output", r.output, "Output OpenEXR file (32-bit float RGB)")->required();
  render->add_option("--png", r.png, "PNG preview (clamped, sRGB); default: beside the EXR");
  render->add_option("--device", r.device,
                     "Device(s): P:D or a case-insensitive name substring, a comma-separated list, or 'all'; "
                     "default: first GPU, else first CPU");
  render->add_option("--res", r.res, "Resolution WIDTHxHEIGHT, overriding the scene's film");
  render->add_option("--spp", r.settings.spp,
                     "Camera samples per pixel per pass; default: about one per four photons of a pass, 1 .. 64")
      ->check(CLI::PositiveNumber);
  render->add_option("--passes", r.settings.passes,
                     "Number of passes (each a full emit, propagate, gather); default: the integrator's 'passes', "
                     "else enough passes for the sampler's sample_count (the render's samples per pixel)")
      ->check(CLI::PositiveNumber);
  render->add_option("--seed", r.settings.seed, "Random seed; default 0");
  render->add_option("-D", r.defines, "Override a <default> of the scene: -D name=value (repeatable)")
      ->allow_extra_args(false);
  render->add_option("--streams", r.streams, "Photon streams per pass, N_s (integrator 'streams'); default 10000");
  render->add_option("--associated", r.associated,
                     "Associated photons per stream, N_a (integrator 'associated'); default 4");
  render->add_option("--beam-streams", r.beam_streams,
                     "With --estimator beams: streams of a pass whose flights are stored as beams (integrator "
                     "'beam_streams'); default 1000");
  render->add_option("--stream-width", r.stream_width,
                     "Stream width w: respawn sphere and deposit disk radius (integrator 'width'); default: the radius");
  render->add_option("--bounces", r.bounces,
                     "Diffuse bounces before a stream ends (integrator 'max_bounces'); default -1, unlimited");
  render->add_option("--max-depth", r.max_depth,
                     "Longest path in segments, as Mitsuba's volpath counts (integrator 'max_depth'); default -1, "
                     "unlimited")
      ->check(CLI::Range(-1, 1 << 30));
  render->add_option("--rr-depth", r.rr_depth,
                     "Russian roulette on streams and paths from this vertex on (integrator 'rr_depth'); default 5")
      ->check(CLI::Range(1, 1 << 30));
  render->add_option("--emission-chains", r.emission_chains,
                     "Camera rays per sample that bring the emission seen in pixels that see a mirror or glass: a "
                     "light seen through glass is an image far smaller than a pixel (integrator "
                     "'emission_chains'); 0: each sample's own path; default 64")
      ->check(CLI::Range(0, 1024));
  render->add_option("--volume-every", r.volume_every,
                     "One camera sample in this many per pixel and pass adds the camera segments' volume estimate, "
                     "weighted to stand for the others (integrator 'volume_every'); 1: every sample; default 4")
      ->check(CLI::Range(1, 1 << 20));
  render->add_option("--march-step", r.march_step,
                     "Ray-marching interval in media (integrator 'march_step'); 0: exact free flights, and in heterogeneous "
                     "media delta and ratio tracking; default 0");
  render->add_option("--radius", r.radius,
                     "Search radius r of the estimates, first pass (integrator 'radius'); default: derived from a "
                     "pilot of the pass's streams, the distance to the 32nd nearest event");
  render->add_option("--volume-radius", r.volume_radius,
                     "Kernel radius of the camera segments' volume estimate, first pass, shrinking as the radius "
                     "does; gather rays read the records with the radius when it is smaller (integrator "
                     "'volume_radius'); default: 3 radii where every medium is homogeneous, with bre and "
                     "--direct nee, else the radius. There, records of light that glass or a mirror focused "
                     "(caustic records) keep 1.5 radii, or the volume radius where that is smaller");
  render->add_option("--alpha", r.alpha,
                     "Radius reduction per pass: r_{k+1}^2 = r_k^2 (k + alpha) / (k + 1) (integrator 'alpha'); default 0.9");
  render->add_option("--time", r.time,
                     "Render passes for this many seconds instead of a pass count (integrator 'time'); the passes "
                     "end within it, scene load, kernel builds and the pilot reported apart");
  render->add_option("--estimator", r.estimator,
                     "Volume estimate: 'bre' (default), the physically based beam radiance estimate over the "
                     "stream records; 'beams', the stream beams' beam x beam 1D estimate (METHOD.md 11); 'paper', "
                     "eq. (4) of the paper literally, kept to reproduce its figures: it has no phase function, "
                     "transmittance or albedo and is not energy-consistent")
      ->check(CLI::IsMember(spm::kEstimatorOption.names()));
  render->add_option("--density-kernel", r.density_kernel, "Density estimation kernel: uniform (default) or epanechnikov")
      ->check(CLI::IsMember(spm::kDensityKernelOption.names()));
  render->add_flag("--final-gather", r.final_gather,
                   "At the camera's first diffuse vertex, gather the photon maps along one cosine-sampled ray instead "
                   "of reading them there, caustics excepted (integrator 'final_gather'; the default); needs --direct "
                   "nee");
  render->add_flag("--no-final-gather", r.no_final_gather,
                   "Read the photon maps at the camera's first diffuse vertex (METHOD.md 5 as written)");
  render->add_flag("--no-wall-images", r.no_wall_images,
                   "Do not mirror the volume records near walls across them (integrator 'wall_images', default "
                   "true): the beam radiance estimate then darkens where its kernel reaches through a wall");
  render->add_option("--direct", r.direct,
                     "Direct light on surfaces: 'nee' (default; shadow rays with transmittance) or 'photons' "
                     "(photon map only, the paper's look)")
      ->check(CLI::IsMember(spm::kDirectOption.names()));
  render->add_flag("--profile", r.profile, "Print per-kernel device times and host stages at the end");
  render->add_option("--profile-json", r.profile_json, "Write the whole profile as JSON (schema: tools/profile.schema.json)");
  render->add_option("--trace", r.trace,
                     "Write a Chrome trace (one track per device queue and the host) for ui.perfetto.dev");
  render->add_option("--device-memory", r.device_memory,
                     "Device memory all of a render's live buffers may hold at once on each device, in bytes (also "
                     "SPM_DEVICE_MEMORY); default: the device's global memory")
      ->check(CLI::PositiveNumber);
  render->add_option("--dump-maps", r.settings.dump_maps,
                     "Write the first pass's maps as PREFIX_volume.ply and PREFIX_surface.ply (position, flux)");
  render->add_option("--terms", r.terms,
                     "Only these terms of the gather, comma-separated (emission, direct, inscatter, volume, surface, "
                     "gather_volume, gather_direct, gather_surface): their part of the image and their cost; "
                     "default: all (tools/gather_terms.py)")
      ->delimiter(',');
  render->add_option("--kernel-dir", r.kernel_dir,
                     "Load kernels from this directory instead of the embedded sources")
      ->check(CLI::ExistingDirectory);

  spm::BenchOptions bench_options;
  std::string bench_device;
  auto* bench = app.add_subcommand(
      "bench", "Time a fixed suite (Fig. 3 (a), (b), scaling in streams and associated photons, a global fog box, "
      "a smoke plume) "
      "stage by stage and "
      "kernel by kernel: medians of --repeat one-pass renders");
  bench->add_option("--scenes", bench_options.scenes_dir, "Directory holding cornell_fog.xml, fog_box.xml and smoke_cornell.xml")
      ->check(CLI::ExistingDirectory);
  bench->add_option("--repeat", bench_options.repeat, "Timed repetitions after one warm-up")
      ->check(CLI::PositiveNumber);
  bench->add_option("--res", bench_options.resolution, "Square resolution")->check(CLI::Range(1, 16384));
  bench->add_option("--spp", bench_options.spp, "Camera samples per pixel")->check(CLI::PositiveNumber);
  bench->add_option("--csv", bench_options.csv, "Also write the results as CSV");
  bench->add_option("--json", bench_options.json,
                    "Also write the results as JSON, with per-kernel medians and occupancy (tools/plot_bench.py)");
  bench->add_flag("--quick", bench_options.quick, "Fig. 3 (a) and (b) only, without the scaling cases");
  bench->add_option("--cases", bench_options.cases,
                    "Only these cases (fig3a fig3b s10k_a10 s100k_a10 fog_box smoke smoke_step1 smoke_mean)")
      ->delimiter(',');
  bench->add_option("--device", bench_device, "Device, as for render");

  std::string compare_image, compare_reference;
  auto* compare = app.add_subcommand(
      "compare", "An image against a reference: RMSE, relMSE (eps 1e-2) and the means, as tools/compare.py");
  compare->add_option("image", compare_image, "OpenEXR image")->required()->check(CLI::ExistingFile);
  compare->add_option("reference", compare_reference, "OpenEXR reference")->required()->check(CLI::ExistingFile);

  std::string vdb_input, vol_output, vdb_grid = "density";
  auto* vdb2vol = app.add_subcommand(
      "vdb2vol", "Convert a float grid of an OpenVDB file to Mitsuba's .vol, densely over its active voxels, with "
      "their world-space box as the file's bounding box (use_grid_bbox places it there)");
  vdb2vol->add_option("input", vdb_input, "OpenVDB file")->required();
  vdb2vol->add_option("output", vol_output, ".vol file to write")->required();
  vdb2vol->add_option("--grid", vdb_grid, "Name of the float grid; default 'density'");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << cluster.prefix() << e.what() << " (see --help)\n";
    return cluster.fail(spm::kExitInput);
  }

  try {
    if (*devices) return cmd_devices();
    if (*render) return cluster.finish(cmd_render(r));
    if (*compare) {
      const spm::ImageDifference d = spm::compare_images(spm::read_exr(compare_image), spm::read_exr(compare_reference),
                                                         compare_image);
      std::printf("RMSE    %.6g\nrelMSE  %.6g  (eps 0.01)\n", d.rmse, d.relmse);
      std::printf("mean    image %.6g %.6g %.6g\n        ref   %.6g %.6g %.6g\n", d.mean[0], d.mean[1], d.mean[2],
                  d.reference_mean[0], d.reference_mean[1], d.reference_mean[2]);
      return 0;
    }
    if (*vdb2vol) {
      const spm::VolumeGrid g = spm::read_vdb(vdb_input, vdb_grid);
      spm::write_vol(vol_output, g);
      std::fprintf(stderr, "spm: wrote %s: %u x %u x %u voxels in (%g, %g, %g) .. (%g, %g, %g), max %g\n",
                   vol_output.c_str(), g.nx, g.ny, g.nz, g.bbox_min.x, g.bbox_min.y, g.bbox_min.z, g.bbox_max.x,
                   g.bbox_max.y, g.bbox_max.z, g.max_value());
      return 0;
    }
    if (*bench) {
      spm::Device device(spm::select_device(bench_device), "");
      std::cerr << "spm: bench on " << device.info().name << "\n";
      spm::run_bench(device, bench_options);
      return 0;
    }
  } catch (const spm::InputError& e) {
    std::cerr << cluster.prefix() << e.what() << "\n";
    return cluster.fail(spm::kExitInput);
  } catch (const cl::Error& e) {
    std::cerr << cluster.prefix() << "OpenCL error: " << spm::describe(e) << "\n";
    return cluster.fail(spm::kExitRuntime);
  } catch (const std::exception& e) {
    std::cerr << cluster.prefix() << e.what() << "\n";
    return cluster.fail(spm::kExitRuntime);
  }
  return 0;
}
