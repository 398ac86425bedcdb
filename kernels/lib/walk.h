/* A ray walked through the scene segment by segment, for every path of
 * the gather (METHOD.md 5): camera paths and their emission chains, shadow
 * rays, final-gather rays, the chain-pixel probe. walk_next intersects the
 * ray from where the last segment ended and yields the next segment
 * [t0, t1] of o + t d in one medium, ending at a surface (hit) or not
 * (t1 = the walk's reach, infinite past its first segment unless the reach
 * carries). A segment that ends on a null boundary is crossed by the next
 * walk_next, which switches the medium; at another surface the walk stops
 * unless the caller turns it (walk_turn: a mirror or glass).
 *
 * The walk owns its share of the random numbers, so that no caller counts
 * them. A path walk (camera paths, emission chains) gives segment k the
 * event first + k of its sample's block (`rng`): the vertex that ends
 * segment k draws its decisions there, and its transmittance's ratio
 * tracking draws lane tr_lane(call, 0) of it. A ray walk (shadow and
 * final-gather rays, which belong to one vertex) keeps the vertex's event
 * and gives segment k the lanes tr_lane(call, k). A walk has at most `cap`
 * segments (SPM_MAX_CAMERA_SPECULAR and SPM_MAX_SHADOW_CROSSINGS,
 * kernels/spm_tuning.h, which also checks that a path's events stay below
 * the gather hops'); past them it stops, `capped`. */
#ifndef SPM_LIB_WALK_H
#define SPM_LIB_WALK_H

#include "bsdf.h"
#include "medium.h"
#include "scene.h"

/* Random-number lanes of a heterogeneous medium's ratio tracking
 * (SPM_RNG_TRANSMITTANCE), 2^16 per medium segment: segment `i` of
 * transmittance call `call` of a path vertex. */
#define SPM_TR_CAMERA 0u
#define SPM_TR_DIRECT 1u
#define SPM_TR_NEE_CAMERA 2u
#define SPM_TR_NEE_SHADOW 3u
#define SPM_TR_FINAL_GATHER 4u
#define SPM_TR_EMISSION 5u /* and up: chain j of emission_chains uses call 5 + j */
inline uint tr_lane(uint call, uint i) { return ((call << 5) | i) << 16; }

/* Segments of a camera path or emission chain at most: null crossings
 * included, at most 4 per specular vertex. */
#define SPM_MAX_PATH_SEGMENTS (4u * SPM_MAX_CAMERA_SPECULAR + 4u)

#define SPM_WALK_PATH 0u /* an event per segment */
#define SPM_WALK_RAY 1u  /* one event, a lane per segment */

#define SPM_WALK_READY 0u /* walk_next intersects from o */
#define SPM_WALK_CROSS 1u /* the last segment ended on a null boundary: crossed first */
#define SPM_WALK_STOP 2u  /* it ended elsewhere, or escaped: the walk is over unless turned */

typedef struct SpmWalk {
  float3 o, d;  /* the segment's ray */
  float t0, t1; /* the segment; t1 = tmax where it ends on no surface */
  float tmax;   /* the ray's reach from o */
  int medium;   /* the segment's medium, -1: none */
  bool hit;     /* the segment ends on `surf` */
  SpmSurface surf;
  const __global SpmShape* shape;
  const __global SpmMaterial* material;
  uint segment; /* this segment's index in the walk */
  uint next;    /* the next segment's */
  uint cap;     /* segments at most */
  bool capped;  /* the walk stopped at its cap */
  bool carry;   /* the reach carries over null crossings (a shadow ray's to its light) */
  uint kind;    /* SPM_WALK_* */
  uint call;    /* the transmittance lanes' call (SPM_TR_*) */
  uint state;   /* SPM_WALK_READY, _CROSS, _STOP */
  SpmRng first; /* the first segment's random numbers */
  SpmRng rng;   /* the segment's, and the vertex's it ends on */
} SpmWalk;

/* A walk along o + t d from t = tmin to tmax (the reach), starting in
 * `medium`. Filled through a pointer, not returned: a struct returned from
 * a function inlined in a loop leaves LLVM's noalias scope declarations
 * behind, which oclgrind 21.10 cannot run. */
inline void walk_begin(SpmWalk* w, float3 o, float3 d, float tmin, float tmax, int medium, uint kind, SpmRng rng,
                       uint call, uint cap, bool carry) {
  w->o = o;
  w->d = d;
  w->t0 = tmin;
  w->t1 = tmin;
  w->tmax = tmax;
  w->medium = medium;
  w->hit = false;
  w->shape = 0;
  w->material = 0;
  w->segment = 0u;
  w->next = 0u;
  w->cap = cap;
  w->capped = false;
  w->carry = carry;
  w->kind = kind;
  w->call = call;
  w->state = SPM_WALK_READY;
  w->first = rng;
  w->rng = rng;
}

/* A camera path from the camera's clip range [tmin, tmax], or an emission
 * chain: an event per segment, from rng's, and transmittance call `call`. */
inline void walk_path(SpmWalk* w, float3 o, float3 d, float tmin, float tmax, int medium, SpmRng rng, uint call) {
  walk_begin(w, o, d, tmin, tmax, medium, SPM_WALK_PATH, rng, call, SPM_MAX_PATH_SEGMENTS, false);
}

/* A ray of one vertex towards `reach` (a light's distance; SPM_INF), its
 * segments lanes of transmittance call `call` of rng's event. */
inline void walk_ray(SpmWalk* w, float3 o, float3 d, float reach, int medium, SpmRng rng, uint call) {
  walk_begin(w, o, d, 0.0f, reach, medium, SPM_WALK_RAY, rng, call, SPM_MAX_SHADOW_CROSSINGS, true);
}

/* The transmittance's lane of the segment. */
inline uint walk_lane(const SpmWalk* w) { return tr_lane(w->call, w->kind == SPM_WALK_PATH ? 0u : w->segment); }

/* The next segment; false when the walk is over: its last segment ended
 * on no surface or on one it was not turned at, or it reached its cap. */
inline bool walk_next(const SpmScene* s, SpmWalk* w) {
  if (w->state == SPM_WALK_STOP) return false;
  if (w->state == SPM_WALK_CROSS) {
    w->medium = target_medium(w->shape, w->surf.ng, w->d, w->medium);
    w->o = leave_surface(&w->surf, w->d);
    w->tmax = w->carry ? w->tmax - w->t1 : SPM_INF;
    w->t0 = 0.0f;
  }
  if (w->next >= w->cap) {
    w->capped = true;
    w->state = SPM_WALK_STOP;
    return false;
  }
  w->segment = w->next++;
  if (w->kind == SPM_WALK_PATH) w->rng.event = w->first.event + w->segment;
  SpmHit h;
  w->hit = scene_intersect(s, w->o + w->t0 * w->d, w->d, w->tmax - w->t0, &h);
  w->t1 = w->hit ? h.t + w->t0 : w->tmax;
  w->state = SPM_WALK_STOP;
  if (w->hit) {
    h.t = w->t1;
    w->surf = scene_surface(s, w->o, w->d, h);
    w->shape = &s->shapes[w->surf.shape];
    w->material = &s->materials[w->shape->material];
    if (w->material->type == SPM_MAT_NULL) w->state = SPM_WALK_CROSS;
  }
  return true;
}

/* The walk goes on from the surface its segment ended on, along `d`
 * (reflected or refracted), in the medium on that side. */
inline void walk_turn(SpmWalk* w, float3 d) {
  w->medium = target_medium(w->shape, w->surf.ng, d, w->medium);
  w->o = leave_surface(&w->surf, d);
  w->d = d;
  w->t0 = 0.0f;
  w->tmax = SPM_INF;
  w->state = SPM_WALK_READY;
}

/* The random numbers of final-gather hop `hop` from a vertex whose are
 * `vertex`: events of their own in the sample's block, past every camera
 * path segment's (SPM_GATHER_EVENT). Through a pointer, as walk_begin. */
inline void hop_rng(SpmRng* out, SpmRng vertex, uint hop) {
  *out = vertex;
  out->event = vertex.event - vertex.event % SPM_SAMPLE_EVENTS + SPM_GATHER_EVENT + hop;
}

/* The medium's transmittance over the segment (medium.h). */
inline float3 walk_transmittance(const SpmScene* s, const SpmWalk* w, float step) {
  return medium_transmittance(&s->md, w->medium, w->o, w->d, w->t0, w->t1, step, w->rng, walk_lane(w));
}

#endif
