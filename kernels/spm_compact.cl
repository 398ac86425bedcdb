/* spm_compact: the next iteration's queue of live streams (METHOD.md 3).
 * From: queue after respawn. To: queue_next holding only streams with
 * survivors that did not end; n := alive_next.
 * The order of queue_next depends on atomics, which is harmless: every
 * stream's numbers come from its id and event index, and the host orders the
 * maps by (stream, event) before use. */
#include "spm_types.h"
#include "spm_streams.h"

__kernel void spm_compact(const __global uint* queue, uint count SPM_STREAM_PARAMS, __global uint* queue_next,
                          __global uint* counters) {
  const uint q = get_global_id(0);
  if (q >= count) return;
  const uint s = queue[q];
  const uint n = st_alive_next[s];
  st_alive[s] = n;
  if (n > 0 && !(st_state[s] & SPM_ACT_END)) queue_next[atomic_inc(&counters[SPM_COUNT_LIVE])] = s;
}
