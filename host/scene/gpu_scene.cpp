#include "scene/gpu_scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "scene/bvh.h"
#include "scene/light_power.h"
#include "util/errors.h"

namespace spm {

namespace {

constexpr double kPi = 3.14159265358979323846;

void put3(float* dst, const glm::vec3& v) {
  dst[0] = v.x;
  dst[1] = v.y;
  dst[2] = v.z;
}

// In double, as the light's power: a small triangle's squared lengths underflow a float.
double triangle_area(const SpmPrim& p) {
  const glm::dvec3 a(p.p0[0], p.p0[1], p.p0[2]);
  const glm::dvec3 b(p.p1[0], p.p1[1], p.p1[2]);
  const glm::dvec3 c(p.p2[0], p.p2[1], p.p2[2]);
  return 0.5 * glm::length(glm::cross(b - a, c - a));
}

double prim_area(const SpmPrim& p) {
  return p.kind == SPM_PRIM_SPHERE ? 4.0 * kPi * double(p.p1[0]) * double(p.p1[0]) : triangle_area(p);
}

// The rectangle the quad of triangles a and b splits, when it is one: its
// four corners in index order a0 a1 a2 a3 (loader.cpp's rectangle and cube
// faces) with a1 - a0 and a3 - a0 at right angles and a2 = a1 + a3 - a0,
// to a relative 1e-4.
std::optional<SpmPatch> quad_patch(const Shape& s, const glm::uvec3& a, const glm::uvec3& b) {
  std::vector<unsigned> ids = {a.x, a.y, a.z, b.x, b.y, b.z};
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  if (ids.size() != 4) return std::nullopt;
  const glm::dvec3 p0(s.positions[ids[0]]), p1(s.positions[ids[1]]), p2(s.positions[ids[2]]), p3(s.positions[ids[3]]);
  const glm::dvec3 eu = p1 - p0, ev = p3 - p0;
  const double lu = glm::length(eu), lv = glm::length(ev);
  if (!(lu > 0.0 && lv > 0.0)) return std::nullopt;
  const double tol = 1e-4 * std::max(lu, lv);
  if (std::abs(glm::dot(eu, ev)) > tol * std::min(lu, lv) || glm::length(p1 + ev - p2) > tol) return std::nullopt;
  SpmPatch patch{};
  put3(patch.center, glm::vec3(0.5 * (p0 + p2)));
  put3(patch.u, glm::vec3(eu / lu));
  put3(patch.v, glm::vec3(ev / lv));
  patch.half_u = static_cast<float>(0.5 * lu);
  patch.half_v = static_cast<float>(0.5 * lv);
  return patch;
}

// Marks the edges of each patch that another patch continues in the same
// plane (a floor of two rectangles): reflecting there would count the
// photons beyond the edge twice. An edge is continued when the point just
// beyond its midpoint lies on another patch of the plane.
void mark_open_edges(std::vector<SpmPatch>& patches) {
  const auto v3 = [](const float* f) { return glm::dvec3(f[0], f[1], f[2]); };
  for (SpmPatch& p : patches) {
    const glm::dvec3 c = v3(p.center), u = v3(p.u), v = v3(p.v), n = glm::cross(u, v);
    const double scale = std::max(p.half_u, p.half_v), eps = 1e-3 * scale;
    const struct {
      glm::dvec3 point;
      spm_uint bit;
    } edges[4] = {{c - (p.half_u + eps) * u, SPM_PATCH_OPEN_U_LO},
                  {c + (p.half_u + eps) * u, SPM_PATCH_OPEN_U_HI},
                  {c - (p.half_v + eps) * v, SPM_PATCH_OPEN_V_LO},
                  {c + (p.half_v + eps) * v, SPM_PATCH_OPEN_V_HI}};
    for (const SpmPatch& o : patches) {
      if (&o == &p) continue;
      const glm::dvec3 oc = v3(o.center), ou = v3(o.u), ov = v3(o.v), on = glm::cross(ou, ov);
      if (std::abs(glm::dot(n, on)) < 1.0 - 1e-4 || std::abs(glm::dot(oc - c, on)) > eps) continue;
      for (const auto& e : edges) {
        const glm::dvec3 q = e.point - oc;
        if (std::abs(glm::dot(q, ou)) <= o.half_u && std::abs(glm::dot(q, ov)) <= o.half_v) p.open |= e.bit;
      }
    }
  }
}

// Largest value any lookup inside majorant cell [lo, hi) of an axis of n
// texels can read: texels floor(lo n - 0.5) .. floor(hi n - 0.5) + 1 (the
// trilinear neighbours; nearest reads a subset), one more each side so that
// rounding of a point on a cell's boundary cannot leave them.
std::pair<uint32_t, uint32_t> majorant_texels(uint32_t cell, uint32_t cells, uint32_t n) {
  const double lo = double(cell) / cells * n - 0.5, hi = double(cell + 1) / cells * n - 0.5;
  const int64_t a = std::max<int64_t>(0, int64_t(std::floor(lo)) - 1);
  const int64_t b = std::min<int64_t>(n - 1, int64_t(std::floor(hi)) + 2);
  return {uint32_t(a), uint32_t(b)};
}

}  // namespace

void append_grid(SceneTables& t, const GridVolume& v) {
  const VolumeGrid& g = v.grid;
  SpmGridVolume out{};
  const glm::mat4 to_local = glm::inverse(v.to_world);
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 4; ++col) out.to_local[4 * row + col] = to_local[col][row];
  out.dims[0] = g.nx;
  out.dims[1] = g.ny;
  out.dims[2] = g.nz;
  out.channels = g.channels;
  out.filter = v.nearest ? SPM_GRID_NEAREST : SPM_GRID_TRILINEAR;
  const uint32_t n[3] = {g.nx, g.ny, g.nz};
  out.voxel = INFINITY;
  for (int a = 0; a < 3; ++a) {
    out.majorant_dims[a] = (n[a] + SPM_MAJORANT_VOXELS - 1) / SPM_MAJORANT_VOXELS;
    out.voxel = std::min(out.voxel, glm::length(glm::vec3(v.to_world[a])) / float(n[a]));
  }
  if (t.grid_data.size() + g.data.size() + size_t(out.majorant_dims[0]) * out.majorant_dims[1] * out.majorant_dims[2] >
      size_t(UINT32_MAX))
    throw InputError(v.where, "the scene's volume grids hold more than 2^32 values");
  out.offset = static_cast<spm_uint>(t.grid_data.size());
  t.grid_data.insert(t.grid_data.end(), g.data.begin(), g.data.end());
  out.majorant_offset = static_cast<spm_uint>(t.grid_data.size());
  for (uint32_t cz = 0; cz < out.majorant_dims[2]; ++cz) {
    const auto [z0, z1] = majorant_texels(cz, out.majorant_dims[2], g.nz);
    for (uint32_t cy = 0; cy < out.majorant_dims[1]; ++cy) {
      const auto [y0, y1] = majorant_texels(cy, out.majorant_dims[1], g.ny);
      for (uint32_t cx = 0; cx < out.majorant_dims[0]; ++cx) {
        const auto [x0, x1] = majorant_texels(cx, out.majorant_dims[0], g.nx);
        float top = 0.0f;
        for (uint32_t z = z0; z <= z1; ++z)
          for (uint32_t y = y0; y <= y1; ++y)
            for (uint32_t x = x0; x <= x1; ++x)
              for (uint32_t c = 0; c < g.channels; ++c)
                top = std::max(top, g.data[((size_t(z) * g.ny + y) * g.nx + x) * g.channels + c]);
        t.grid_data.push_back(top);
      }
    }
  }
  t.grids.push_back(out);
}

namespace {

SpmCamera make_camera(const Camera& c, int width, int height) {
  SpmCamera out{};
  const glm::vec3 origin(c.to_world[3]);
  put3(out.origin, origin);
  put3(out.axis_x, glm::vec3(c.to_world[0]));
  put3(out.axis_y, glm::vec3(c.to_world[1]));
  put3(out.axis_z, glm::vec3(c.to_world[2]));
  const float t = std::tan(glm::radians(c.fov) * 0.5f);
  const float w = static_cast<float>(width), h = static_cast<float>(height);
  Camera::FovAxis axis = c.fov_axis;
  if (axis == Camera::FovAxis::Smaller) axis = w <= h ? Camera::FovAxis::X : Camera::FovAxis::Y;
  if (axis == Camera::FovAxis::Larger) axis = w >= h ? Camera::FovAxis::X : Camera::FovAxis::Y;
  switch (axis) {
    case Camera::FovAxis::X:
      out.tan_half_x = t;
      out.tan_half_y = t * h / w;
      break;
    case Camera::FovAxis::Y:
      out.tan_half_y = t;
      out.tan_half_x = t * w / h;
      break;
    default: {
      const float diag = std::sqrt(w * w + h * h);
      out.tan_half_x = t * w / diag;
      out.tan_half_y = t * h / diag;
    }
  }
  out.near_clip = c.near_clip;
  out.far_clip = c.far_clip;
  out.width = static_cast<spm_uint>(width);
  out.height = static_cast<spm_uint>(height);
  out.medium = c.medium;
  out.filter = c.filter == Camera::Filter::Box ? SPM_FILTER_BOX : SPM_FILTER_GAUSSIAN;
  out.filter_stddev = c.filter_stddev;
  out.filter_radius = 4.0f * c.filter_stddev;  // Mitsuba's Gaussian support
  return out;
}

}  // namespace

SceneTables flatten_scene(const Scene& scene, int width, int height) {
  SceneTables t;
  for (const auto& m : scene.materials) {
    SpmMaterial g{};
    put3(g.reflectance, m.reflectance);
    g.type = m.type == Material::Type::Diffuse   ? SPM_MAT_DIFFUSE
             : m.type == Material::Type::Mirror  ? SPM_MAT_MIRROR
             : m.type == Material::Type::Dielectric ? SPM_MAT_DIELECTRIC
                                                 : SPM_MAT_NULL;
    g.eta = m.int_ior / m.ext_ior;
    g.twosided = m.twosided ? 1u : 0u;
    t.materials.push_back(g);
  }
  for (const auto& m : scene.media) {
    SpmMedium g{};
    put3(g.sigma_t, m.sigma_t);
    put3(g.albedo, m.albedo);
    g.g = m.hg ? m.g : 0.0f;
    g.phase = m.hg ? SPM_PHASE_HG : SPM_PHASE_ISOTROPIC;
    g.sigma_t_grid = m.sigma_t_grid;
    g.albedo_grid = m.albedo_grid;
    t.media.push_back(g);
  }
  for (const GridVolume& v : scene.volumes) append_grid(t, v);
  for (size_t i = 0; i < scene.shapes.size(); ++i) {
    const Shape& s = scene.shapes[i];
    SpmShape g{};
    g.material = static_cast<spm_uint>(s.material);
    g.interior = s.interior;
    g.exterior = s.exterior;
    g.light = s.light;
    g.flags = s.flip_normals ? SPM_SHAPE_FLIP_NORMALS : 0u;
    t.shapes.push_back(g);
    if (s.kind == Shape::Kind::Sphere) {
      SpmPrim p{};
      put3(p.p0, s.center);
      p.p1[0] = s.radius;
      p.kind = SPM_PRIM_SPHERE;
      p.shape = static_cast<spm_uint>(i);
      p.normals = SPM_NONE;
      t.prims.push_back(p);
      continue;
    }
    // SPM_NONE, or the patch triangle k lies on.
    std::vector<spm_uint> patch_of(s.triangles.size(), SPM_NONE);
    if (s.quads && s.normals.empty()) {
      for (size_t k = 0; k + 1 < s.triangles.size(); k += 2) {
        if (const auto patch = quad_patch(s, s.triangles[k], s.triangles[k + 1])) {
          patch_of[k] = patch_of[k + 1] = static_cast<spm_uint>(t.patches.size());
          t.patches.push_back(*patch);
        }
      }
    }
    for (size_t k = 0; k < s.triangles.size(); ++k) {
      const glm::uvec3& tri = s.triangles[k];
      SpmPrim p{};
      put3(p.p0, s.positions[tri.x]);
      put3(p.p1, s.positions[tri.y]);
      put3(p.p2, s.positions[tri.z]);
      p.kind = SPM_PRIM_TRIANGLE;
      p.shape = static_cast<spm_uint>(i);
      p.normals = patch_of[k] == SPM_NONE ? SPM_NONE : (SPM_PRIM_PATCH | patch_of[k]);
      if (!s.normals.empty()) {
        SpmPrimNormals n{};
        put3(n.n0, s.normals[tri.x]);
        put3(n.n1, s.normals[tri.y]);
        put3(n.n2, s.normals[tri.z]);
        p.normals = static_cast<spm_uint>(t.normals.size());
        t.normals.push_back(n);
      }
      t.prims.push_back(p);
    }
  }

  mark_open_edges(t.patches);
  const auto start = std::chrono::steady_clock::now();
  t.nodes = build_bvh(t.prims).nodes;
  t.bvh_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // Lights, after the BVH reordered the primitives.
  std::vector<std::vector<spm_uint>> prims_of_shape(scene.shapes.size());
  for (size_t i = 0; i < t.prims.size(); ++i) prims_of_shape[t.prims[i].shape].push_back(static_cast<spm_uint>(i));
  double total = 0.0;
  std::vector<double> powers;
  for (const auto& l : scene.lights) {
    SpmLight g{};
    const glm::dvec3 power = light_power(scene, l);
    g.power = static_cast<float>((power.x + power.y + power.z) / 3.0);
    g.medium = l.medium;
    // The loader refuses these already; kept for scenes built in code.
    if (!(g.power > 0.0f)) throw InputError(l.where, "light emits no power (zero radiance, intensity or area)");
    if (!std::isfinite(g.power)) throw InputError(l.where, "light power overflows a 32-bit float");
    if (l.type == Light::Type::Area) {
      g.type = SPM_LIGHT_AREA;
      put3(g.emission, l.radiance);
      const auto& ids = prims_of_shape[l.shape];
      g.prim_begin = static_cast<spm_uint>(t.light_prims.size());
      g.prim_count = static_cast<spm_uint>(ids.size());
      double area = 0.0;
      for (spm_uint id : ids) area += prim_area(t.prims[id]);
      double acc = 0.0;
      for (size_t k = 0; k < ids.size(); ++k) {
        acc += prim_area(t.prims[ids[k]]);
        const float cdf = k + 1 == ids.size() ? 1.0f : static_cast<float>(acc / area);
        t.light_prims.push_back({ids[k], cdf});
      }
      g.area = static_cast<float>(area);
    } else {
      g.type = l.type == Light::Type::Point ? SPM_LIGHT_POINT : SPM_LIGHT_SPOT;
      put3(g.emission, l.intensity);
      put3(g.position, glm::vec3(l.type == Light::Type::Point ? glm::vec4(l.position, 1.0f) : l.to_world[3]));
      put3(g.axis_x, glm::normalize(glm::vec3(l.to_world[0])));
      put3(g.axis_y, glm::normalize(glm::vec3(l.to_world[1])));
      put3(g.axis_z, glm::normalize(glm::vec3(l.to_world[2])));
      g.cutoff = glm::radians(l.cutoff_angle);
      g.beam_width = glm::radians(std::min(l.beam_width, l.cutoff_angle));
      g.cos_cutoff = std::cos(g.cutoff);
      g.cos_beam = std::cos(g.beam_width);
    }
    t.lights.push_back(g);
    powers.push_back(g.power);
    total += g.power;
  }
  if (t.lights.empty()) throw InputError(scene.path, "scene has no light");
  double acc = 0.0;
  for (size_t i = 0; i < powers.size(); ++i) {
    acc += powers[i];
    t.light_cdf.push_back(i + 1 == powers.size() ? 1.0f : static_cast<float>(acc / total));
  }
  t.camera = make_camera(scene.camera, width, height);
  return t;
}

GpuScene::GpuScene(Device& device, const SceneTables& t)
    : nodes_(device.upload("nodes", t.nodes)),
      prims_(device.upload("prims", t.prims)),
      normals_(device.upload("normals", t.normals)),
      patches_(device.upload("patches", t.patches)),
      shapes_(device.upload("shapes", t.shapes)),
      materials_(device.upload("materials", t.materials)),
      media_(device.upload("media", t.media)),
      lights_(device.upload("lights", t.lights)),
      light_prims_(device.upload("light_prims", t.light_prims)),
      light_cdf_(device.upload("light_cdf", t.light_cdf)),
      grids_(device.upload("volume grids", t.grids)),
      grid_data_(device.upload("volume grid values", t.grid_data)),
      camera_(device.upload("camera", std::vector<SpmCamera>{t.camera})),
      num_prims_(static_cast<cl_uint>(t.prims.size())),
      num_lights_(static_cast<cl_uint>(t.lights.size())) {
  // Device::upload gives an empty table one element.
  const auto size = [](const auto& v) { return sizeof(v[0]) * std::max<size_t>(1, v.size()); };
  bytes_ = size(t.nodes) + size(t.prims) + size(t.normals) + size(t.patches) + size(t.shapes) + size(t.materials) + size(t.media) +
           size(t.lights) + size(t.light_prims) + size(t.light_cdf) + size(t.grids) + size(t.grid_data) +
           sizeof(SpmCamera);
}

cl_uint GpuScene::bind(cl::Kernel& k, cl_uint i) const {
  // The names of SPM_SCENE_PARAMS (kernels/lib/scene.h).
  const std::pair<const char*, const cl::Buffer*> tables[] = {
      {"scene_nodes", &nodes_},         {"scene_prims", &prims_},   {"scene_normals", &normals_},
      {"scene_patches", &patches_},     {"scene_shapes", &shapes_},       {"scene_materials", &materials_}, {"scene_media", &media_},
      {"scene_lights", &lights_},       {"scene_light_prims", &light_prims_}, {"scene_light_cdf", &light_cdf_},
      {"scene_grids", &grids_},         {"scene_grid_data", &grid_data_}};
  for (const auto& [name, buffer] : tables) bind_arg(k, i++, name, *buffer);
  bind_arg(k, i++, "scene_num_prims", num_prims_);
  bind_arg(k, i++, "scene_num_lights", num_lights_);
  return i;
}

}  // namespace spm
