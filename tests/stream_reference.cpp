#include "stream_reference.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "cl_compat.h"
#include "spm_streams.h"

namespace spm::ref {

// The kernels' own helpers (kernels/lib/, through tests/cl_compat.h), their
// sqrt, exp, log, ... moved by clc::t_rounding's ulps; the reference around
// them is its own sequential model of the stream kernels.
using namespace clc;

namespace {

constexpr uint32_t kMaxMarchSteps = 1u << 22;  // SPM_MAX_MARCH_STEPS (kernels/lib/medium.h)

// March outcomes (SPM_EV_*).
enum class Event { Medium, Surface, Escape };

// What follows an event: the stages of the kernels' queues (spm_streams.h)
// the stream passes through, as bits.
constexpr uint32_t kDeposit = 1, kAbsorb = 2, kSphere = 4, kDisk = 8, kEnd = 16;

// The scene as the kernels' SPM_SCENE sees it (kernels/lib/scene.h).
SpmScene scene_of(const SceneTables& t) {
  return make_scene(t.nodes.data(), t.prims.data(), t.normals.data(), t.patches.data(), t.shapes.data(), t.materials.data(),
                    t.media.data(), t.lights.data(), t.light_prims.data(), t.light_cdf.data(), t.grids.data(),
                    t.grid_data.data(), static_cast<uint>(t.prims.size()), static_cast<uint>(t.lights.size()));
}

// Uniform k (0..3) of a draw, as spm_absorb picks photon j's.
float lane(float4 u, uint32_t k) { return k == 0 ? u.x : k == 1 ? u.y : k == 2 ? u.z : u.w; }

// ---- kernels/lib/stream.h and lights.h --------------------------------------------
//
// These headers use OpenCL swizzles (frame.xyz, u.yzw), which cl_compat.h's
// plain structs cannot offer, so the reference keeps its own copies of what it
// needs from them.

// land_on_plane (METHOD.md 1).
float3 land_on_plane(float3 x, float3 n, float3 d, float3 offset) {
  const float dn = dot(d, n), on = dot(offset, n);
  if (fabs(dn) < 1e-6f) return x + offset - on * n;
  return x + offset - (on / dn) * d;
}

float3 in_tangent_disk(float3 x, float3 n, float2 u, float radius) {
  float3 t, b;
  make_basis(n, &t, &b);
  return x + radius * (u.x * t + u.y * b);
}

float spot_falloff(const SpmLight& l, float cos_theta) {
  if (cos_theta <= l.cos_cutoff) return 0.0f;
  if (cos_theta >= l.cos_beam) return 1.0f;
  return (l.cutoff - acos(clamp(cos_theta, -1.0f, 1.0f))) / (l.cutoff - l.beam_width);
}

void sample_area_light_point(const SpmScene& sc, const SpmLight& l, float3 u, float3* p, float3* n) {
  uint32_t lo = l.prim_begin, hi = l.prim_begin + l.prim_count - 1;
  while (lo < hi) {
    const uint32_t mid = (lo + hi) / 2;
    if (sc.light_prims[mid].cdf > u.x) hi = mid;
    else lo = mid + 1;
  }
  const SpmPrim& prim = sc.prims[sc.light_prims[lo].prim];
  if (prim.kind == SPM_PRIM_SPHERE) {
    *n = sample_uniform_sphere(u.y, u.z);
    *p = load3(prim.p0) + prim.p1[0] * *n;
  } else {
    const float2 b = sample_triangle(u.y, u.z);
    const float3 p0 = load3(prim.p0), p1 = load3(prim.p1), p2 = load3(prim.p2);
    *p = (1.0f - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
    *n = normalize(cross(p1 - p0, p2 - p0));
  }
  if (sc.shapes[prim.shape].flags & SPM_SHAPE_FLIP_NORMALS) *n = -*n;
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

// ---- intersections, brute force ------------------------------------------------------

// trace_closest of kernels/lib/intersect.h without its BVH: hit_prim on every
// primitive, so that the BVH's traversal is checked too.
bool closest_hit(const SpmScene& sc, float3 o, float3 d, SpmHit* hit) {
  *hit = SpmHit{SPM_INF, SPM_NONE, 0.0f, 0.0f};
  for (uint32_t i = 0; i < sc.num_prims; ++i) {
    float t, u, v;
    if (hit_prim(o, d, &sc.prims[i], hit->t, &t, &u, &v)) *hit = SpmHit{t, i, u, v};
  }
  return hit->prim != SPM_NONE;
}

// The margins need what hit_triangle and hit_sphere return early from: the
// barycentrics of a ray that misses, the discriminant of one that passes by.

// Moller-Trumbore as hit_triangle solves it, without its range tests.
struct TriangleSolve {
  bool valid = false;
  float t = 0, u = 0, v = 0;
};

TriangleSolve solve_triangle(float3 o, float3 d, const SpmPrim& p) {
  TriangleSolve r;
  const float3 p0 = load3(p.p0);
  const float3 e1 = load3(p.p1) - p0;
  const float3 e2 = load3(p.p2) - p0;
  const float3 pv = cross(d, e2);
  const float det = dot(e1, pv);
  if (det == 0.0f) return r;
  const float inv = 1.0f / det;
  const float3 s = o - p0;
  r.u = dot(s, pv) * inv;
  const float3 q = cross(s, e1);
  r.v = dot(d, q) * inv;
  r.t = dot(e2, q) * inv;
  r.valid = true;
  return r;
}

// hit_sphere's discriminant and nearer positive root.
struct SphereSolve {
  float disc = -1, t = 0;
};

SphereSolve solve_sphere(float3 o, float3 d, const SpmPrim& p) {
  SphereSolve r;
  const float3 c = load3(p.p0);
  const float rad = p.p1[0];
  const float3 f = o - c;
  const float b = -dot(f, d);
  const float3 l = f + b * d;
  r.disc = rad * rad - dot(l, l);
  if (r.disc < 0.0f) return r;
  const float sq = sqrt(r.disc);
  const float t0 = b - sq;
  const float t1 = b + sq;
  r.t = t0 > 0.0f ? t0 : t1;
  return r;
}

// How far inside its outline the ray meets primitive p (< 0: outside):
// the smallest barycentric of a triangle, disc / r^2 of a sphere, and where.
struct Approach {
  bool valid = false;
  float inside = 0, t = 0;
};

Approach approach(float3 o, float3 d, const SpmPrim& p) {
  Approach a;
  if (p.kind == SPM_PRIM_SPHERE) {
    const SphereSolve s = solve_sphere(o, d, p);
    const float r2 = p.p1[0] * p.p1[0];
    a.inside = s.disc / r2;
    if (s.disc < 0.0f) {  // nearest approach of the ray to the sphere
      const float3 f = o - load3(p.p0);
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

float3 geometric_normal(const SpmPrim& p, float3 at) {
  if (p.kind == SPM_PRIM_SPHERE) return normalize(at - load3(p.p0));
  const float3 p0 = load3(p.p0);
  return normalize(cross(load3(p.p1) - p0, load3(p.p2) - p0));
}

// Would the device, whose floats differ in the last bits, possibly hit a
// different surface than `hit`? Two primitives are the same surface when they
// belong to the same shape and lie in the same plane (the two triangles of a
// rectangle): which one the ray meets changes nothing. Notes the margin of
// every primitive whose outline lies close to the ray and which competes with
// the hit (nearer than it, or replacing it if the hit were missed).
void note_geometry(const SpmScene& sc, float3 o, float3 d, const SpmHit& hit, bool found, Margins& m) {
  constexpr float kNear = 1e-3f;  // primitives closer than this to the ray are inspected
  const float t_tol = 1e-4f * (1.0f + (found ? hit.t : 0.0f));
  const auto same_surface = [&](uint32_t a, uint32_t b, float3 at) {
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
  const float3 at = found ? o + hit.t * d : o;
  bool replaced_by_same = false;
  for (uint32_t i = 0; i < sc.num_prims; ++i) {
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

// specular_bounce for a stream's flux, and what the reference records of it:
// whether a dielectric reflected, and the margin of that choice, u against
// the Fresnel reflectance of specular_bounce's cos_i and eta.
float3 specular_event(const SpmMaterial& m, const SpmSurface& s, float3 d, float u, float3* out, bool* reflected,
                      Margins& mg) {
  *reflected = true;
  if (m.type == SPM_MAT_DIELECTRIC) {
    const float cos_i = clamp(-dot(d, facing_normal(&s, d)), 0.0f, 1.0f);
    const float eta = dot(d, s.ng) < 0.0f ? m.eta : 1.0f / m.eta;
    float cos_t;
    const float f = fresnel_dielectric(cos_i, eta, &cos_t);
    mg.note(u - f, "Fresnel choice");
    *reflected = u < f;
  }
  return specular_bounce(&m, &s, d, u, false, out);
}

// ---- spm_march.cl -----------------------------------------------------------------

float free_flight(float sigma, float tmax, float step, SpmRng rng, Margins& m) {
  if (step <= 0.0f) return -log(1.0f - rng4(rng, SPM_RNG_DISTANCE, 0).x) / sigma;
  const float p = -expm1(-sigma * step);
  for (uint32_t k = 0; k < kMaxMarchSteps; k += 2) {
    // The loop test (float)k * step < tmax against the surface distance.
    if (std::isfinite(tmax)) m.note(((float)k * step - tmax) / (1.0f + tmax), "march step against the surface");
    if (!((float)k * step < tmax)) break;
    const float4 u = rng4(rng, SPM_RNG_DISTANCE, k / 2);  // two steps per draw
    m.note(u.x - p, "march step interaction");
    if (u.x < p) return (float)k * step - log1p(-u.y * p) / sigma;
    m.note(u.z - p, "march step interaction");
    if (u.z < p) return (float)(k + 1) * step - log1p(-u.w * p) / sigma;
  }
  return SPM_INF;
}

// survival() of spm_interact.cl: (c / a, a) with a = mean(c).
struct Survival {
  float3 factor;
  float prob = 0;
};
Survival survival(float3 c) {
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
// survivors' weight 1 / q of Russian roulette, q from the flux `phi` of
// each of the stream's n photons were they all to survive absorption
// (interact.h on METHOD.md 10); *refill when q < 0.95 and the stream is not
// collapsed (n is then its alive count).
float goes_on(uint32_t k, float3 phi, float n, bool collapsed, float flux0, const StreamSettings& set, SpmRng rng,
              StreamResult& out, Margins& margins, bool* refill) {
  if (!(set.max_depth == SPM_NONE || k + 2u <= set.max_depth)) {
    out.end = StreamEnd::MaxDepth;
    return 0.0f;
  }
  if (k < set.rr_depth) return 1.0f;
  const float q = fmin(0.95f, (collapsed ? (float)set.associated : n) * max_comp(phi) /
                                   ((float)set.associated * flux0));
  const float u = rng4(rng, SPM_RNG_ROULETTE, 0).x;
  if (q < 0.95f) margins.note(u - q, "Russian roulette");
  if (!(u < q)) {
    out.end = StreamEnd::Roulette;
    ++out.roulette;
    return 0.0f;
  }
  *refill = !collapsed && q < 0.95f;
  return 1.0f / q;
}

StreamResult trace_stream(const SceneTables& tables, const StreamSettings& set, uint32_t id, int ulps) {
  // Heterogeneous media are tested against closed forms instead
  // (test_heterogeneous.cpp).
  for (const SpmMedium& m : tables.media) {
    if (m.sigma_t_grid >= 0 || m.albedo_grid >= 0)
      throw std::invalid_argument("the stream reference models homogeneous media only");
  }
  t_rounding = {ulps, id};
  const SpmScene sc = scene_of(tables);
  StreamResult out;
  Margins margins{&out};

  // ---- spm_emit ----
  const SpmRng emit_rng = rng_make(set.seed, set.pass, id, 0);
  const float4 u0 = rng4(emit_rng, SPM_RNG_EMIT, 0);
  const float4 u1 = rng4(emit_rng, SPM_RNG_EMIT, 1);
  out.light = pick_from_cdf(sc.light_cdf, sc.num_lights, u0.x);
  const float prob = sc.light_cdf[out.light] - (out.light > 0 ? sc.light_cdf[out.light - 1] : 0.0f);
  const SpmLight& l = sc.lights[out.light];
  float3 p, n, d, power;
  if (l.type == SPM_LIGHT_AREA) {
    sample_area_light_point(sc, l, float3(u0.y, u0.z, u0.w), &p, &n);  // u0.yzw
    d = to_world(sample_cosine_hemisphere(u1.x, u1.y), n);
    power = SPM_PI * l.area * load3(l.emission);
    p = offset_origin(p, n, sc.extent);
  } else if (l.type == SPM_LIGHT_POINT) {
    p = load3(l.position);
    d = sample_uniform_sphere(u1.x, u1.y);
    n = d;
    power = 4.0f * SPM_PI * load3(l.emission);
  } else {
    p = load3(l.position);
    const float3 cone = sample_uniform_cone(u1.x, u1.y, l.cos_cutoff);
    d = normalize(cone.x * load3(l.axis_x) + cone.y * load3(l.axis_y) + cone.z * load3(l.axis_z));
    n = d;
    power = load3(l.emission) * spot_falloff(l, cone.z) * (2.0f * SPM_PI * (1.0f - l.cos_cutoff));
  }
  float3 origin = p, dir = d;
  // spm_respawn: the associated photons' offsets from the leader, the disk
  // across the light's plane at emission (event 0), re-placed after each
  // medium (ball) and diffuse (tangent disk) event; a collapsed stream has none.
  std::vector<float3> offsets(set.associated);
  const auto respawn = [&](uint32_t count, SpmRng rng, bool ball, float3 normal) {
    for (uint32_t j = 0; j < count; ++j) {
      const float4 u = rng4(rng, SPM_RNG_RESPAWN, j);
      offsets[j] = ball ? set.stream_width * sample_ball(u.x, u.y, u.z)
                        : in_tangent_disk(float3(0.0f), normal, sample_disk(u.x, u.y), set.stream_width);
    }
  };
  respawn(set.associated, emit_rng, false, n);
  float3 phi = power / (prob * (float)set.streams * (float)set.associated);
  const float flux0 = max_comp(phi);
  uint32_t alive = set.associated;
  int medium = l.medium;
  uint32_t bounces = 0, events = 1, medium_events = 0, depth = 0;  // event 0 was the emission
  // spm_interact's depth_counts and goes_on (METHOD.md 10).
  const auto counts = [&](uint32_t k) { return set.max_depth == SPM_NONE || k + 1u <= set.max_depth; };
  bool had_event = false, after_specular = false;

  for (;;) {
    const uint32_t event = events;
    margins.event = event;
    const SpmRng rng = rng_make(set.seed, set.pass, id, event);

    // ---- spm_march ----
    SpmHit h;
    const bool surface = closest_hit(sc, origin, dir, &h);
    note_geometry(sc, origin, dir, h, surface, margins);
    Event state = surface ? Event::Surface : Event::Escape;
    float t = h.t;
    if (medium >= 0) {
      const float3 sigma = load3(sc.md.media[medium].sigma_t);
      const float mean = mean_comp(sigma);
      float3 weight(1.0f);
      const float te = mean > 0.0f ? free_flight(mean, h.t, set.march_step, rng, margins) : SPM_INF;
      if (std::isfinite(h.t) && std::isfinite(te)) {
        margins.note((te - h.t) / (1.0f + h.t), "free flight against the surface");
      }
      if (te < h.t) {
        state = Event::Medium;
        t = te;
        weight = sigma / mean * exp(-(sigma - mean) * te);
      } else if (surface) {
        weight = exp(-(sigma - mean) * h.t);
      }
      phi = phi * weight;
    }

    // ---- spm_interact ----
    uint32_t n = alive;
    bool refill = false;  // goes_on kept the stream with q < 0.95
    uint32_t act = 0;
    Survival scale;
    float3 event_pos, event_dir, event_normal;
    uint32_t event_patch = SPM_NONE;
    bool event_had_event = false, event_caustic = false;
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
        const float3 x = origin + t * dir;
        const SpmMedium& m = sc.md.media[medium];
        SpmVolumeRecord r{};
        vstore3(x, 0, r.position);
        vstore3(dir, 0, r.direction);
        const float3 flux = (float)n * phi;
        vstore3(flux, 0, r.flux);
        r.stream = id;
        r.depth = k;
        r.medium = medium;
        r.flags = after_specular ? SPM_RECORD_CAUSTIC : 0u;
        out.volume.push_back(r);
        out.collapsed_medium_events += out.collapsed;
        depth = k;
        had_event = true;
        after_specular = false;
        const float3 albedo = load3(m.albedo);
        const float w = goes_on(k, phi * survival(albedo).factor, (float)n, out.collapsed, flux0, set, rng, out,
                                margins, &refill);
        if (w == 0.0f) {
          act = kEnd;
        } else if (++medium_events >= SPM_MAX_MEDIUM_EVENTS) {
          act = kEnd;
          ++out.capped;
          out.end = StreamEnd::MediumCap;
        } else {
          const float4 u = rng4(rng, SPM_RNG_PHASE, 0);
          const float g = m.phase == SPM_PHASE_HG ? m.g : 0.0f;
          dir = sample_phase(dir, g, u.x, u.y);
          origin = x;
          event_pos = x;
          scale = survival(albedo);
          scale.factor = scale.factor * w;
          act = kAbsorb | kSphere;
        }
      }
    } else {
      const SpmSurface surf = scene_surface(&sc, origin, dir, h);
      const SpmShape& shape = sc.shapes[surf.shape];
      const SpmMaterial& mat = sc.materials[shape.material];
      // Every branch below turns on which side of the surface the ray arrives.
      margins.note(dot(dir, surf.ng), "side of the surface arriving");
      if (mat.type == SPM_MAT_NULL) {
        // A medium boundary is no event: the stream just changes medium.
        medium = target_medium(&shape, surf.ng, dir, medium);
        origin = leave_surface(&surf, dir);
        ++out.null_events;
      } else if (mat.type != SPM_MAT_DIFFUSE) {
        // Collapse: the associated photons' flux goes to the leader.
        const uint32_t k = depth + 1;
        phi = (float)n * phi;
        n = 1;
        alive = 1;
        out.collapsed = true;
        float3 next;
        bool reflected;
        const float3 f = specular_event(mat, surf, dir, rng4(rng, SPM_RNG_BSDF, 0).x, &next, &reflected, margins);
        if (!(max_comp(f) > 0.0f)) {
          act = kEnd;
          ++out.black_events;
          out.end = StreamEnd::BlackSurface;
        } else {
          if (mat.type == SPM_MAT_DIELECTRIC) ++(reflected ? out.fresnel_reflections : out.fresnel_refractions);
          ++out.specular_events;
          depth = k;
          had_event = true;
          after_specular = true;
          phi = phi * f;
          const float w = goes_on(k, phi, 1.0f, true, flux0, set, rng, out, margins, &refill);
          if (w == 0.0f) {
            act = kEnd;
          } else {
            margins.note(dot(next, surf.ng), "side of the surface leaving");
            phi = phi * w;
            dir = next;
            medium = target_medium(&shape, surf.ng, next, medium);
            origin = leave_surface(&surf, next);
          }
        }
      } else if (!reflects_from(&mat, &surf, dir)) {
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
          event_patch = surf.patch;
          event_dir = dir;
          event_had_event = had_event;
          event_caustic = after_specular;
          event_normal = dot(dir, surf.ng) < 0.0f ? surf.ng : -surf.ng;
          had_event = true;
          after_specular = false;
          depth = k;
          const float3 reflectance = load3(mat.reflectance);
          if (++bounces >= set.max_bounces) {
            act = kDeposit | kEnd;
            out.end = StreamEnd::MaxBounces;
          } else {
            const float w = goes_on(k, phi * survival(reflectance).factor, (float)n, out.collapsed, flux0, set, rng,
                                    out, margins, &refill);
            if (w == 0.0f) {
              act = kDeposit | kEnd;
            } else {
              const float4 u = rng4(rng, SPM_RNG_BSDF, 0);
              const float3 next = to_world(sample_cosine_hemisphere(u.x, u.y), facing_normal(&surf, dir));
              margins.note(dot(next, surf.ng), "side of the surface leaving");
              dir = next;
              medium = target_medium(&shape, surf.ng, next, medium);
              origin = leave_surface(&surf, next);
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
        const SpmPatchFrame patch = patch_frame(sc.patches, event_patch);
        const float3 pos = out.collapsed ? event_pos
                                         : fold_into_patch(&patch, land_on_plane(event_pos, event_normal, event_dir,
                                                                                 offsets[j]));
        SpmSurfaceRecord r{};
        vstore3(pos, 0, r.position);
        vstore3(event_dir, 0, r.direction);
        vstore3(phi, 0, r.flux);
        vstore3(event_normal, 0, r.normal);
        r.stream = id;
        r.depth_photon = (depth << 16) | j;
        r.flags = (event_had_event ? SPM_RECORD_HAD_EVENT : 0u) | (event_caustic ? SPM_RECORD_CAUSTIC : 0u);
        out.surface.push_back(r);
      }
    }

    // ---- spm_absorb: photon j survives if its uniform is below a ----
    if (act & kAbsorb) {
      for (uint32_t j = 0; j < n; ++j) {
        const float4 u = rng4(rng, SPM_RNG_ABSORB, j / 4);
        if (lane(u, j % 4) < scale.prob) ++alive_next;
      }
      phi = phi * scale.factor;
    }

    // ---- spm_respawn refills a stream roulette kept with q < 0.95 and
    // gives the survivors new offsets ----
    if (refill && alive_next > 0) {
      phi = phi * ((float)alive_next / (float)set.associated);
      alive_next = set.associated;
      ++out.refills;
    }
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
  vstore3(phi, 0, out.phi);
  return out;
}

}  // namespace spm::ref
