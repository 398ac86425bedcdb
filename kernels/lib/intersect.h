/* Ray-primitive tests and the traversal of the flattened BVH built on the host
 * (host/scene/bvh.cpp). */
#ifndef SPM_LIB_INTERSECT_H
#define SPM_LIB_INTERSECT_H

#include "../spm_types.h"
#include "math.h"

#define SPM_BVH_STACK 64

typedef struct SpmHit {
  float t;
  uint prim;
  float u; /* barycentrics of p1 and p2 (triangles) */
  float v;
} SpmHit;

/* Moller-Trumbore, both sides; t in (0, tmax). */
inline bool hit_triangle(float3 o, float3 d, const __global SpmPrim* p, float tmax, float* t, float* u, float* v) {
  const float3 p0 = load3(p->p0);
  const float3 e1 = load3(p->p1) - p0;
  const float3 e2 = load3(p->p2) - p0;
  const float3 pv = cross(d, e2);
  const float det = dot(e1, pv);
  if (det == 0.0f) return false;
  const float inv = 1.0f / det;
  const float3 s = o - p0;
  const float bu = dot(s, pv) * inv;
  if (bu < 0.0f || bu > 1.0f) return false;
  const float3 q = cross(s, e1);
  const float bv = dot(d, q) * inv;
  if (bv < 0.0f || bu + bv > 1.0f) return false;
  const float tt = dot(e2, q) * inv;
  if (!(tt > 0.0f && tt < tmax)) return false;
  *t = tt;
  *u = bu;
  *v = bv;
  return true;
}

/* Nearest root in (0, tmax) of |o + t d - c| = r, d unit length. The
 * discriminant is computed from the distance of the ray to the centre, which
 * keeps precision for spheres far from the origin (Ray Tracing Gems ch. 7). */
inline bool hit_sphere(float3 o, float3 d, const __global SpmPrim* p, float tmax, float* t) {
  const float3 c = load3(p->p0);
  const float r = p->p1[0];
  const float3 f = o - c;
  const float b = -dot(f, d);
  const float3 l = f + b * d;
  const float disc = r * r - dot(l, l);
  if (disc < 0.0f) return false;
  const float sq = sqrt(disc);
  const float t0 = b - sq;
  const float t1 = b + sq;
  const float tt = t0 > 0.0f ? t0 : t1;
  if (!(tt > 0.0f && tt < tmax)) return false;
  *t = tt;
  return true;
}

inline bool hit_prim(float3 o, float3 d, const __global SpmPrim* p, float tmax, float* t, float* u, float* v) {
  if (p->kind == SPM_PRIM_SPHERE) {
    *u = 0.0f;
    *v = 0.0f;
    return hit_sphere(o, d, p, tmax, t);
  }
  return hit_triangle(o, d, p, tmax, t, u, v);
}

inline bool hit_box(const __global SpmBvhNode* n, float3 o, float3 inv_d, float tmax) {
  const float3 t0 = (load3(n->lo) - o) * inv_d;
  const float3 t1 = (load3(n->hi) - o) * inv_d;
  const float3 tn = fmin(t0, t1);
  const float3 tf = fmax(t0, t1);
  const float enter = fmax(fmax(tn.x, tn.y), fmax(tn.z, 0.0f));
  const float leave = fmin(fmin(tf.x, tf.y), fmin(tf.z, tmax));
  return enter <= leave;
}

/* Closest hit in (0, tmax); false when the ray escapes. */
inline bool trace_closest(const __global SpmBvhNode* nodes, const __global SpmPrim* prims, uint num_prims,
                          float3 o, float3 d, float tmax, SpmHit* hit) {
  hit->t = tmax;
  hit->prim = SPM_NONE;
  hit->u = 0.0f;
  hit->v = 0.0f;
  if (num_prims == 0) return false;
  const float3 inv_d = 1.0f / d;
  uint stack[SPM_BVH_STACK];
  int top = 0;
  uint node = 0;
  for (;;) {
    const __global SpmBvhNode* n = &nodes[node];
    if (hit_box(n, o, inv_d, hit->t)) {
      const uint count = SPM_BVH_COUNT(*n);
      if (count > 0) {
        for (uint i = n->offset; i < n->offset + count; ++i) {
          float t, u, v;
          if (hit_prim(o, d, &prims[i], hit->t, &t, &u, &v)) {
            hit->t = t;
            hit->prim = i;
            hit->u = u;
            hit->v = v;
          }
        }
      } else {
        /* Visit the child on the ray's near side first. */
        const uint axis = SPM_BVH_AXIS(*n);
        const float da = axis == 0 ? d.x : (axis == 1 ? d.y : d.z);
        const uint near_child = da < 0.0f ? n->offset : node + 1;
        const uint far_child = da < 0.0f ? node + 1 : n->offset;
        stack[top++] = far_child;
        node = near_child;
        continue;
      }
    }
    if (top == 0) break;
    node = stack[--top];
  }
  return hit->prim != SPM_NONE;
}

/* Surface data at a hit. `ng` is the geometric normal and `ns` the shading
 * normal, both on the side Mitsuba calls exterior (flip_normals applied). */
typedef struct SpmSurface {
  float3 p;
  float3 ng;
  float3 ns;
  uint shape;
  uint patch;   /* index into SpmPatch, or SPM_NONE */
  float extent; /* the scene's largest coordinate (offset_origin) */
} SpmSurface;

inline SpmSurface surface_at(const __global SpmPrim* prims, const __global SpmPrimNormals* normals,
                             const __global SpmShape* shapes, float extent, float3 o, float3 d, SpmHit h) {
  const __global SpmPrim* p = &prims[h.prim];
  SpmSurface s;
  s.p = o + h.t * d;
  s.shape = p->shape;
  s.patch = p->normals != SPM_NONE && (p->normals & SPM_PRIM_PATCH) ? p->normals & ~SPM_PRIM_PATCH : SPM_NONE;
  s.extent = extent;
  if (p->kind == SPM_PRIM_SPHERE) {
    s.ng = normalize(s.p - load3(p->p0));
    s.ns = s.ng;
  } else {
    const float3 p0 = load3(p->p0);
    s.ng = normalize(cross(load3(p->p1) - p0, load3(p->p2) - p0));
    s.ns = s.ng;
    if (p->normals != SPM_NONE && !(p->normals & SPM_PRIM_PATCH)) {
      const __global SpmPrimNormals* n = &normals[p->normals];
      const float3 ns = (1.0f - h.u - h.v) * load3(n->n0) + h.u * load3(n->n1) + h.v * load3(n->n2);
      const float len = length(ns);
      if (len > 0.0f) s.ns = ns / len;
    }
  }
  if (shapes[s.shape].flags & SPM_SHAPE_FLIP_NORMALS) {
    s.ng = -s.ng;
    s.ns = -s.ns;
  }
  return s;
}

/* A patch (SpmPatch) in private memory: centre c, unit edge directions u
 * and v, and the bounds lo and hi of its local coordinates (dot(p - c, u),
 * dot(p - c, v)) at the edges where the surface ends; an edge another
 * patch continues in the same plane has no bound (+-SPM_PATCH_OPEN).
 * valid = 0: a surface on no patch. */
#define SPM_PATCH_OPEN 1e30f

typedef struct SpmPatchFrame {
  float3 c, u, v;
  float2 lo, hi;
  int valid;
} SpmPatchFrame;

inline SpmPatchFrame patch_frame(const __global SpmPatch* patches, uint patch) {
  SpmPatchFrame f;
  f.c = f.u = f.v = SPM_F3(0.0f, 0.0f, 0.0f);
  f.lo = SPM_F2(-SPM_PATCH_OPEN, -SPM_PATCH_OPEN);
  f.hi = SPM_F2(SPM_PATCH_OPEN, SPM_PATCH_OPEN);
  f.valid = patch != SPM_NONE;
  if (!f.valid) return f;
  const __global SpmPatch* p = &patches[patch];
  f.c = load3(p->center);
  f.u = load3(p->u);
  f.v = load3(p->v);
  const uint open = p->open;
  f.lo = SPM_F2((open & SPM_PATCH_OPEN_U_LO) ? -SPM_PATCH_OPEN : -p->half_u,
                  (open & SPM_PATCH_OPEN_V_LO) ? -SPM_PATCH_OPEN : -p->half_v);
  f.hi = SPM_F2((open & SPM_PATCH_OPEN_U_HI) ? SPM_PATCH_OPEN : p->half_u,
                  (open & SPM_PATCH_OPEN_V_HI) ? SPM_PATCH_OPEN : p->half_v);
  return f;
}

inline float2 patch_coords(const SpmPatchFrame* f, float3 p) {
  const float3 q = p - f->c;
  return SPM_F2(dot(q, f->u), dot(q, f->v));
}

/* s reflected into [lo, hi] at the bound it lies beyond (and clamped, for
 * an offset longer than the patch is wide). */
inline float fold_coord(float s, float lo, float hi) {
  if (s > hi) s = 2.0f * hi - s;
  else if (s < lo) s = 2.0f * lo - s;
  return clamp(s, lo, hi);
}

/* A point of the patch's plane, reflected across the edges it lies beyond:
 * where an associated photon lands when its offset from the leader takes it
 * off the patch (spm_deposit). Reflection keeps the density of photons of
 * an evenly lit patch even up to its edges, where the photons that would
 * land beyond an edge land mirrored just inside it (the reflection method
 * of kernel density estimation, Silverman 1986, 2.10). */
inline float3 fold_into_patch(const SpmPatchFrame* f, float3 p) {
  if (!f->valid) return p;
  const float2 q = patch_coords(f, p);
  return p + (fold_coord(q.x, f->lo.x, f->hi.x) - q.x) * f->u + (fold_coord(q.y, f->lo.y, f->hi.y) - q.y) * f->v;
}

/* Mitsuba's rule for the medium a direction leaves into: a shape that names
 * a medium on either side is a medium transition, exterior on the side the
 * normal points to and interior on the other; any other shape keeps the
 * `current` medium (METHOD.md 9). */
inline int target_medium(const __global SpmShape* shape, float3 ng, float3 d, int current) {
  if (shape->interior < 0 && shape->exterior < 0) return current;
  return dot(ng, d) > 0.0f ? shape->exterior : shape->interior;
}

#endif
