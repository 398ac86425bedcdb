#include "scene/gpu_scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>

#include "render/tuning.h"
#include "scene/bvh.h"
#include "scene/fresnel.h"
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

// Half the diagonal of the bounding box of an area light's primitives.
double light_size(const SceneTables& t, const SpmLight& l) {
  if (l.type != SPM_LIGHT_AREA) return 0.0;
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (spm_uint k = l.prim_begin; k < l.prim_begin + l.prim_count; ++k) {
    const SpmPrim& p = t.prims[t.light_prims[k].prim];
    if (p.kind == SPM_PRIM_SPHERE) {
      const glm::dvec3 c(p.p0[0], p.p0[1], p.p0[2]);
      lo = glm::min(lo, c - double(p.p1[0]));
      hi = glm::max(hi, c + double(p.p1[0]));
    } else {
      for (const float* v : {p.p0, p.p1, p.p2}) {
        lo = glm::min(lo, glm::dvec3(v[0], v[1], v[2]));
        hi = glm::max(hi, glm::dvec3(v[0], v[1], v[2]));
      }
    }
  }
  return 0.5 * glm::length(hi - lo);
}

// SpmLight::aim of every light: its share of the power of the small lights
// in a medium (kAimedLightSize), 0 for the others.
// Appends the environment map of l to `data` for the kernels
// (kernels/lib/lights.h): its texels, the CDF over its rows of cells and
// each row's over its cells. A cell's weight is its mean luminance under
// the bilinear lookup (4 x 4 midpoints), so that a small bright sun's cells
// are weighed by the light they hold, not by their brightest texel; but at
// least 1/8 of the brightest texel the lookup reads anywhere in the cell,
// since a sliver of the cell between its midpoints and its edge may read a
// texel none of them reads, whose light a weight of 0 there would lose;
// times its solid angle. Every direction with light then has a positive
// density.
void append_environment(std::vector<float>& data, SpmLight& g, const Light& l) {
  const int w = l.map_width, h = l.map_height;
  g.prim_begin = static_cast<spm_uint>(data.size());
  g.prim_count = static_cast<spm_uint>(w);
  g.map_height = static_cast<spm_uint>(h);
  std::vector<double> lum(l.map.size());
  for (size_t k = 0; k < l.map.size(); ++k) {
    const glm::vec3& c = l.map[k];
    data.insert(data.end(), {c.x, c.y, c.z});
    lum[k] = 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;  // linear sRGB luminance, as Mitsuba weighs it
  }
  // The lookup of lights.h's env_radiance at (u, theta / pi), in luminance.
  const auto lookup = [&](double u, double v) {
    const double xf = u * w - 0.5, yf = v * (h - 1);
    const double x0 = std::floor(xf), fx = xf - x0;
    const int ix0 = (int(x0) + w) % w, ix1 = (ix0 + 1) % w;
    const int iy0 = std::min(int(yf), h - 1), iy1 = std::min(iy0 + 1, h - 1);
    const double fy = yf - iy0;
    const auto at = [&](int x, int y) { return lum[size_t(y) * w + x]; };
    return (1 - fy) * ((1 - fx) * at(ix0, iy0) + fx * at(ix1, iy0)) + fy * ((1 - fx) * at(ix0, iy1) + fx * at(ix1, iy1));
  };
  constexpr int kSub = 4;
  std::vector<double> cells(size_t(w) * h), rows(h, 0.0);
  for (int j = 0; j < h; ++j) {
    const double solid_angle = 2.0 * kPi / w * (std::cos(kPi * j / h) - std::cos(kPi * (j + 1) / h));
    // The rows the lookup reads in the cell's band of theta.
    const int y0 = static_cast<int>(std::floor(double(j) * (h - 1) / h));
    const int y1 = std::min(h - 1, static_cast<int>(std::ceil(double(j + 1) * (h - 1) / h)));
    for (int i = 0; i < w; ++i) {
      double mean = 0.0;
      for (int a = 0; a < kSub; ++a)
        for (int b = 0; b < kSub; ++b) mean += lookup((i + (a + 0.5) / kSub) / w, (j + (b + 0.5) / kSub) / h);
      double top = 0.0;
      for (int y = y0; y <= y1; ++y)
        for (int x = i - 1; x <= i + 1; ++x) top = std::max(top, lum[size_t(y) * w + size_t((x + w) % w)]);
      cells[size_t(j) * w + i] = std::max(mean / (kSub * kSub), top / (2 * kSub)) * solid_angle;
      rows[j] += cells[size_t(j) * w + i];
    }
  }
  const double total = std::accumulate(rows.begin(), rows.end(), 0.0);
  double acc = 0.0;
  for (int j = 0; j < h; ++j) {
    acc += rows[j];
    data.push_back(j + 1 == h ? 1.0f : static_cast<float>(total > 0.0 ? acc / total : double(j + 1) / h));
  }
  for (int j = 0; j < h; ++j) {
    double in_row = 0.0;
    for (int i = 0; i < w; ++i) {
      in_row += cells[size_t(j) * w + i];
      data.push_back(i + 1 == w ? 1.0f
                                : static_cast<float>(rows[j] > 0.0 ? in_row / rows[j] : double(i + 1) / w));
    }
  }
}

void aim_at_small_lights(SceneTables& t) {
  double diagonal = 0.0;
  if (!t.nodes.empty()) {
    const SpmBvhNode& root = t.nodes[0];
    diagonal = glm::length(glm::dvec3(root.hi[0] - root.lo[0], root.hi[1] - root.lo[1], root.hi[2] - root.lo[2]));
  }
  std::vector<bool> aimed;
  double total = 0.0;
  for (const SpmLight& l : t.lights) {
    aimed.push_back(l.medium >= 0 && l.type != SPM_LIGHT_DIRECTIONAL && l.type != SPM_LIGHT_ENVMAP &&
                    light_size(t, l) <= kAimedLightSize * diagonal);
    if (aimed.back()) total += l.power;
  }
  for (size_t i = 0; i < t.lights.size(); ++i) {
    t.lights[i].aim = aimed[i] ? float(double(t.lights[i].power) / total) : 0.0f;
  }
}

glm::dvec3 prim_centroid(const SpmPrim& p) {
  const glm::dvec3 a(p.p0[0], p.p0[1], p.p0[2]);
  if (p.kind == SPM_PRIM_SPHERE) return a;
  return (a + glm::dvec3(p.p1[0], p.p1[1], p.p1[2]) + glm::dvec3(p.p2[0], p.p2[1], p.p2[2])) / 3.0;
}

// The rectangle that triangles a and b tile, when they do: they share two
// corners d0 and d1 (its diagonal), by position, so that vertices split
// for their normals or texture coordinates still match, and their other
// corners ca and cb satisfy ca + cb = d0 + d1 (a parallelogram) with
// d0 - ca and d1 - ca at right angles, both to a relative 1e-4. This holds
// for rectangle and cube faces (loader.cpp) and for the quads of an OBJ
// file, which tinyobjloader splits into consecutive triangles.
std::optional<SpmPatch> quad_patch(const std::vector<glm::vec3>& pos, const glm::uvec3& a, const glm::uvec3& b) {
  const glm::dvec3 pa[3] = {glm::dvec3(pos[a.x]), glm::dvec3(pos[a.y]), glm::dvec3(pos[a.z])};
  const glm::dvec3 pb[3] = {glm::dvec3(pos[b.x]), glm::dvec3(pos[b.y]), glm::dvec3(pos[b.z])};
  bool shared_a[3] = {false, false, false}, shared_b[3] = {false, false, false};
  int shared = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (pa[i] == pb[j] && !shared_a[i] && !shared_b[j]) {
        shared_a[i] = shared_b[j] = true;
        ++shared;
      }
  if (shared != 2) return std::nullopt;
  glm::dvec3 diagonal[2], ca{}, cb{};
  int ends = 0;
  for (int i = 0; i < 3; ++i) {
    if (shared_a[i]) diagonal[ends++] = pa[i];
    else ca = pa[i];
    if (!shared_b[i]) cb = pb[i];
  }
  const glm::dvec3 eu = diagonal[0] - ca, ev = diagonal[1] - ca;
  const double lu = glm::length(eu), lv = glm::length(ev);
  if (!(lu > 0.0 && lv > 0.0)) return std::nullopt;
  const double tol = 1e-4 * std::max(lu, lv);
  if (std::abs(glm::dot(eu, ev)) > 1e-4 * lu * lv || glm::length(ca + cb - diagonal[0] - diagonal[1]) > tol)
    return std::nullopt;
  SpmPatch patch{};
  put3(patch.center, glm::vec3(0.5 * (diagonal[0] + diagonal[1])));
  put3(patch.u, glm::vec3(eu / lu));
  put3(patch.v, glm::vec3(ev / lv));
  patch.half_u = static_cast<float>(0.5 * lu);
  patch.half_v = static_cast<float>(0.5 * lv);
  return patch;
}

// Whether triangle pair k, k + 1 may be a patch: without vertex normals, or
// with all six equal to the pair's geometric normal (a flat quad of an OBJ
// file with normals), which shades the same without them.
bool flat_pair(const Shape& s, const glm::uvec3& a, const glm::uvec3& b) {
  if (s.normals.empty()) return true;
  for (const glm::uvec3& t : {a, b}) {
    const glm::dvec3 p0(s.positions[t.x]), p1(s.positions[t.y]), p2(s.positions[t.z]);
    const glm::dvec3 ng = glm::normalize(glm::cross(p1 - p0, p2 - p0));
    for (const unsigned i : {t.x, t.y, t.z})
      if (glm::dot(glm::dvec3(s.normals[i]), ng) < 1.0 - 1e-6) return false;
  }
  return true;
}

// Whether q lies on a triangle of the scene, other than those of patch
// `self`, in the plane through q with unit normal n (to eps): a BVH point
// query, so that marking the edges costs O(P log P) in the primitives.
bool on_coplanar_triangle(const SceneTables& t, const glm::dvec3& q, const glm::dvec3& n, double eps,
                          spm_uint self) {
  std::vector<spm_uint> stack = {0};
  while (!stack.empty()) {
    const SpmBvhNode& node = t.nodes[stack.back()];
    const spm_uint index = stack.back();
    stack.pop_back();
    bool inside = true;
    for (int a = 0; a < 3; ++a) inside = inside && q[a] >= node.lo[a] - eps && q[a] <= node.hi[a] + eps;
    if (!inside) continue;
    if (SPM_BVH_COUNT(node) == 0) {
      stack.push_back(index + 1);
      stack.push_back(node.offset);
      continue;
    }
    for (spm_uint i = node.offset; i < node.offset + SPM_BVH_COUNT(node); ++i) {
      const SpmPrim& p = t.prims[i];
      if (p.kind != SPM_PRIM_TRIANGLE || p.normals == (SPM_PRIM_PATCH | self)) continue;
      const glm::dvec3 p0(p.p0[0], p.p0[1], p.p0[2]), p1(p.p1[0], p.p1[1], p.p1[2]), p2(p.p2[0], p.p2[1], p.p2[2]);
      const glm::dvec3 m = glm::cross(p1 - p0, p2 - p0);
      const double twice_area = glm::length(m);
      if (std::abs(glm::dot(m, n)) < (1.0 - 1e-4) * twice_area || std::abs(glm::dot(q - p0, m)) > eps * twice_area)
        continue;
      // Barycentric signs, each edge's sub-triangle against the whole.
      const double w0 = glm::dot(glm::cross(p1 - q, p2 - q), m), w1 = glm::dot(glm::cross(p2 - q, p0 - q), m),
                   w2 = glm::dot(glm::cross(p0 - q, p1 - q), m);
      if (w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0) return true;
    }
  }
  return false;
}

// Marks the edges of each patch that the surface continues across in the
// same plane (a floor of two rectangles, an OBJ floor of many quads, a
// rectangle beside a coplanar triangle): reflecting there would count the
// photons beyond the edge twice. An edge is continued when the point just
// beyond its midpoint lies on another triangle of the plane.
void mark_open_edges(SceneTables& t) {
  const auto v3 = [](const float* f) { return glm::dvec3(f[0], f[1], f[2]); };
  for (size_t i = 0; i < t.patches.size(); ++i) {
    SpmPatch& p = t.patches[i];
    const glm::dvec3 c = v3(p.center), u = v3(p.u), v = v3(p.v), n = glm::cross(u, v);
    const double eps = 1e-3 * std::max(p.half_u, p.half_v);
    const struct {
      glm::dvec3 point;
      spm_uint bit;
    } edges[4] = {{c - (p.half_u + eps) * u, SPM_PATCH_OPEN_U_LO},
                  {c + (p.half_u + eps) * u, SPM_PATCH_OPEN_U_HI},
                  {c - (p.half_v + eps) * v, SPM_PATCH_OPEN_V_LO},
                  {c + (p.half_v + eps) * v, SPM_PATCH_OPEN_V_HI}};
    for (const auto& e : edges)
      if (on_coplanar_triangle(t, e.point, n, eps, static_cast<spm_uint>(i))) p.open |= e.bit;
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
    using T = Material::Type;
    g.type = m.type == T::Diffuse           ? SPM_MAT_DIFFUSE
             : m.type == T::Conductor       ? SPM_MAT_CONDUCTOR
             : m.type == T::Dielectric      ? SPM_MAT_DIELECTRIC
             : m.type == T::ThinDielectric  ? SPM_MAT_THIN_DIELECTRIC
             : m.type == T::RoughConductor  ? SPM_MAT_ROUGH_CONDUCTOR
             : m.type == T::RoughDielectric ? SPM_MAT_ROUGH_DIELECTRIC
             : m.type == T::Plastic         ? SPM_MAT_PLASTIC
                                            : SPM_MAT_NULL;
    g.eta = m.int_ior / m.ext_ior;
    g.twosided = m.twosided ? 1u : 0u;
    // Mitsuba clamps the roughness there, so that D stays finite.
    g.alpha = std::max(m.alpha, 1e-4f);
    g.distribution = m.distribution == Material::Distribution::GGX ? SPM_MICROFACET_GGX : SPM_MICROFACET_BECKMANN;
    put3(g.specular, m.specular);
    put3(g.k_eta, m.eta);
    put3(g.k, m.k);
    // Light inside a plastic's coat meets it from the dense side.
    g.fdr_int = m.type == T::Plastic ? float(fresnel_diffuse_reflectance(1.0 / double(g.eta))) : 0.0f;
    g.nonlinear = m.nonlinear ? 1u : 0u;
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
    // SPM_NONE, or the patch triangle k lies on: consecutive pairs that tile
    // a rectangle, taken greedily.
    std::vector<spm_uint> patch_of(s.triangles.size(), SPM_NONE);
    for (size_t k = 0; k + 1 < s.triangles.size(); ++k) {
      if (!flat_pair(s, s.triangles[k], s.triangles[k + 1])) continue;
      if (const auto patch = quad_patch(s.positions, s.triangles[k], s.triangles[k + 1])) {
        patch_of[k] = patch_of[k + 1] = static_cast<spm_uint>(t.patches.size());
        t.patches.push_back(*patch);
        t.patch_shapes.push_back(static_cast<spm_uint>(i));
        ++k;
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
      if (!s.normals.empty() && patch_of[k] == SPM_NONE) {
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

  const auto start = std::chrono::steady_clock::now();
  t.nodes = build_bvh(t.prims).nodes;
  t.bvh_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  mark_open_edges(t);

  // Lights, after the BVH reordered the primitives.
  std::vector<std::vector<spm_uint>> prims_of_shape(scene.shapes.size());
  for (size_t i = 0; i < t.prims.size(); ++i) prims_of_shape[t.prims[i].shape].push_back(static_cast<spm_uint>(i));
  double total = 0.0;
  std::vector<double> powers;
  std::vector<float> light_data;  // the environment maps, after the CDF in t.light_cdf
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
      glm::dvec3 centroid(0.0);
      for (spm_uint id : ids) {
        const double a = prim_area(t.prims[id]);
        area += a;
        centroid += a * prim_centroid(t.prims[id]);
      }
      if (area > 0.0) put3(g.position, glm::vec3(centroid / area));
      double acc = 0.0;
      for (size_t k = 0; k < ids.size(); ++k) {
        acc += prim_area(t.prims[ids[k]]);
        const float cdf = k + 1 == ids.size() ? 1.0f : static_cast<float>(acc / area);
        t.light_prims.push_back({ids[k], cdf});
      }
      g.area = static_cast<float>(area);
    } else if (l.type == Light::Type::Directional) {
      // Streams start on the disk across the light's direction that covers
      // the bounding sphere, centred on it and just outside it (METHOD.md 14).
      g.type = SPM_LIGHT_DIRECTIONAL;
      put3(g.emission, l.irradiance);
      const BoundingSphere b = scene_bounding_sphere(scene);
      const glm::vec3 w = l.direction;
      const glm::vec3 u = unit_perpendicular(w);
      put3(g.axis_x, u);
      put3(g.axis_y, glm::cross(w, u));
      put3(g.axis_z, w);
      put3(g.position, glm::vec3(b.center - glm::dvec3(w) * (1.001 * b.radius)));
      g.disk_radius = static_cast<float>(b.radius);
      g.area = static_cast<float>(light_extent(scene, l));
    } else if (l.type == Light::Type::Envmap) {
      g.type = SPM_LIGHT_ENVMAP;
      put3(g.emission, glm::vec3(l.scale));
      put3(g.axis_x, l.frame[0]);
      put3(g.axis_y, l.frame[1]);
      put3(g.axis_z, l.frame[2]);
      const BoundingSphere b = scene_bounding_sphere(scene);
      put3(g.position, glm::vec3(b.center));
      g.disk_radius = static_cast<float>(b.radius);
      g.area = static_cast<float>(kPi * b.radius * b.radius);
      append_environment(light_data, g, l);
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
  aim_at_small_lights(t);
  double acc = 0.0;
  for (size_t i = 0; i < powers.size(); ++i) {
    acc += powers[i];
    t.light_cdf.push_back(i + 1 == powers.size() ? 1.0f : static_cast<float>(acc / total));
  }
  t.light_cdf.insert(t.light_cdf.end(), light_data.begin(), light_data.end());
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
