/* spm_interact: what happens at the leader's event (METHOD.md 3; the
 * physics is in lib/interact.h). From: the live queue, with march's event.
 * To: exactly one of the deposit list (a diffuse event: one entry per alive
 * photon, each with its surface map slot), the absorb list (a medium event:
 * one entry per alive photon), the next live queue (specular, null), or the
 * end. A stream that goes on from a diffuse event also gets its entries in
 * the absorb list reserved, which deposit fills. */
#include "spm_types.h"
#include "lib/interact.h"

__kernel void spm_interact(SPM_SCENE_PARAMS, SpmStreamParams params, const __global uint* live,
                           __global uint* counts, uint surface_first, __global SpmVolumeRecord* volume,
                           __global uint* deposit_list, __global uint* absorb_list, __global uint* live_next
                               SPM_STREAM_PARAMS) {
  const uint q = get_global_id(0);
  if (q >= counts[SPM_COUNT_LIVE]) return;
  const uint s = live[q];
  const SpmScene sc = SPM_SCENE;
  const SpmStreams st = SPM_STREAMS;
  const uint event = st_events[s];
  const SpmRng rng = rng_make(params.seed, params.pass, st_id[s], event);
  if (!all(isfinite(st_phi[s].xyz))) atomic_or(&counts[SPM_COUNT_ERRORS], SPM_ERROR_NONFINITE);

  uint to;
  if (st_event[s] == SPM_EV_ESCAPE) {
    to = end_stream(st, s, SPM_END_ESCAPED, counts, SPM_COUNT_EV_ESCAPE);
  } else if (st_event[s] == SPM_EV_MEDIUM) {
    to = medium_event(&sc, &params, st, s, st_hit[s].x, rng, volume, counts);
  } else {
    to = surface_event(&sc, &params, st, s, rng, counts);
  }
  st_events[s] = event + 1;
  if (event + 1 >= SPM_MAX_EVENTS && st_end[s] == SPM_END_NONE) {
    end_stream(st, s, SPM_END_CAPPED, counts, SPM_COUNT_CAPPED);
    if (to != SPM_TO_DEPOSIT) to = SPM_TO_END;
  }

  const uint n = st_alive[s];
  if (to == SPM_TO_LIVE) push_stream(live_next, counts, SPM_COUNT_LIVE_NEXT, s);
  if (to == SPM_TO_ABSORB || (to == SPM_TO_DEPOSIT && st_end[s] == SPM_END_NONE)) {
    const uint base = atomic_add(&counts[SPM_COUNT_ABSORB], n);
    atomic_inc(&counts[SPM_COUNT_ABSORBING]);
    st_absorb_base[s] = base;
    st_alive_next[s] = 0;
    if (to == SPM_TO_ABSORB) list_photons(absorb_list, base, n, s);
  }
  if (to == SPM_TO_DEPOSIT) {
    const uint base = atomic_add(&counts[SPM_COUNT_SURFACE], n);
    if (base + n > params.surface_capacity) atomic_or(&counts[SPM_COUNT_ERRORS], SPM_ERROR_SURFACE_OVERFLOW);
    st_record_base[s] = base;
    list_photons(deposit_list, base - surface_first, n, s);
  }
}
