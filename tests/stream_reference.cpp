#include "stream_reference.h"

#include <Random123/philox.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "spm_streams.h"

namespace spm::ref {

namespace {

// ---- what the kernels' headers define for OpenCL C only -------------------

constexpr float kPi = 3.14159265358979323846f;  // SPM_PI
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr uint32_t kMaxMarchSteps = 1u << 22;  // SPM_MAX_MARCH_STEPS (spm_march.cl)

// Counter purposes (kernels/lib/rng.h).
constexpr uint32_t kRngBsdf = 3, kRngDistance = 4, kRngPhase = 5, kRngAbsorb = 6, kRngRespawn = 7, kRngEmit = 8,
                   kRngRoulette = 10;

// March outcomes (SPM_EV_*).
enum class Event { Medium, Surface, Escape };

// What follows an event: the stages of the kernels' queues (spm_streams.h)
// the stream passes through, as bits.
constexpr uint32_t kDeposit = 1, kAbsorb = 2, kSphere = 4, kDisk = 8, kEnd = 16;

// ---- the device's math library, modelled ------------------------------------
//
// Device and host libraries may round sqrt, exp, log, sin, cos, acos, ...
// differently by a few ulps (OpenCL allows up to 4). With `ulps` > 0 every
// such result moves that many ulps up or down (pseudo-randomly per call), so
// that a second run shows how sensitive each record is to that rounding.

struct Rounding {
  int ulps = 0;
  uint32_t calls = 0;
};
thread_local Rounding t_rounding;

float rounded(float x) {
  if (t_rounding.ulps == 0 || x == 0.0f || !std::isfinite(x)) return x;
  uint32_t h = ++t_rounding.calls * 0x9e3779b9u;  // Fibonacci hashing of the call count
  h ^= h >> 16;
  const float to = (h & 1u) ? kInf : -kInf;
  for (int k = 0; k < t_rounding.ulps; ++k) x = std::nextafter(x, to);
  return x;
}
float fsqrt(float x) { return rounded(std::sqrt(x)); }
float fexp(float x) { return rounded(std::exp(x)); }
float flog(float x) { return rounded(std::log(x)); }
float fexpm1(float x) { return rounded(std::expm1(x)); }
float flog1p(float x) { return rounded(std::log1p(x)); }
float fsin(float x) { return rounded(std::sin(x)); }
float fcos(float x) { return rounded(std::cos(x)); }
float fcbrt(float x) { return rounded(std::cbrt(x)); }
float facos(float x) { return rounded(std::acos(x)); }

// ---- float3 as the kernels use it --------------------------------------------

struct V3 {
  float x = 0, y = 0, z = 0;
};
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator-(V3 a) { return {-a.x, -a.y, -a.z}; }
V3 operator*(V3 a, V3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
V3 operator*(float s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
V3 operator*(V3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
V3 operator/(V3 a, float s) { return {a.x / s, a.y / s, a.z / s}; }
V3 operator/(V3 a, V3 b) { return {a.x / b.x, a.y / b.y, a.z / b.z}; }
float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
float length(V3 a) { return fsqrt(dot(a, a)); }
V3 normalize(V3 a) { return a / length(a); }
V3 vexp(V3 a) { return {fexp(a.x), fexp(a.y), fexp(a.z)}; }
V3 load3(const float* p) { return {p[0], p[1], p[2]}; }
void store3(V3 v, float* p) {
  p[0] = v.x;
  p[1] = v.y;
  p[2] = v.z;
}
float max_comp(V3 v) { return std::fmax(v.x, std::fmax(v.y, v.z)); }
float mean_comp(V3 v) { return (v.x + v.y + v.z) * (1.0f / 3.0f); }
V3 vabs(V3 v) { return {std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)}; }

// ---- kernels/lib/math.h, sampling.h, phase.h ------------------------------------

void make_basis(V3 n, V3* t, V3* b) {
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float c = n.x * n.y * a;
  *t = {1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x};
  *b = {c, sign + n.y * n.y * a, -n.y};
}

V3 to_world(V3 v, V3 n) {
  V3 t, b;
  make_basis(n, &t, &b);
  return v.x * t + v.y * b + v.z * n;
}

V3 offset_origin(V3 p, V3 side_normal, float extent) {
  const float scale = 0.01f * extent + max_comp(vabs(p));
  return p + side_normal * (2e-5f * scale);
}

// kernels/lib/scene.h's SpmScene::extent.
float scene_extent(const SceneTables& sc) {
  if (sc.prims.empty()) return 0.0f;
  const SpmBvhNode& root = sc.nodes[0];
  return max_comp(V3{std::fmax(std::fabs(root.lo[0]), std::fabs(root.hi[0])),
                     std::fmax(std::fabs(root.lo[1]), std::fabs(root.hi[1])),
                     std::fmax(std::fabs(root.lo[2]), std::fabs(root.hi[2]))});
}

V3 sample_cosine_hemisphere(float u1, float u2) {
  const float r = fsqrt(u1);
  const float phi = 2.0f * kPi * u2;
  return {r * fcos(phi), r * fsin(phi), fsqrt(std::fmax(0.0f, 1.0f - u1))};
}

V3 sample_uniform_sphere(float u1, float u2) {
  const float z = 1.0f - 2.0f * u1;
  const float r = fsqrt(std::fmax(0.0f, 1.0f - z * z));
  const float phi = 2.0f * kPi * u2;
  return {r * fcos(phi), r * fsin(phi), z};
}

V3 sample_uniform_cone(float u1, float u2, float cos_max) {
  const float z = 1.0f - u1 * (1.0f - cos_max);
  const float r = fsqrt(std::fmax(0.0f, 1.0f - z * z));
  const float phi = 2.0f * kPi * u2;
  return {r * fcos(phi), r * fsin(phi), z};
}

void sample_disk(float u1, float u2, float* x, float* y) {
  const float r = fsqrt(u1);
  const float phi = 2.0f * kPi * u2;
  *x = r * fcos(phi);
  *y = r * fsin(phi);
}

V3 in_tangent_disk(V3 x, V3 n, float ux, float uy, float radius) {
  V3 t, b;
  make_basis(n, &t, &b);
  return x + radius * (ux * t + uy * b);
}

V3 sample_ball(float u1, float u2, float u3) { return fcbrt(u1) * sample_uniform_sphere(u2, u3); }

// kernels/lib/stream.h's land_on_plane (METHOD.md 1).
V3 land_on_plane(V3 x, V3 n, V3 d, V3 offset) {
  const float dn = dot(d, n), on = dot(offset, n);
  if (std::fabs(dn) < 1e-6f) return x + offset - on * n;
  return x + offset - (on / dn) * d;
}

V3 sample_phase(V3 d, float g, float u1, float u2) {
  float cos_theta;
  if (std::fabs(g) < 1e-3f) {
    cos_theta = 1.0f - 2.0f * u1;
  } else {
    const float sq = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
    cos_theta = std::clamp((1.0f + g * g - sq * sq) / (2.0f * g), -1.0f, 1.0f);
  }
  const float sin_theta = fsqrt(std::fmax(0.0f, 1.0f - cos_theta * cos_theta));
  const float phi = 2.0f * kPi * u2;
  return normalize(to_world({sin_theta * fcos(phi), sin_theta * fsin(phi), cos_theta}, d));
}

// ---- kernels/lib/rng.h -------------------------------------------------------

struct Rng {
  uint32_t seed, pass, id, event;
};

struct U4 {
  float v[4];
};

float u01(uint32_t x) { return static_cast<float>(x >> 8) * (1.0f / 16777216.0f); }

U4 rng4(const Rng& r, uint32_t purpose, uint32_t lane) {
  philox4x32_key_t k = {{r.seed, r.pass}};
  philox4x32_ctr_t c = {{r.id, r.event, purpose, lane}};
  philox4x32_ctr_t x = philox4x32(c, k);
  return {{u01(x.v[0]), u01(x.v[1]), u01(x.v[2]), u01(x.v[3])}};
}

// ---- the stream's decision margins -----------------------------------------

struct Margins {
  StreamResult* out;
  uint32_t event = 0;
  void note(float m, const char* what) {
    m = std::fabs(m);
    if (m < out->margin) {
      out->margin = m;
      out->margin_what = what;
      out->margin_event = event;
    }
  }
};

// ---- kernels/lib/intersect.h, brute force ------------------------------------

struct Hit {
  float t = kInf;
  uint32_t prim = SPM_NONE;
  float u = 0, v = 0;
};

// The kernel's Moller-Trumbore without its range tests: barycentrics and t.
struct TriangleSolve {
  bool valid = false;
  float t = 0, u = 0, v = 0;
};

TriangleSolve solve_triangle(V3 o, V3 d, const SpmPrim& p) {
  TriangleSolve r;
  const V3 p0 = load3(p.p0);
  const V3 e1 = load3(p.p1) - p0;
  const V3 e2 = load3(p.p2) - p0;
  const V3 pv = cross(d, e2);
  const float det = dot(e1, pv);
  if (det == 0.0f) return r;
  const float inv = 1.0f / det;
  const V3 s = o - p0;
  r.u = dot(s, pv) * inv;
  const V3 q = cross(s, e1);
  r.v = dot(d, q) * inv;
  r.t = dot(e2, q) * inv;
  r.valid = true;
  return r;
}

bool hit_triangle(V3 o, V3 d, const SpmPrim& p, float tmax, float* t, float* u, float* v) {
  const TriangleSolve s = solve_triangle(o, d, p);
  if (!s.valid) return false;
  if (s.u < 0.0f || s.u > 1.0f) return false;
  if (s.v < 0.0f || s.u + s.v > 1.0f) return false;
  if (!(s.t > 0.0f && s.t < tmax)) return false;
  *t = s.t;
  *u = s.u;
  *v = s.v;
  return true;
}

// Sphere roots as in the kernel; `disc` is returned for the margin.
struct SphereSolve {
  float disc = -1, t = 0;
};

SphereSolve solve_sphere(V3 o, V3 d, const SpmPrim& p) {
  SphereSolve r;
  const V3 c = load3(p.p0);
  const float rad = p.p1[0];
  const V3 f = o - c;
  const float b = -dot(f, d);
  const V3 l = f + b * d;
  r.disc = rad * rad - dot(l, l);
  if (r.disc < 0.0f) return r;
  const float sq = fsqrt(r.disc);
  const float t0 = b - sq;
  const float t1 = b + sq;
  r.t = t0 > 0.0f ? t0 : t1;
  return r;
}

bool hit_prim(V3 o, V3 d, const SpmPrim& p, float tmax, float* t, float* u, float* v) {
  if (p.kind == SPM_PRIM_SPHERE) {
    *u = 0.0f;
    *v = 0.0f;
    const SphereSolve s = solve_sphere(o, d, p);
    if (s.disc < 0.0f || !(s.t > 0.0f && s.t < tmax)) return false;
    *t = s.t;
    return true;
  }
  return hit_triangle(o, d, p, tmax, t, u, v);
}

bool trace_closest(const SceneTables& sc, V3 o, V3 d, Hit* hit) {
  *hit = Hit{};
  for (uint32_t i = 0; i < sc.prims.size(); ++i) {
    float t, u, v;
    if (hit_prim(o, d, sc.prims[i], hit->t, &t, &u, &v)) *hit = {t, i, u, v};
  }
  return hit->prim != SPM_NONE;
}

// How far inside its outline the ray meets primitive p (< 0: outside):
// the smallest barycentric of a triangle, disc / r^2 of a sphere, and where.
struct Approach {
  bool valid = false;
  float inside = 0, t = 0;
};

Approach approach(V3 o, V3 d, const SpmPrim& p) {
  Approach a;
  if (p.kind == SPM_PRIM_SPHERE) {
    const SphereSolve s = solve_sphere(o, d, p);
    const float r2 = p.p1[0] * p.p1[0];
    a.inside = s.disc / r2;
    if (s.disc < 0.0f) {  // nearest approach of the ray to the sphere
      const V3 f = o - load3(p.p0);
      a.t = -dot(f, d);
    } else {
      a.t = s.t;
    }
    a.valid = a.t > 0.0f;
    return a;
  }
  const TriangleSolve s = solve_triangle(o, d, p);
  a.valid = s.valid && s.t > 0.0f;
  a.inside = std::min({s.u, s.v, 1.0f - s.u - s.v});
  a.t = s.t;
  return a;
}

V3 geometric_normal(const SpmPrim& p, V3 at) {
  if (p.kind == SPM_PRIM_SPHERE) return normalize(at - load3(p.p0));
  const V3 p0 = load3(p.p0);
  return normalize(cross(load3(p.p1) - p0, load3(p.p2) - p0));
}

// Would the device, whose floats differ in the last bits, possibly hit a
// different surface than `hit`? Two primitives are the same surface when they
// belong to the same shape and lie in the same plane (the two triangles of a
// rectangle): which one the ray meets changes nothing. Notes the margin of
// every primitive whose outline lies close to the ray and which competes with
// the hit (nearer than it, or replacing it if the hit were missed).
void note_geometry(const SceneTables& sc, V3 o, V3 d, const Hit& hit, bool found, Margins& m) {
  constexpr float kNear = 1e-3f;  // primitives closer than this to the ray are inspected
  const float t_tol = 1e-4f * (1.0f + (found ? hit.t : 0.0f));
  const auto same_surface = [&](uint32_t a, uint32_t b, V3 at) {
    const SpmPrim &pa = sc.prims[a], &pb = sc.prims[b];
    if (pa.shape != pb.shape) return false;
    if (a == b) return true;
    if (pa.kind == SPM_PRIM_SPHERE || pb.kind == SPM_PRIM_SPHERE) return false;
    return dot(geometric_normal(pa, at), geometric_normal(pb, at)) > 1.0f - 1e-6f;
  };
  // Is the hit itself a close call, and what would the ray meet without it?
  float hit_inside = 1.0f;
  if (found) {
    const Approach a = approach(o, d, sc.prims[hit.prim]);
    hit_inside = a.inside;
  }
  const V3 at = found ? o + hit.t * d : o;
  bool replaced_by_same = false;
  for (uint32_t i = 0; i < sc.prims.size(); ++i) {
    if (found && i == hit.prim) continue;
    const Approach a = approach(o, d, sc.prims[i]);
    if (!a.valid || a.inside < -kNear) continue;
    const bool competes = !found || a.t <= hit.t + t_tol;
    if (found && same_surface(i, hit.prim, at) && std::fabs(a.t - hit.t) <= t_tol) {
      if (a.inside >= -kNear) replaced_by_same = true;
      continue;
    }
    if (!competes) continue;
    // A different surface at or before the hit: its outline decides.
    if (a.inside < 0.0f) {
      m.note(a.inside, "ray near the outline of a nearer primitive");
    } else if (found) {
      // Inside its outline yet not the nearest: the distances decide.
      m.note((a.t - hit.t) / (1.0f + hit.t), "two surfaces at nearly the same distance");
    }
  }
  if (found && !replaced_by_same) m.note(hit_inside, "ray near the outline of the hit primitive");
}

struct Surface {
  V3 p, ng, ns;
  uint32_t shape = 0;
  float extent = 0;
};

Surface surface_at(const SceneTables& sc, V3 o, V3 d, const Hit& h) {
  const SpmPrim& p = sc.prims[h.prim];
  Surface s;
  s.p = o + h.t * d;
  s.shape = p.shape;
  s.extent = scene_extent(sc);
  if (p.kind == SPM_PRIM_SPHERE) {
    s.ng = normalize(s.p - load3(p.p0));
    s.ns = s.ng;
  } else {
    const V3 p0 = load3(p.p0);
    s.ng = normalize(cross(load3(p.p1) - p0, load3(p.p2) - p0));
    s.ns = s.ng;
    if (p.normals != SPM_NONE) {
      const SpmPrimNormals& n = sc.normals[p.normals];
      const V3 ns = (1.0f - h.u - h.v) * load3(n.n0) + h.u * load3(n.n1) + h.v * load3(n.n2);
      const float len = length(ns);
      if (len > 0.0f) s.ns = ns / len;
    }
  }
  if (sc.shapes[s.shape].flags & SPM_SHAPE_FLIP_NORMALS) {
    s.ng = -s.ng;
    s.ns = -s.ns;
  }
  return s;
}

int target_medium(const SpmShape& shape, V3 ng, V3 d, int current) {
  if (shape.interior < 0 && shape.exterior < 0) return current;
  return dot(ng, d) > 0.0f ? shape.exterior : shape.interior;
}

// ---- kernels/lib/bsdf.h ----------------------------------------------------------

float fresnel_dielectric(float cos_i, float eta, float* cos_t) {
  const float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0f) {
    *cos_t = 0.0f;
    return 1.0f;
  }
  *cos_t = fsqrt(1.0f - sin2_t);
  const float rs = (cos_i - eta * *cos_t) / (cos_i + eta * *cos_t);
  const float rp = (eta * cos_i - *cos_t) / (eta * cos_i + *cos_t);
  return 0.5f * (rs * rs + rp * rp);
}

bool reflects_from(const SpmMaterial& m, const Surface& s, V3 d) { return m.twosided || dot(d, s.ng) < 0.0f; }

V3 facing_normal(const Surface& s, V3 d) { return dot(d, s.ng) < 0.0f ? s.ns : -s.ns; }

V3 leave_surface(const Surface& s, V3 d) {
  return offset_origin(s.p, dot(d, s.ng) > 0.0f ? s.ng : -s.ng, s.extent);
}

// specular_bounce with radiance = false; `reflected` tells the dielectric's choice.
float specular_bounce(const SpmMaterial& m, const Surface& s, V3 d, float u, V3* out, bool* reflected, Margins& mg) {
  const V3 n = facing_normal(s, d);
  const float cos_i = std::clamp(-dot(d, n), 0.0f, 1.0f);
  *reflected = true;
  if (m.type == SPM_MAT_MIRROR) {
    if (!reflects_from(m, s, d)) return 0.0f;
    *out = normalize(d + 2.0f * cos_i * n);
    return 1.0f;
  }
  const float eta = dot(d, s.ng) < 0.0f ? m.eta : 1.0f / m.eta;
  float cos_t;
  const float f = fresnel_dielectric(cos_i, eta, &cos_t);
  mg.note(u - f, "Fresnel choice");
  if (u < f) {
    *out = normalize(d + 2.0f * cos_i * n);
    return 1.0f;
  }
  *reflected = false;
  *out = normalize(d / eta + (cos_i / eta - cos_t) * n);
  return 1.0f;
}

// ---- kernels/lib/lights.h, scene.h ------------------------------------------------

float spot_falloff(const SpmLight& l, float cos_theta) {
  if (cos_theta <= l.cos_cutoff) return 0.0f;
  if (cos_theta >= l.cos_beam) return 1.0f;
  return (l.cutoff - facos(std::clamp(cos_theta, -1.0f, 1.0f))) / (l.cutoff - l.beam_width);
}

uint32_t pick_from_cdf(const std::vector<float>& cdf, float u) {
  uint32_t lo = 0, hi = static_cast<uint32_t>(cdf.size()) - 1;
  while (lo < hi) {
    const uint32_t mid = (lo + hi) / 2;
    if (cdf[mid] > u) hi = mid;
    else lo = mid + 1;
  }
  return lo;
}

void sample_area_light_point(const SceneTables& sc, const SpmLight& l, float ux, float uy, float uz, V3* p, V3* n) {
  uint32_t lo = l.prim_begin, hi = l.prim_begin + l.prim_count - 1;
  while (lo < hi) {
    const uint32_t mid = (lo + hi) / 2;
    if (sc.light_prims[mid].cdf > ux) hi = mid;
    else lo = mid + 1;
  }
  const SpmPrim& prim = sc.prims[sc.light_prims[lo].prim];
  if (prim.kind == SPM_PRIM_SPHERE) {
    *n = sample_uniform_sphere(uy, uz);
    *p = load3(prim.p0) + prim.p1[0] * *n;
  } else {
    const float s = fsqrt(uy);
    const float bx = 1.0f - s, by = uz * s;  // sample_triangle
    const V3 p0 = load3(prim.p0), p1 = load3(prim.p1), p2 = load3(prim.p2);
    *p = (1.0f - bx - by) * p0 + bx * p1 + by * p2;
    *n = normalize(cross(p1 - p0, p2 - p0));
  }
  if (sc.shapes[prim.shape].flags & SPM_SHAPE_FLIP_NORMALS) *n = -*n;
}

// ---- spm_march.cl -----------------------------------------------------------------

float free_flight(float sigma, float tmax, float step, const Rng& rng, Margins& m) {
  if (step <= 0.0f) return -flog(1.0f - rng4(rng, kRngDistance, 0).v[0]) / sigma;
  const float p = -fexpm1(-sigma * step);
  for (uint32_t k = 0; k < kMaxMarchSteps; k += 2) {
    // The loop test (float)k * step < tmax against the surface distance.
    if (std::isfinite(tmax)) m.note(((float)k * step - tmax) / (1.0f + tmax), "march step against the surface");
    if (!((float)k * step < tmax)) break;
    const U4 u = rng4(rng, kRngDistance, k / 2);  // two steps per draw
    m.note(u.v[0] - p, "march step interaction");
    if (u.v[0] < p) return (float)k * step - flog1p(-u.v[1] * p) / sigma;
    m.note(u.v[2] - p, "march step interaction");
    if (u.v[2] < p) return (float)(k + 1) * step - flog1p(-u.v[3] * p) / sigma;
  }
  return kInf;
}

// survival() of spm_interact.cl: (c / a, a) with a = mean(c).
struct Survival {
  V3 factor;
  float prob = 0;
};
Survival survival(V3 c) {
  const float a = mean_comp(c);
  return a > 0.0f ? Survival{c / a, a} : Survival{{0, 0, 0}, 0.0f};
}

}  // namespace

const char* to_string(StreamEnd end) {
  switch (end) {
    case StreamEnd::Escaped: return "escaped";
    case StreamEnd::Absorbed: return "absorbed";
    case StreamEnd::MaxBounces: return "max_bounces";
    case StreamEnd::BlackSurface: return "black surface";
    case StreamEnd::MediumCap: return "medium-event cap";
    case StreamEnd::EventCap: return "event cap";
    case StreamEnd::Roulette: return "Russian roulette";
    case StreamEnd::MaxDepth: return "max_depth";
  }
  return "?";
}

uint32_t end_code(StreamEnd end) {
  switch (end) {
    case StreamEnd::Escaped: return SPM_END_ESCAPED;
    case StreamEnd::Absorbed: return SPM_END_ABSORBED;
    case StreamEnd::MaxBounces: return SPM_END_BOUNCES;
    case StreamEnd::BlackSurface: return SPM_END_BLACK;
    case StreamEnd::MediumCap:
    case StreamEnd::EventCap: return SPM_END_CAPPED;
    case StreamEnd::Roulette: return SPM_END_ROULETTE;
    case StreamEnd::MaxDepth: return SPM_END_DEPTH;
  }
  return SPM_END_NONE;
}

// spm_interact's goes_on: 0 when the stream ends after vertex k, else the
// survivors' weight 1 / q of Russian roulette (METHOD.md 10).
float goes_on(uint32_t k, V3 flux, float flux0, const StreamSettings& set, const Rng& rng, StreamResult& out,
              Margins& margins) {
  if (!(set.max_depth == SPM_NONE || k + 2u <= set.max_depth)) {
    out.end = StreamEnd::MaxDepth;
    return 0.0f;
  }
  if (k < set.rr_depth) return 1.0f;
  const float q = std::fmin(0.95f, max_comp(flux) / flux0);
  const float u = rng4(rng, kRngRoulette, 0).v[0];
  if (q < 0.95f) margins.note(u - q, "Russian roulette");
  if (!(u < q)) {
    out.end = StreamEnd::Roulette;
    ++out.roulette;
    return 0.0f;
  }
  return 1.0f / q;
}

StreamResult trace_stream(const SceneTables& sc, const StreamSettings& set, uint32_t id, int ulps) {
  t_rounding = {ulps, id};
  StreamResult out;
  Margins margins{&out};

  // ---- spm_emit ----
  const Rng emit_rng{set.seed, set.pass, id, 0};
  const U4 u0 = rng4(emit_rng, kRngEmit, 0);
  const U4 u1 = rng4(emit_rng, kRngEmit, 1);
  out.light = pick_from_cdf(sc.light_cdf, u0.v[0]);
  const float prob = sc.light_cdf[out.light] - (out.light > 0 ? sc.light_cdf[out.light - 1] : 0.0f);
  const SpmLight& l = sc.lights[out.light];
  V3 p, n, d, power;
  if (l.type == SPM_LIGHT_AREA) {
    sample_area_light_point(sc, l, u0.v[1], u0.v[2], u0.v[3], &p, &n);
    d = to_world(sample_cosine_hemisphere(u1.v[0], u1.v[1]), n);
    power = kPi * l.area * load3(l.emission);
    p = offset_origin(p, n, scene_extent(sc));
  } else if (l.type == SPM_LIGHT_POINT) {
    p = load3(l.position);
    d = sample_uniform_sphere(u1.v[0], u1.v[1]);
    n = d;
    power = 4.0f * kPi * load3(l.emission);
  } else {
    p = load3(l.position);
    const V3 cone = sample_uniform_cone(u1.v[0], u1.v[1], l.cos_cutoff);
    d = normalize(cone.x * load3(l.axis_x) + cone.y * load3(l.axis_y) + cone.z * load3(l.axis_z));
    n = d;
    power = load3(l.emission) * spot_falloff(l, cone.z) * (2.0f * kPi * (1.0f - l.cos_cutoff));
  }
  V3 origin = p, dir = d;
  // spm_respawn: the associated photons' offsets from the leader, the disk
  // across the light's plane at emission (event 0), re-placed after each
  // medium (ball) and diffuse (tangent disk) event; a collapsed stream has none.
  std::vector<V3> offsets(set.associated);
  const auto respawn = [&](uint32_t count, const Rng& rng, bool ball, V3 normal) {
    for (uint32_t j = 0; j < count; ++j) {
      const U4 u = rng4(rng, kRngRespawn, j);
      if (ball) {
        offsets[j] = set.stream_width * sample_ball(u.v[0], u.v[1], u.v[2]);
      } else {
        float dx, dy;
        sample_disk(u.v[0], u.v[1], &dx, &dy);
        offsets[j] = in_tangent_disk(V3{0.0f, 0.0f, 0.0f}, normal, dx, dy, set.stream_width);
      }
    }
  };
  respawn(set.associated, emit_rng, false, n);
  V3 phi = power / (prob * (float)set.streams * (float)set.associated);
  const float flux0 = (float)set.associated * max_comp(phi);
  uint32_t alive = set.associated;
  int medium = l.medium;
  uint32_t bounces = 0, events = 1, medium_events = 0, depth = 0;  // event 0 was the emission
  // spm_interact's depth_counts and goes_on (METHOD.md 10).
  const auto counts = [&](uint32_t k) { return set.max_depth == SPM_NONE || k + 1u <= set.max_depth; };
  bool had_event = false;

  for (;;) {
    const uint32_t event = events;
    margins.event = event;
    const Rng rng{set.seed, set.pass, id, event};

    // ---- spm_march ----
    Hit h;
    const bool surface = trace_closest(sc, origin, dir, &h);
    note_geometry(sc, origin, dir, h, surface, margins);
    Event state = surface ? Event::Surface : Event::Escape;
    float t = h.t;
    if (medium >= 0) {
      const V3 sigma = load3(sc.media[medium].sigma_t);
      const float mean = mean_comp(sigma);
      V3 weight{1.0f, 1.0f, 1.0f};
      const float te = mean > 0.0f ? free_flight(mean, h.t, set.march_step, rng, margins) : kInf;
      if (std::isfinite(h.t) && std::isfinite(te)) {
        margins.note((te - h.t) / (1.0f + h.t), "free flight against the surface");
      }
      if (te < h.t) {
        state = Event::Medium;
        t = te;
        weight = sigma / mean * vexp(-(sigma - V3{mean, mean, mean}) * te);
      } else if (surface) {
        weight = vexp(-(sigma - V3{mean, mean, mean}) * h.t);
      }
      phi = phi * weight;
    }

    // ---- spm_interact ----
    uint32_t n = alive;
    uint32_t act = 0;
    Survival scale;
    V3 event_pos{}, event_dir{}, event_normal{};
    bool event_had_event = false;
    if (state == Event::Escape) {
      act = kEnd;
      ++out.escape_events;
      out.end = StreamEnd::Escaped;
    } else if (state == Event::Medium) {
      const uint32_t k = depth + 1;
      ++out.medium_events;
      if (!counts(k)) {
        act = kEnd;
        out.end = StreamEnd::MaxDepth;
      } else {
        const V3 x = origin + t * dir;
        const SpmMedium& m = sc.media[medium];
        SpmVolumeRecord r{};
        store3(x, r.position);
        store3(dir, r.direction);
        const V3 flux = (float)n * phi;
        store3(flux, r.flux);
        r.stream = id;
        r.depth = k;
        r.medium = medium;
        out.volume.push_back(r);
        out.collapsed_medium_events += out.collapsed;
        depth = k;
        had_event = true;
        const V3 albedo = load3(m.albedo);
        const float w = goes_on(k, flux * albedo, flux0, set, rng, out, margins);
        if (w == 0.0f) {
          act = kEnd;
        } else if (++medium_events >= SPM_MAX_MEDIUM_EVENTS) {
          act = kEnd;
          ++out.capped;
          out.end = StreamEnd::MediumCap;
        } else {
          const U4 u = rng4(rng, kRngPhase, 0);
          const float g = m.phase == SPM_PHASE_HG ? m.g : 0.0f;
          dir = sample_phase(dir, g, u.v[0], u.v[1]);
          origin = x;
          event_pos = x;
          scale = survival(albedo);
          scale.factor = scale.factor * w;
          act = kAbsorb | kSphere;
        }
      }
    } else {
      const Surface surf = surface_at(sc, origin, dir, h);
      const SpmShape& shape = sc.shapes[surf.shape];
      const SpmMaterial& mat = sc.materials[shape.material];
      // Every branch below turns on which side of the surface the ray arrives.
      margins.note(dot(dir, surf.ng), "side of the surface arriving");
      if (mat.type == SPM_MAT_NULL) {
        // A medium boundary is no event: the stream just changes medium.
        medium = target_medium(shape, surf.ng, dir, medium);
        origin = leave_surface(surf, dir);
        ++out.null_events;
      } else if (mat.type != SPM_MAT_DIFFUSE) {
        // Collapse: the associated photons' flux goes to the leader.
        const uint32_t k = depth + 1;
        phi = (float)n * phi;
        n = 1;
        alive = 1;
        out.collapsed = true;
        V3 next;
        bool reflected;
        if (specular_bounce(mat, surf, dir, rng4(rng, kRngBsdf, 0).v[0], &next, &reflected, margins) == 0.0f) {
          act = kEnd;
          ++out.black_events;
          out.end = StreamEnd::BlackSurface;
        } else {
          if (mat.type == SPM_MAT_DIELECTRIC) ++(reflected ? out.fresnel_reflections : out.fresnel_refractions);
          ++out.specular_events;
          depth = k;
          had_event = true;
          const float w = goes_on(k, phi, flux0, set, rng, out, margins);
          if (w == 0.0f) {
            act = kEnd;
          } else {
            margins.note(dot(next, surf.ng), "side of the surface leaving");
            phi = phi * w;
            dir = next;
            medium = target_medium(shape, surf.ng, next, medium);
            origin = leave_surface(surf, next);
          }
        }
      } else if (!reflects_from(mat, surf, dir)) {
        // The back of a one-sided diffuse surface is black (Mitsuba).
        act = kEnd;
        ++out.black_events;
        out.end = StreamEnd::BlackSurface;
      } else {
        const uint32_t k = depth + 1;
        ++out.diffuse_events;
        if (!counts(k)) {
          act = kEnd;
          out.end = StreamEnd::MaxDepth;
        } else {
          out.collapsed_deposits += out.collapsed;
          event_pos = surf.p;
          event_dir = dir;
          event_had_event = had_event;
          event_normal = dot(dir, surf.ng) < 0.0f ? surf.ng : -surf.ng;
          had_event = true;
          depth = k;
          const V3 reflectance = load3(mat.reflectance);
          if (++bounces >= set.max_bounces) {
            act = kDeposit | kEnd;
            out.end = StreamEnd::MaxBounces;
          } else {
            const float w = goes_on(k, (float)n * phi * reflectance, flux0, set, rng, out, margins);
            if (w == 0.0f) {
              act = kDeposit | kEnd;
            } else {
              const U4 u = rng4(rng, kRngBsdf, 0);
              const V3 next = to_world(sample_cosine_hemisphere(u.v[0], u.v[1]), facing_normal(surf, dir));
              margins.note(dot(next, surf.ng), "side of the surface leaving");
              dir = next;
              medium = target_medium(shape, surf.ng, next, medium);
              origin = leave_surface(surf, next);
              scale = survival(reflectance);
              scale.factor = scale.factor * w;
              act = kDeposit | kAbsorb | kDisk;
            }
          }
        }
      }
    }
    events = event + 1;
    if (event + 1 >= SPM_MAX_EVENTS && !(act & kEnd)) {
      // The cap ends the stream at interact: a diffuse event still deposits.
      act = (act & kDeposit) | kEnd;
      ++out.capped;
      out.end = StreamEnd::EventCap;
    }
    uint32_t alive_next = (act & kAbsorb) ? 0u : n;

    // ---- spm_deposit: one record per alive photon, before absorption ----
    if (act & kDeposit) {
      for (uint32_t j = 0; j < n; ++j) {
        const V3 pos = out.collapsed ? event_pos : land_on_plane(event_pos, event_normal, event_dir, offsets[j]);
        SpmSurfaceRecord r{};
        store3(pos, r.position);
        store3(event_dir, r.direction);
        store3(phi, r.flux);
        store3(event_normal, r.normal);
        r.stream = id;
        r.depth_photon = (depth << 16) | j;
        r.flags = event_had_event ? SPM_RECORD_HAD_EVENT : 0u;
        out.surface.push_back(r);
      }
    }

    // ---- spm_absorb: photon j survives if its uniform is below a ----
    if (act & kAbsorb) {
      for (uint32_t j = 0; j < n; ++j) {
        const U4 u = rng4(rng, kRngAbsorb, j / 4);
        if (u.v[j % 4] < scale.prob) ++alive_next;
      }
      phi = phi * scale.factor;
    }

    // ---- spm_respawn gives the survivors new offsets ----
    if ((act & (kSphere | kDisk)) && !out.collapsed) {
      respawn(alive_next, rng, (act & kSphere) != 0, event_normal);
    }
    alive = alive_next;
    if (!(alive > 0 && !(act & kEnd))) {
      if (alive == 0 && !(act & kEnd)) out.end = StreamEnd::Absorbed;
      break;
    }
  }
  out.alive = alive;
  out.events = events;
  store3(phi, out.phi);
  return out;
}

}  // namespace spm::ref
