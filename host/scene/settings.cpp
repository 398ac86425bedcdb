#include "scene/settings.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "render/tuning.h"
#include "scene/xml_props.h"
#include "util/errors.h"

namespace spm {

namespace {

using I = IntegratorSettings;

// A number as the table and its messages print it: "0.9", "10000", "1e+30".
std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

constexpr double kMany = 1 << 30;  // no real upper bound

}  // namespace

const std::vector<Setting>& settings_table() {
  static const std::vector<Setting> rows = {
      {"streams", "--streams", &I::streams, 1, kMany, false, false, {}, nullptr,
       [] {
         return "derived: " + number(kDefaultStreams) +
                ", fewer where a time budget's pass would take more than a tenth of it";
       },
       "Photon streams per pass, N_s", "docs/experiments/defaults.md \"Defaults that follow the scene\""},
      {"associated", "--associated", &I::associated, 1, 65535, false, false, {}, nullptr,
       [] { return "derived: " + number(kDefaultAssociated); }, "Associated photons per stream, N_a",
       "docs/experiments/defaults.md \"Defaults that follow the scene\""},
      {"beam_streams", "--beam-streams", &I::beam_streams, 1, kMany, false, false, {}, nullptr,
       [] { return "derived: " + number(kDefaultBeamStreams) + ", at most the streams"; },
       "With --estimator beams: the streams of a pass whose flights are stored as beams (METHOD.md 11)",
       "docs/experiments/equal-time.md \"Stream beams\""},
      {"radius", "--radius", &I::radius, 0, INFINITY, true, false, {}, nullptr,
       [] {
         return "derived: the median distance to the k-th nearest event of a pilot of the pass's streams, k = " +
                number(kScaleNeighbours) + " (METHOD.md 22)";
       },
       "Search radius r of the estimates in the first pass, shrinking over passes (METHOD.md 6)",
       "docs/experiments/defaults.md \"Defaults that follow the scene\""},
      {"width", "--stream-width", &I::stream_width, 0, INFINITY, true, false, {}, nullptr, [] { return std::string("derived: the radius"); },
       "Stream width w: the sphere and disk the associated photons are placed in (METHOD.md 1)", nullptr},
      {"volume_radius", "--volume-radius", &I::volume_radius, 0, INFINITY, true, false, {}, nullptr,
       [] {
         return "derived: " + number(kVolumeRadiusFactor) +
                " radii where every medium is homogeneous, with bre and direct nee (caustic records " +
                number(kCausticVolumeRadiusFactor) + " radii), else the radius";
       },
       "Kernel radius of the camera segments' volume estimate in the first pass, shrinking as the radius does; "
       "gather rays read the records with the radius where it is smaller (METHOD.md 17)",
       "docs/experiments/volume-kernels.md \"A wider volume kernel by default\""},
      {"alpha", "--alpha", &I::alpha, 0, 1, true, true, {}, nullptr, nullptr,
       "Radius reduction per pass: r_{k+1}^2 = r_k^2 (k + alpha) / (k + 1) (METHOD.md 6)",
       "docs/experiments/defaults.md \"A slower radius schedule\""},
      {"max_bounces", "--bounces", &I::max_bounces, 1, kMany, false, false, -1.0, nullptr,
       [] { return std::string("-1, unlimited"); }, "Diffuse bounces before a stream ends (the paper: 4)",
       nullptr},
      {"max_depth", "--max-depth", &I::max_depth, -1, kMany, false, false, {}, nullptr,
       [] { return std::string("-1, unlimited"); },
       "Longest path in segments, as Mitsuba's volpath counts them (METHOD.md 10)", nullptr},
      {"rr_depth", "--rr-depth", &I::rr_depth, 1, kMany, false, false, {}, nullptr, nullptr,
       "Russian roulette on streams and paths from this path vertex on (METHOD.md 10)", nullptr},
      {"march_step", "--march-step", &I::march_step, 0, INFINITY, false, false, {}, nullptr,
       [] { return std::string("0: exact free flights, delta and ratio tracking in heterogeneous media"); },
       "Ray-marching interval in media, the paper's Delta (METHOD.md 3, 12)", nullptr},
      {"estimator", "--estimator", &I::estimator, 0, 0, false, false, {}, &kEstimatorOption, nullptr,
       "Volume estimate: bre, the beam radiance estimate over the stream records; beams, the stream beams' "
       "beam x beam 1D estimate (METHOD.md 11); paper, eq. (4) of the paper literally, kept to reproduce its "
       "figures: it has no phase function, transmittance or albedo and is not energy-consistent",
       nullptr},
      {"kernel", "--density-kernel", &I::density_kernel, 0, 0, false, false, {}, &kDensityKernelOption, nullptr,
       "Density estimation kernel, normalised over the disk of radius r", nullptr},
      {"direct", "--direct", &I::direct, 0, 0, false, false, {}, &kDirectOption, nullptr,
       "Direct light: nee, by shadow rays with transmittance, on surfaces and as single scattering in media; "
       "photons, from the photon maps alone (the paper's look)",
       nullptr},
      {"final_gather", "--final-gather", &I::final_gather, 0, 0, false, false, {}, nullptr, nullptr,
       "At the camera's first diffuse vertex, gather the photon maps along one cosine-sampled ray instead of "
       "reading them there, caustics excepted; needs direct nee (METHOD.md 16)",
       "docs/experiments/equal-time.md \"Final gather, stream beams and equal time (issue 14)\""},
      {"wall_images", "--wall-images", &I::wall_images, 0, 0, false, false, {}, nullptr, nullptr,
       "Mirror the volume records near walls across them, so that the volume estimate does not darken where "
       "its kernel reaches through a wall (METHOD.md 18)",
       "docs/experiments/volume-kernels.md \"Volume estimates that stop at walls\""},
      {"emission_chains", "--emission-chains", &I::emission_chains, 0, 1024, false, false, {}, nullptr, nullptr,
       "Camera rays per sample that bring the emission seen in pixels that see a mirror or glass, where a "
       "light is an image far smaller than a pixel; 0: each sample's own path (METHOD.md 19)",
       "docs/experiments/caustics.md \"Emission chains: lights seen through glass and in mirrors\""},
      {"volume_every", "--volume-every", &I::volume_every, 1, kMany, false, false, {}, nullptr, nullptr,
       "One camera sample in this many per pixel and pass adds the camera segments' volume estimate, weighted "
       "to stand for the others; 1: every sample (METHOD.md 21)",
       "docs/experiments/volume-kernels.md \"Camera volume estimates for one sample in four\""},
      {"spp", "--spp", &I::spp, 1, 1 << 20, false, false, {}, nullptr,
       [] {
         return "derived: one per " + number(kPhotonsPerSample) + " photons of a pass, 1 .. " +
                number(kMaxPassSpp) + "; a timed render balances them";
       },
       "Camera samples per pixel per pass", "docs/experiments/pass-balance.md \"Passes balanced for error per second\"",
       false},
      {"passes", "--passes", &I::passes, 1, kMany, false, false, {}, nullptr,
       [] { return std::string("enough passes for the sampler's sample_count, the render's samples per pixel"); },
       "Passes, each a full emit, propagate, gather; on the command line it wins over a time budget", nullptr},
      {"time", "--time", &I::time, 0, INFINITY, false, false, {}, nullptr, [] { return std::string("0: no time budget"); },
       "Render passes for this many seconds instead of a pass count; scene load, kernel builds and the pilot "
       "are reported apart",
       nullptr},
      {"target_error", "--target-error", &I::target_error, 0, INFINITY, false, false, {}, nullptr,
       [] { return std::string("0: no target"); },
       "Render passes until the estimated relMSE of the image (METHOD.md 15) is below this; with a time budget, "
       "whichever comes first",
       nullptr},
      {"seed", "--seed", &I::seed, 0, 2147483647, false, false, {}, nullptr, nullptr,
       "Random seed: a pass draws its numbers from (seed, pass) alone (METHOD.md 7)", nullptr, false},
  };
  return rows;
}

const Setting& setting(const std::string& name) {
  for (const Setting& s : settings_table()) {
    if (name == s.name) return s;
  }
  throw std::logic_error("no setting '" + name + "'");
}

std::string setting_problem(const Setting& s, double value) {
  if (s.special && value == *s.special) return "";
  const bool integer = std::holds_alternative<int I::*>(s.member);
  if (!std::isfinite(value) || (integer && value != std::floor(value))) {
    return std::string("must be ") + (integer ? "a whole number" : "a finite number");
  }
  if ((s.lo_open ? value > s.lo : value >= s.lo) && (s.hi_open ? value < s.hi : value <= s.hi)) return "";
  if (s.lo_open && s.lo == 0.0 && std::isinf(s.hi)) return "must be positive";
  if (!s.lo_open && s.lo == 0.0 && std::isinf(s.hi)) return "must not be negative";
  std::string range;
  if (s.hi >= kMany) {
    range = "must be at least " + number(s.lo);
  } else if (s.lo_open || s.hi_open) {
    range = "must be in " + std::string(s.lo_open ? "(" : "[") + number(s.lo) + ", " + number(s.hi) +
            (s.hi_open ? ")" : "]");
  } else {
    range = "must be in " + number(s.lo) + " .. " + number(s.hi);
  }
  if (s.special) range += ", or " + number(*s.special);
  return range;
}

std::string setting_problem(const Setting& s, const std::string& value) {
  if (!s.names || s.names->has(value)) return "";
  return "unknown " + std::string(s.names->what) + " '" + value + "' (" + s.names->listed() + ")";
}

void read_setting(xml::Props& p, const Setting& s, IntegratorSettings& in) {
  bool given = false;
  std::visit(
      [&](auto member) {
        using T = std::decay_t<decltype(in.*member)>;
        std::optional<T> v;
        if constexpr (std::is_same_v<T, int>) v = p.get_int(s.name);
        if constexpr (std::is_same_v<T, float>) v = p.get_float(s.name);
        if constexpr (std::is_same_v<T, bool>) v = p.get_bool(s.name);
        if constexpr (std::is_same_v<T, std::string>) v = p.get_string(s.name);
        if (!v) return;
        std::string problem;
        if constexpr (std::is_same_v<T, std::string>) problem = setting_problem(s, *v);
        if constexpr (std::is_same_v<T, int> || std::is_same_v<T, float>) problem = setting_problem(s, double(*v));
        if (!problem.empty()) {
          p.fail(s.name, problem.rfind("unknown", 0) == 0 ? problem : std::string(s.name) + " " + problem);
        }
        in.*member = *v;
        given = true;
      },
      s.member);
  if (given) in.sources[s.name] = SettingSource::Scene;
}

void read_settings(xml::Props& p, IntegratorSettings& in) {
  for (const Setting& s : settings_table()) {
    if (s.xml) read_setting(p, s, in);
  }
}

void set_from_flag(const Setting& s, const std::string& value, IntegratorSettings& in) {
  const std::string flag = s.flag;
  std::visit(
      [&](auto member) {
        using T = std::decay_t<decltype(in.*member)>;
        if constexpr (std::is_same_v<T, std::string>) {
          const std::string problem = setting_problem(s, value);
          if (!problem.empty()) throw InputError(flag, problem);
          in.*member = value;
        } else if constexpr (std::is_same_v<T, bool>) {
          in.*member = value == "true";
        } else {
          char* end = nullptr;
          const double v = std::strtod(value.c_str(), &end);
          if (value.empty() || *end != 0) throw InputError(flag, "expected a number, got '" + value + "'");
          const std::string problem = setting_problem(s, v);
          if (!problem.empty()) throw InputError(flag, problem + ", got '" + value + "'");
          in.*member = T(v);
        }
      },
      s.member);
  in.sources[s.name] = SettingSource::CommandLine;
}

void check_settings(const IntegratorSettings& in, const std::string& path) {
  for (const Setting& s : settings_table()) {
    std::string problem;
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(in.*member)>;
          if constexpr (std::is_same_v<T, std::string>) problem = setting_problem(s, in.*member);
          if constexpr (std::is_same_v<T, int> || std::is_same_v<T, float>) {
            // A left-out setting's default may stand for "derived" (0).
            if (!(s.unset && in.source(s.name) == SettingSource::Default && in.*member == IntegratorSettings{}.*member))
              problem = setting_problem(s, double(in.*member));
          }
        },
        s.member);
    if (!problem.empty()) {
      throw InputError(in.where.empty() ? path : in.where,
                       std::string(s.name) + " " + problem + " (" + s.flag + ")");
    }
  }
}

std::string setting_text(const Setting& s, const IntegratorSettings& in) {
  return std::visit(
      [&](auto member) -> std::string {
        using T = std::decay_t<decltype(in.*member)>;
        if constexpr (std::is_same_v<T, std::string>) return in.*member;
        if constexpr (std::is_same_v<T, bool>) return in.*member ? "true" : "false";
        if constexpr (std::is_same_v<T, int> || std::is_same_v<T, float>) return number(double(in.*member));
      },
      s.member);
}

nlohmann::json setting_json(const Setting& s, const IntegratorSettings& in) {
  return std::visit([&](auto member) { return nlohmann::json(in.*member); }, s.member);
}

namespace {

const char* source_name(SettingSource s) {
  switch (s) {
    case SettingSource::Scene: return "scene";
    case SettingSource::CommandLine: return "command line";
    case SettingSource::Derived: return "derived";
    case SettingSource::Default: break;
  }
  return "default";
}

}  // namespace

std::string settings_line(const IntegratorSettings& used) {
  std::string line;
  for (const Setting& s : settings_table()) {
    line += (line.empty() ? "" : ", ") + std::string(s.name) + " " + setting_text(s, used);
    const SettingSource src = used.source(s.name);
    if (src == SettingSource::Scene && used.integrator_type != "spm") {
      line += " (scene, " + used.integrator_type + ")";
    } else if (src != SettingSource::Default) {
      line += std::string(" (") + source_name(src) + ")";
    }
  }
  return line;
}

nlohmann::json settings_json(const IntegratorSettings& used) {
  nlohmann::json j, sources;
  for (const Setting& s : settings_table()) {
    j[s.name] = setting_json(s, used);
    sources[s.name] = source_name(used.source(s.name));
  }
  j["sources"] = sources;
  j["integrator"] = used.integrator_type;
  return j;
}

std::string setting_default(const Setting& s) {
  if (s.unset) return s.unset();
  return setting_text(s, IntegratorSettings{});
}

std::string setting_help(const Setting& s) {
  std::string help = std::string(s.help) + " (";
  if (s.xml) help += "integrator '" + std::string(s.name) + "'; ";
  if (s.names) help += "one of " + s.names->listed() + "; ";
  return help + "default " + setting_default(s) + ")";
}

}  // namespace spm
