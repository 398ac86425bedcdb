/* spm_respawn: the associated photons' offsets from the leader (METHOD.md
 * 1 and 3; paper 3.1 step 3). From: streams with SPM_ACT_SPHERE or
 * SPM_ACT_DISK. To: the stream's offset frame, which the next diffuse
 * event's deposit lands on its tangent plane.
 * After a medium event each surviving associated photon j gets an offset
 * uniform in the sphere of radius w; after emission and diffuse events,
 * uniform in the disk of radius w in the light's (or surface's) plane. The
 * offsets travel with the leader until they are re-placed. They are a pure
 * function of (stream, event, j) (METHOD.md 7), so respawn keeps only that
 * event and the sphere or the disk's normal, and deposit draws photon j's
 * offset when it lands it (stream_offset in lib/stream.h), which measured
 * cheaper than drawing and storing N_a offsets here (README).
 * A collapsed stream has no offsets: its one photon is the leader
 * (METHOD.md 4). */
#include "spm_types.h"
#include "lib/stream.h"

__kernel void spm_respawn(const __global uint* queue, uint count SPM_STREAM_PARAMS) {
  const uint q = get_global_id(0);
  if (q >= count) return;
  const uint s = queue[q];
  const uint act = st_state[s];
  if (!(act & (SPM_ACT_SPHERE | SPM_ACT_DISK)) || (st_flags[s] & SPM_STREAM_COLLAPSED)) return;
  const uint ball = (act & SPM_ACT_SPHERE) ? 1u : 0u;
  st_offsets[s] = (float4)(st_event_normal[s].xyz, as_float(((st_events[s] - 1u) << 1) | ball));
}
