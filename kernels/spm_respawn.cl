/* spm_respawn: the associated photons' offsets from the leader (METHOD.md
 * 1 and 3; paper 3.1 step 3). From: the respawn queue (streams after emit
 * or absorb). To: the next iteration's live queue with the survivors, or
 * the end (SPM_END_ABSORBED) when none survived. A stream that roulette
 * kept with q < 0.95 (SPM_STREAM_REFILL, lib/interact.h) goes on with N_a
 * photons sharing its n survivors' flux.
 * After a medium event each surviving associated photon j gets an offset
 * uniform in the sphere of radius w; after emission and diffuse events,
 * uniform in the disk of radius w in the light's (or surface's) plane. The
 * offsets travel with the leader until they are re-placed. They are a pure
 * function of (stream, event, j) (METHOD.md 7), so respawn keeps only that
 * event and the sphere or the disk's normal, and deposit draws photon j's
 * offset when it lands it (stream_offset in lib/stream.h), which measured
 * cheaper than drawing and storing N_a offsets here
 * (docs/experiments/fig3-and-speed.md "Measured here").
 * A collapsed stream has no offsets: its one photon is the leader
 * (METHOD.md 4). */
#include "spm_types.h"
#include "lib/stream.h"

__kernel void spm_respawn(SpmStreamParams params, const __global uint* respawn_queue, __global uint* live_next,
                          __global uint* counts SPM_STREAM_PARAMS) {
  const uint q = get_global_id(0);
  if (q >= counts[SPM_COUNT_RESPAWN]) return;
  const uint s = respawn_queue[q];
  uint n = st_alive_next[s];
  if (n > 0u && (st_flags[s] & SPM_STREAM_REFILL)) {
    const float share = (float)n / (float)params.associated;
    st_phi[s] *= (float4)(share, share, share, 1.0f);
    n = params.associated;
    st_alive_next[s] = n;
  }
  st_flags[s] &= ~SPM_STREAM_REFILL;
  st_alive[s] = n;
  if (n == 0) {
    st_end[s] = SPM_END_ABSORBED;
    return;
  }
  if (!(st_flags[s] & SPM_STREAM_COLLAPSED)) {
    const uint ball = st_event[s] == SPM_EV_MEDIUM ? 1u : 0u;
    st_offsets[s] = (float4)(st_event_normal[s].xyz, as_float(((st_events[s] - 1u) << 1) | ball));
  }
  push_stream(live_next, counts, SPM_COUNT_LIVE_NEXT, s);
}
