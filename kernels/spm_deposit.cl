/* spm_deposit: a diffuse event's surface photon records (METHOD.md 1, 3).
 * From: the deposit list, one entry per alive photon of the streams with a
 * diffuse event; entry g fills surface map slot surface_first + g, which
 * interact reserved. To: the absorb list when the stream goes on (each
 * photon moves its own entry, at the place interact reserved), or the end.
 * Each alive photon lands where the line through its offset from the
 * leader, parallel to the leader's direction, meets the tangent plane at the
 * hit, so the footprint is the stream's cross-section projected onto the
 * surface (an ellipse of area pi w^2 / |cos theta| for a disk of radius w
 * across the direction), and is recorded with flux phi. A collapsed stream
 * deposits its one photon exactly at the hit, so caustics stay sharp
 * (METHOD.md 4). On a rectangle patch a photon landing beyond an edge is
 * reflected back across it (fold_into_patch), so no record lies off the
 * surface it was deposited on. */
#include "spm_types.h"
#include "lib/intersect.h"
#include "lib/stream.h"

__kernel void spm_deposit(SpmStreamParams params, const __global uint* deposit_list, const __global uint* counts,
                          uint surface_first, __global SpmSurfaceRecord* surface, __global uint* absorb_list,
                          const __global SpmPatch* patches SPM_STREAM_PARAMS) {
  const uint g = get_global_id(0);
  const uint slot = surface_first + g;
  if (slot >= counts[SPM_COUNT_SURFACE]) return;
  const uint s = deposit_list[g];
  const uint j = slot - st_record_base[s];
  if (st_end[s] == SPM_END_NONE) absorb_list[st_absorb_base[s] + j] = s;
  if (slot >= params.surface_capacity) return; /* interact raised SPM_ERROR_SURFACE_OVERFLOW */
  const float3 x = st_event_pos[s].xyz;
  const float3 normal = st_event_normal[s].xyz;
  const float4 dir = st_event_dir[s];
  float3 p = x;
  if (!(st_flags[s] & SPM_STREAM_COLLAPSED)) {
    const SpmPatchFrame patch = patch_frame(patches, as_uint(st_event_pos[s].w));
    p = fold_into_patch(&patch, land_on_plane(x, normal, dir.xyz, stream_offset(st_offsets[s], &params, st_id[s], j)));
  }
  __global SpmSurfaceRecord* r = &surface[slot];
  vstore3(p, 0, r->position);
  vstore3(dir.xyz, 0, r->direction);
  vstore3(st_phi[s].xyz, 0, r->flux);
  vstore3(normal, 0, r->normal);
  r->stream = st_id[s];
  r->depth_photon = (st_depth[s] << 16) | j;
  r->flags = (uint)dir.w;
  r->pad = 0;
}
