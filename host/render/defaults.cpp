#include "render/defaults.h"

#include <algorithm>
#include <cmath>

#include "render/render.h"
#include "scene/light_power.h"

namespace spm {

int derived_streams(const IntegratorSettings& in) { return in.streams > 0 ? in.streams : kDefaultStreams; }

int derived_beam_streams(const IntegratorSettings& in) {
  return std::min(derived_streams(in), in.beam_streams > 0 ? in.beam_streams : kDefaultBeamStreams);
}

int derived_associated(const IntegratorSettings& in) {
  return in.associated > 0 ? in.associated : kDefaultAssociated;
}

namespace {

// Whether the volume estimate may take a kernel wider than the radius
// (kVolumeRadiusFactor).
bool wide_volume_kernel(const Scene& scene) {
  const IntegratorSettings& in = scene.integrator;
  const bool homogeneous = std::none_of(scene.media.begin(), scene.media.end(),
                                        [](const Medium& m) { return m.heterogeneous(); });
  return homogeneous && in.estimator == "bre" && in.direct == "nee";
}

}  // namespace

float derived_volume_radius(const Scene& scene) {
  const IntegratorSettings& in = scene.integrator;
  if (in.volume_radius > 0.0f) return in.volume_radius;
  return wide_volume_kernel(scene) ? kVolumeRadiusFactor * in.radius : in.radius;
}

float derived_caustic_volume_radius(const Scene& scene) {
  const float volume_radius = derived_volume_radius(scene);
  if (!wide_volume_kernel(scene)) return volume_radius;
  return std::min(volume_radius, kCausticVolumeRadiusFactor * scene.integrator.radius);
}

void fill_derived(Scene& scene, const RenderSettings& s) {
  IntegratorSettings& in = scene.integrator;
  const auto fill = [&](const char* name, auto& value, auto derived) {
    if (value > 0) return;
    value = derived;
    in.sources[name] = SettingSource::Derived;
  };
  fill("streams", in.streams, derived_streams(in));
  fill("associated", in.associated, derived_associated(in));
  fill("beam_streams", in.beam_streams, derived_beam_streams(in));
  fill("volume_radius", in.volume_radius, derived_volume_radius(scene));
  fill("spp", in.spp, s.spp);
  fill("passes", in.passes, s.passes);
}

int samples_per_pass(const Scene& scene, int width, int height) {
  const double photons = double(derived_streams(scene.integrator)) * derived_associated(scene.integrator);
  const double spp = photons / (kPhotonsPerSample * double(width) * double(height));
  return static_cast<int>(std::clamp(std::lround(spp), 1L, long(kMaxPassSpp)));
}

float neighbour_radius(const std::vector<glm::vec3>& points, int k, int queries) {
  if (points.size() <= size_t(k)) return 0.0f;
  const size_t n = points.size(), q = std::min<size_t>(n, size_t(queries));
  std::vector<float> radii, d2(n);
  for (size_t i = 0; i < q; ++i) {
    const glm::vec3 x = points[i * n / q];
    for (size_t j = 0; j < n; ++j) {
      const glm::vec3 off = points[j] - x;
      d2[j] = glm::dot(off, off);
    }
    // d2 holds the query itself at distance 0: the k-th other point is at index k.
    std::nth_element(d2.begin(), d2.begin() + k, d2.end());
    radii.push_back(std::sqrt(d2[k]));
  }
  std::nth_element(radii.begin(), radii.begin() + radii.size() / 2, radii.end());
  return radii[radii.size() / 2];
}

float pilot_radius(const ScalePilot& pilot) {
  const float v = neighbour_radius(pilot.volume, kScaleNeighbours);
  const float s = neighbour_radius(pilot.surface, kScaleNeighbours);
  if (v > 0.0f && s > 0.0f) return std::min(v, s);
  return std::max(v, s);
}

namespace {

float scene_diagonal(const Scene& scene) {
  auto [lo, hi] = shape_bounds(scene);
  for (const Light& l : scene.lights) {
    if (l.type == Light::Type::Area || l.type == Light::Type::Directional || l.type == Light::Type::Envmap) continue;
    lo = glm::min(lo, l.position);
    hi = glm::max(hi, l.position);
  }
  const float d = glm::length(hi - lo);
  return std::isfinite(d) && d > 0.0f ? d : 1.0f;
}

}  // namespace

Scene derive_scale(const Scene& scene, const ScalePilot& pilot) {
  Scene out = scene;
  IntegratorSettings& in = out.integrator;
  if (!(in.radius > 0.0f)) {
    float r = pilot_radius(pilot);
    if (!(r > 0.0f)) r = scene_diagonal(scene) * kFallbackRadius;
    in.radius = r;
    in.sources["radius"] = SettingSource::Derived;
  }
  if (!(in.stream_width > 0.0f)) {
    in.stream_width = in.radius;  // METHOD.md 8: w = r
    in.sources["width"] = SettingSource::Derived;
  }
  return out;
}

}  // namespace spm
