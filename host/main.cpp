// spm: streamed photon mapping in participating media, on OpenCL.
// Command line only: parse, then call the library. The render's settings
// and their flags come from the table of scene/settings.h.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>

#include "bench/bench.h"
#include "device/device.h"
#include "film/compare.h"
#include "film/image_io.h"
#include "mpi/cluster.h"
#include "profile/profile.h"
#include "render/defaults.h"
#include "render/render.h"
#include "render/terms.h"
#include "render/tuning.h"
#include "scene/loader.h"
#include "scene/settings.h"
#include "scene/volume_grid.h"
#include "util/errors.h"
#include "util/text_file.h"

namespace {

std::string gib(cl_ulong bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return buf;
}

int cmd_devices() {
  const auto devices = spm::list_devices();
  if (devices.empty()) std::cout << "no OpenCL device found\n";
  for (const auto& d : devices) {
    std::cout << d.platform << ":" << d.index << "  " << d.name << "  [" << d.type << ", " << d.version << ", "
              << d.compute_units << " compute units, " << gib(d.global_memory) << "]  platform: " << d.platform_name
              << "\n";
  }
  return 0;
}

// What `spm render` reads apart from the settings: files, devices, output.
struct RenderArgs {
  std::string scene, output, png, device, res, kernel_dir, profile_json, trace, dump_maps;
  std::vector<std::string> defines, terms;
  bool profile = false;
  std::optional<size_t> device_memory;
  // The settings' flags as given, by setting name (a boolean's: "true" or
  // "false"), applied over the scene's values in table order.
  std::map<std::string, std::string> flags;
};

// The settings' flags, one per row of the table (a boolean's twice: --x and
// --no-x), each with the row's help and default.
void add_setting_flags(CLI::App* render, RenderArgs& a) {
  for (const spm::Setting& s : spm::settings_table()) {
    const std::string name = s.name, flag = s.flag;
    if (std::holds_alternative<bool spm::IntegratorSettings::*>(s.member)) {
      const auto set = [&a, name](const char* value) { return [&a, name, value](int) { a.flags[name] = value; }; };
      render->add_flag_function(flag, set("true"), spm::setting_help(s));
      render->add_flag_function("--no-" + flag.substr(2), set("false"), "The opposite of " + flag);
    } else {
      const bool text = std::holds_alternative<std::string spm::IntegratorSettings::*>(s.member);
      const bool whole = std::holds_alternative<int spm::IntegratorSettings::*>(s.member);
      render
          ->add_option_function<std::string>(flag, [&a, name](const std::string& v) { a.flags[name] = v; },
                                             spm::setting_help(s))
          ->type_name(text ? "NAME" : whole ? "INT" : "FLOAT");
    }
  }
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

size_t device_memory_budget(const std::optional<size_t>& flag) {
  if (flag) return *flag;
  const char* env = std::getenv("SPM_DEVICE_MEMORY");
  if (!env || !*env) return 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(env, &end, 10);
  if (*end != 0 || v == 0) throw spm::InputError("SPM_DEVICE_MEMORY", std::string("expected bytes, got '") + env + "'");
  return static_cast<size_t>(v);
}

// SIGINT during a render: the passes in flight finish, no new one starts, and
// the image of the completed passes is written.
std::atomic<bool> g_interrupted{false};

extern "C" void on_sigint(int) { g_interrupted = true; }

// A progress bar on a terminal, plain lines otherwise; a timed render says
// how long is left.
// Each line ends with the image's estimated relMSE once two passes are in.
spm::Progress progress_printer(bool tty, float budget) {
  const auto started = std::chrono::steady_clock::now();
  return [tty, started, budget](int done, int total, const spm::ErrorEstimate& e) {
    char error[64] = "";
    if (e.relmse >= 0.0) std::snprintf(error, sizeof error, ", estimated relMSE %.2e", e.relmse);
    if (total == 0) {
      const double spent = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      std::cerr << (tty ? "\r" : "") << "spm: " << done << " pass(es) done";
      if (budget > 0.0f) std::cerr << ", " << static_cast<int>(std::ceil(std::max(0.0, budget - spent))) << " s left";
      std::cerr << error << (tty ? "   " : "\n") << std::flush;
    } else if (tty) {
      const int width = 40, filled = width * done / total;
      std::cerr << "\r[" << std::string(filled, '#') << std::string(width - filled, ' ') << "] " << done << "/"
                << total << error << std::flush;
    } else {
      std::cerr << "spm: pass " << done << "/" << total << " done" << error << "\n";
    }
  };
}

void write_profile(const RenderArgs& a, const spm::RenderSettings& settings, const spm::RenderStats& stats,
                   const std::vector<spm::Device*>& devices, spm::Profiler& profiler, const nlohmann::json& used,
                   const nlohmann::json& rank_profiles) {
  if (a.profile) {
    spm::print_kernel_table(std::cout, profiler.kernels());
    std::printf(
        "stages: propagate %.3f s, grid build %.3f s, gather %.3f s, error probe %.3f s; passes %.3f s in all\n",
        stats.propagate_seconds, stats.grid_seconds, stats.gather_seconds, stats.probe_seconds, stats.seconds);
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
    j["settings"] = used;
    for (size_t d = 0; d < devices.size(); ++d) {  // this process's (rank 0's) devices come first
      j["devices"][d]["passes"] = stats.devices[d].passes;
      j["devices"][d]["busy_seconds"] = stats.devices[d].busy_seconds;
    }
    if (!rank_profiles.is_null()) j["ranks"] = rank_profiles;
    spm::write_text(a.profile_json, j.dump(2) + "\n");
  }
  if (!a.trace.empty()) profiler.write_trace(a.trace);
}

int cmd_render(const RenderArgs& a) {
  spm::Profiler profiler(!a.trace.empty());
  double t = profiler.now();
  spm::RenderSettings settings;
  parse_res(a.res, settings);
  settings.dump_maps = a.dump_maps;
  if (!a.terms.empty()) settings.terms = spm::gather_terms(a.terms, "--terms");
  spm::Scene scene = spm::load_scene(a.scene, parse_defines(a.defines));
  for (const spm::Setting& s : spm::settings_table()) {
    if (a.flags.count(s.name)) spm::set_from_flag(s, a.flags.at(s.name), scene.integrator);
  }
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
  nlohmann::json used;  // the settings in use, derived ones included, for the profile
  if (cluster.root()) {
    const std::string ranks =
        cluster.size() > 1 ? " (rank 0 of " + std::to_string(cluster.size()) + " MPI ranks)" : "";
    std::fprintf(stderr, "spm: rendering %s at %dx%d on %s%s\n", a.scene.c_str(), settings.width, settings.height,
                 names.c_str(), ranks.c_str());
    // After the tuning passes where the radius is planned (render.h).
    settings.announce = [&](const spm::Scene& resolved, double pilot_seconds) {
      std::fprintf(stderr, "spm: %s; caustic volume radius %.6g\n", spm::settings_line(resolved.integrator).c_str(),
                   spm::derived_caustic_volume_radius(resolved));
      used = spm::settings_json(resolved.integrator);
      used["caustic_volume_radius"] = spm::derived_caustic_volume_radius(resolved);
      used["pilot_s"] = pilot_seconds;
    };
  }
  if (cluster.root()) {
    settings.planned = [&](int passes, const spm::Plan& plan, float radius) {
      std::fprintf(stderr, "spm: plan after %d passes: radius %.6g (%.3g x derived)%s, predicted relMSE %.3g\n",
                   passes, radius, plan.scale,
                   scene.integrator.time > 0.0f ? (", " + std::to_string(plan.spp) + " samples per pass").c_str() : "",
                   plan.predicted);
    };
  }
  settings.stop = &g_interrupted;
  std::signal(SIGINT, on_sigint);
  const bool tty = ::isatty(STDERR_FILENO);
  spm::RenderStats stats;
  t = profiler.now();
  nlohmann::json rank_profiles;  // several MPI ranks: one profile per rank
  const spm::Image image = spm::render_cluster(scene, settings, devices, &stats,
                                               progress_printer(tty, scene.integrator.time), &profiler, &rank_profiles);
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
  write_profile(a, settings, stats, devices, profiler, used, rank_profiles);
  if (stats.error.relmse >= 0.0) {
    const float target = scene.integrator.target_error;
    std::fprintf(stderr, "spm: estimated relMSE %.3g (variance %.3g, bias %.3g) after %d passes, %.2f s%s\n",
                 stats.error.relmse, stats.error.variance, stats.error.bias, stats.passes, stats.seconds,
                 target > 0.0f ? (stats.error.relmse < target ? "; the target is met" : "; the target is not met")
                               : "");
  }
  for (size_t d = 0; d < stats.devices.size(); ++d) {
    const std::string who = cluster.size() > 1 ? stats.devices[d].name  // named "rank R device D (name)"
                                               : "device " + std::to_string(d) + " (" + stats.devices[d].name + ")";
    std::fprintf(stderr, "spm: %s: %d passes, busy %.2f s\n", who.c_str(), stats.devices[d].passes,
                 stats.devices[d].busy_seconds);
  }
  std::fprintf(stderr, "spm: wrote %s and %s (%d passes in %.2f s; kernel build %.2f s, BVH %.3f s)\n",
               a.output.c_str(), png.c_str(), stats.passes, stats.seconds, stats.build_seconds, stats.bvh_seconds);
  return 0;
}

CLI::App* add_render(CLI::App& app, RenderArgs& r) {
  auto* render = app.add_subcommand("render", "Render a scene file (Mitsuba 3 XML subset) to OpenEXR");
  render->add_option("scene", r.scene, "Scene file")->required();
  render->add_option("-o,--output", r.output, "Output OpenEXR file (32-bit float RGB)")->required();
  render->add_option("--png", r.png, "PNG preview (clamped, sRGB); default: beside the EXR");
  render->add_option("--device", r.device,
                     "Device(s): P:D or a case-insensitive name substring, a comma-separated list, or 'all'; "
                     "default: first GPU, else first CPU");
  render->add_option("--res", r.res, "Resolution WIDTHxHEIGHT, overriding the scene's film");
  render->add_option("-D", r.defines, "Override a <default> of the scene: -D name=value (repeatable)")
      ->allow_extra_args(false);
  add_setting_flags(render, r);
  render->add_flag("--profile", r.profile, "Print per-kernel device times and host stages at the end");
  render->add_option("--profile-json", r.profile_json, "Write the whole profile as JSON (schema: tools/profile.schema.json)");
  render->add_option("--trace", r.trace,
                     "Write a Chrome trace (one track per device queue and the host) for ui.perfetto.dev");
  render->add_option("--device-memory", r.device_memory,
                     "Device memory all of a render's live buffers may hold at once on each device, in bytes (also "
                     "SPM_DEVICE_MEMORY); default: the device's global memory")
      ->check(CLI::PositiveNumber);
  render->add_option("--dump-maps", r.dump_maps,
                     "Write the first pass's maps as PREFIX_volume.ply and PREFIX_surface.ply (position, flux)");
  render->add_option("--terms", r.terms,
                     "Only these terms of the gather, comma-separated (" + spm::kGatherTerms.listed() +
                         "): their part of the image and their cost; default: all (tools/gather_terms.py)")
      ->delimiter(',');
  render->add_option("--kernel-dir", r.kernel_dir, "Load kernels from this directory instead of the embedded sources")
      ->check(CLI::ExistingDirectory);
  return render;
}

CLI::App* add_bench(CLI::App& app, spm::BenchOptions& o, std::string& device) {
  auto* bench = app.add_subcommand(
      "bench", "Time a fixed suite (Fig. 3 (a), (b), scaling in streams and associated photons, a global fog box, "
               "a smoke plume) stage by stage and kernel by kernel: medians of --repeat one-pass renders");
  bench->add_option("--scenes", o.scenes_dir, "Directory holding cornell_fog.xml, fog_box.xml and smoke_cornell.xml")
      ->check(CLI::ExistingDirectory);
  bench->add_option("--repeat", o.repeat, "Timed repetitions after one warm-up")->check(CLI::PositiveNumber);
  bench->add_option("--res", o.resolution, "Square resolution")->check(CLI::Range(1, 16384));
  bench->add_option("--spp", o.spp, "Camera samples per pixel")->check(CLI::PositiveNumber);
  bench->add_option("--csv", o.csv, "Also write the results as CSV");
  bench->add_option("--json", o.json,
                    "Also write the results as JSON, with per-kernel medians and occupancy (tools/plot_bench.py)");
  bench->add_flag("--quick", o.quick, "Fig. 3 (a) and (b) only, without the scaling cases");
  bench->add_option("--cases", o.cases,
                    "Only these cases (fig3a fig3b s10k_a10 s100k_a10 fog_box smoke smoke_step1 smoke_mean)")
      ->delimiter(',');
  bench->add_option("--device", device, "Device, as for render");
  return bench;
}

struct CompareArgs {
  std::string image, reference;
};

CLI::App* add_compare(CLI::App& app, CompareArgs& c) {
  auto* compare = app.add_subcommand(
      "compare", "An image against a reference: RMSE, relMSE (eps 1e-2) and the means, as tools/compare.py");
  compare->add_option("image", c.image, "OpenEXR image")->required()->check(CLI::ExistingFile);
  compare->add_option("reference", c.reference, "OpenEXR reference")->required()->check(CLI::ExistingFile);
  return compare;
}

int cmd_compare(const std::string& image, const std::string& reference) {
  const spm::ImageDifference d = spm::compare_images(spm::read_exr(image), spm::read_exr(reference), image);
  std::printf("RMSE    %.6g\nrelMSE  %.6g  (eps 0.01)\n", d.rmse, d.relmse);
  std::printf("mean    image %.6g %.6g %.6g\n        ref   %.6g %.6g %.6g\n", d.mean[0], d.mean[1], d.mean[2],
              d.reference_mean[0], d.reference_mean[1], d.reference_mean[2]);
  return 0;
}

struct Vdb2VolArgs {
  std::string input, output, grid = "density";
};

CLI::App* add_vdb2vol(CLI::App& app, Vdb2VolArgs& v) {
  auto* vdb2vol = app.add_subcommand(
      "vdb2vol", "Convert a float grid of an OpenVDB file to Mitsuba's .vol, densely over its active voxels, with "
                 "their world-space box as the file's bounding box (use_grid_bbox places it there)");
  vdb2vol->add_option("input", v.input, "OpenVDB file")->required();
  vdb2vol->add_option("output", v.output, ".vol file to write")->required();
  vdb2vol->add_option("--grid", v.grid, "Name of the float grid; default 'density'");
  return vdb2vol;
}

int cmd_vdb2vol(const std::string& input, const std::string& output, const std::string& grid) {
  const spm::VolumeGrid g = spm::read_vdb(input, grid);
  spm::write_vol(output, g);
  std::fprintf(stderr, "spm: wrote %s: %u x %u x %u voxels in (%g, %g, %g) .. (%g, %g, %g), max %g\n", output.c_str(),
               g.nx, g.ny, g.nz, g.bbox_min.x, g.bbox_min.y, g.bbox_min.z, g.bbox_max.x, g.bbox_max.y, g.bbox_max.z,
               g.max_value());
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
  auto* render = add_render(app, r);
  auto* settings = app.add_subcommand(
      "settings", "Print every setting of spm render and every tuning constant, as docs/TUNING.md has them");
  spm::BenchOptions bench_options;
  std::string bench_device;
  auto* bench = add_bench(app, bench_options, bench_device);
  CompareArgs c;
  auto* compare = add_compare(app, c);
  Vdb2VolArgs v;
  auto* vdb2vol = add_vdb2vol(app, v);
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
    if (*settings) std::cout << spm::tuning_markdown();
    if (*compare) return cmd_compare(c.image, c.reference);
    if (*vdb2vol) return cmd_vdb2vol(v.input, v.output, v.grid);
    if (*bench) {
      spm::Device device(spm::select_device(bench_device), "");
      std::cerr << "spm: bench on " << device.info().name << "\n";
      spm::run_bench(device, bench_options);
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
