/* spm_deposit: a diffuse event's surface photon records (METHOD.md 1, 3).
 * From: streams with SPM_ACT_DEPOSIT. To: surface map slots
 * [record_base, record_base + n) reserved by interact.
 * One work-item per associated photon: each alive photon lands where the
 * line through its offset from the leader, parallel to the leader's
 * direction, meets the tangent plane at the hit, so the footprint is the
 * stream's cross-section projected onto the surface (an ellipse of area
 * pi w^2 / |cos theta| for a disk of radius w across the direction), and is
 * recorded with flux phi. A collapsed stream deposits its one photon
 * exactly at the hit, so caustics stay sharp (METHOD.md 4). */
#include "spm_types.h"
#include "lib/stream.h"

__kernel void spm_deposit(const __global uint* queue, uint count SPM_STREAM_PARAMS, uint associated, float width,
                          __global SpmSurfaceRecord* surface, uint surface_capacity, uint seed, uint pass) {
  uint q, j;
  if (!photon_item(get_global_id(0), count, associated, &q, &j)) return;
  const uint s = queue[q];
  const uint n = st_alive[s];
  if (!(st_state[s] & SPM_ACT_DEPOSIT) || j >= n) return;
  const uint slot = st_record_base[s] + j;
  if (slot >= surface_capacity) return; /* interact raised SPM_ERROR_SURFACE_OVERFLOW */
  const float3 x = st_event_pos[s].xyz;
  const float3 normal = st_event_normal[s].xyz;
  const float4 dir = st_event_dir[s];
  const float3 p = (st_flags[s] & SPM_STREAM_COLLAPSED)
                       ? x
                       : land_on_plane(x, normal, dir.xyz, stream_offset(st_offsets[s], seed, pass, st_id[s], j, width));
  __global SpmSurfaceRecord* r = &surface[slot];
  vstore3(p, 0, r->position);
  vstore3(dir.xyz, 0, r->direction);
  vstore3(st_phi[s].xyz, 0, r->flux);
  vstore3(normal, 0, r->normal);
  r->stream = st_id[s];
  r->depth_photon = (st_depth[s] << 16) | j;
  r->flags = dir.w > 0.0f ? SPM_RECORD_HAD_EVENT : 0u;
  r->pad = 0;
}
