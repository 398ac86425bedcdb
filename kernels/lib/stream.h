/* Helpers shared by the stream kernels (METHOD.md 3). */
#ifndef SPM_LIB_STREAM_H
#define SPM_LIB_STREAM_H

#include "../spm_streams.h"
#include "math.h"
#include "rng.h"

/* Random numbers of the stream's current event (the index interact advanced
 * past: events - 1). */
#define STREAM_EVENT_RNG(s, seed, pass) rng_make((seed), (pass), st_id[(s)], st_events[(s)] - 1u)

/* Per-photon kernels run one work-item per (queue entry, photon): item g is
 * photon g % associated of the stream at queue entry g / associated. */
inline bool photon_item(uint g, uint count, uint associated, uint* q, uint* j) {
  *q = g / associated;
  *j = g % associated;
  return *q < count;
}

/* Point at offset (u in the unit disk) in the plane through x normal to n. */
inline float3 in_tangent_disk(float3 x, float3 n, float2 u, float radius) {
  float3 t, b;
  make_basis(n, &t, &b);
  return x + radius * (u.x * t + u.y * b);
}

#endif
