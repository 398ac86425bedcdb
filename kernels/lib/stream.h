/* Helpers shared by the stream kernels (METHOD.md 3). */
#ifndef SPM_LIB_STREAM_H
#define SPM_LIB_STREAM_H

#include "../spm_streams.h"
#include "../spm_types.h"
#include "math.h"
#include "rng.h"
#include "sampling.h"

/* A record at path vertex `depth` counts within max_depth (METHOD.md 10). */
inline bool depth_counts(uint depth, uint max_depth) { return max_depth == SPM_NONE || depth + 1u <= max_depth; }

/* Pushes stream s onto a queue whose size is counts[size] (pbrt-v4's Push:
 * reserve the entry atomically, then write it). */
inline void push_stream(__global uint* queue, __global uint* counts, uint size, uint s) {
  queue[atomic_inc(&counts[size])] = s;
}

/* Lists stream s's n alive photons from entry `base` of a photon list; a
 * photon's index is its entry minus the stream's base. */
inline void list_photons(__global uint* list, uint base, uint n, uint s) {
  for (uint j = 0; j < n; ++j) list[base + j] = s;
}

/* Where the line through x + offset along d meets the plane through x
 * normal to n (METHOD.md 1). A direction in the plane to float precision
 * projects the offset onto the plane instead: the footprint is then
 * unbounded, and no leader reaches a surface along its own plane. */
inline float3 land_on_plane(float3 x, float3 n, float3 d, float3 offset) {
  const float dn = dot(d, n), on = dot(offset, n);
  if (fabs(dn) < 1e-6f) return x + offset - on * n;
  return x + offset - (on / dn) * d;
}

/* Point at offset (u in the unit disk) in the plane through x normal to n. */
inline float3 in_tangent_disk(float3 x, float3 n, float2 u, float radius) {
  float3 t, b;
  make_basis(n, &t, &b);
  return x + radius * (u.x * t + u.y * b);
}

/* Photon j's offset from the leader as spm_respawn's frame of stream `id`
 * says: drawn with the random numbers of the event that placed it, uniform
 * in the ball of radius w or in the disk of radius w normal to frame.xyz. */
inline float3 stream_offset(float4 frame, const SpmStreamParams* p, uint id, uint j) {
  const uint bits = as_uint(frame.w);
  const float4 u = rng4(rng_make(p->seed, p->pass, id, bits >> 1), SPM_RNG_RESPAWN, j);
  if (bits & 1u) return p->stream_width * sample_ball(u.x, u.y, u.z);
  return in_tangent_disk((float3)(0.0f), frame.xyz, sample_disk(u.x, u.y), p->stream_width);
}

#endif
