/* Stream state (METHOD.md 1 and 3), structure of arrays, listed ONCE: the
 * kernels take it as SPM_STREAM_PARAMS and the host allocates and binds it
 * from the same list (host/spm/stream_state.h), so they cannot disagree.
 * X(type, name): one buffer of `type` per stream slot of a batch. */
#ifndef SPM_STREAMS_H
#define SPM_STREAMS_H

#define SPM_STREAM_STATE(X)                                                                    \
  X(float4, origin)       /* leader position (w unused) */                                     \
  X(float4, direction)    /* leader direction of travel (w unused) */                          \
  X(float4, phi)          /* flux of each associated photon, RGB (w unused) */                 \
  X(float4, hit)          /* march: event distance t, primitive (bits), barycentrics u, v */   \
  X(float4, event_pos)    /* interact: where the event happened */                             \
  X(float4, event_dir)    /* interact: arriving direction; w: the record's SPM_RECORD_* flags */ \
  X(float4, event_normal) /* interact: surface normal on the arriving side */                  \
  X(float4, offsets)      /* respawn: disk normal; w: (event << 1) | ball, spm_respawn.cl */  \
  X(float4, scale)        /* absorb: survivors' flux factor per channel; w: survival prob. */  \
  X(uint, alive)          /* n: alive associated photons */                                    \
  X(uint, alive_next)     /* absorb: survivors of this event */                                \
  X(int, medium)          /* medium the leader travels in, -1: none */                         \
  X(uint, bounces)        /* diffuse bounces so far */                                         \
  X(uint, events)         /* events so far = RNG event index of the next one */                \
  X(uint, depth)          /* path vertices so far, as Mitsuba counts them (METHOD.md 10) */    \
  X(float, flux0)         /* max over RGB of a photon's emitted flux phi (roulette) */        \
  X(uint, medium_events)  /* medium interactions so far (safety cap) */                        \
  X(uint, event)          /* march: SPM_EV_* of the leader's next event; emit: SPM_EV_EMIT */  \
  X(uint, end)            /* SPM_END_*: why the stream ended; SPM_END_NONE while it lives */   \
  X(uint, flags)          /* SPM_STREAM_HAD_EVENT, _COLLAPSED, _AFTER_SPECULAR, _REFILL */     \
  X(uint, record_base)    /* interact: first surface-map slot of this event's deposit */       \
  X(uint, absorb_base)    /* interact: first entry of the stream's photons in the absorb list */ \
  X(uint, id)             /* stream id within the pass: the RNG counter */

/* Events (st_event): march's outcomes, and emission for respawn. */
#define SPM_EV_MEDIUM 1u
#define SPM_EV_SURFACE 2u
#define SPM_EV_ESCAPE 3u
#define SPM_EV_EMIT 4u

/* Why a stream ended (st_end); the kernel that ends it writes it. */
#define SPM_END_NONE 0u
#define SPM_END_ESCAPED 1u   /* interact: march found no surface and no medium event */
#define SPM_END_BLACK 2u     /* interact: the black back of a one-sided surface, or a black mirror */
#define SPM_END_DEPTH 3u     /* interact: no later vertex counts within max_depth */
#define SPM_END_ROULETTE 4u  /* interact: Russian roulette (METHOD.md 10) */
#define SPM_END_BOUNCES 5u   /* interact: the max_bounces-th diffuse event, after its deposit */
#define SPM_END_CAPPED 6u    /* interact: SPM_MAX_MEDIUM_EVENTS or SPM_MAX_EVENTS */
#define SPM_END_ABSORBED 7u  /* respawn: absorb left no associated photon */

#define SPM_STREAM_HAD_EVENT 1u
#define SPM_STREAM_COLLAPSED 2u /* a specular event collapsed the stream (METHOD.md 4) */
#define SPM_STREAM_AFTER_SPECULAR 4u /* the last event was specular (a medium boundary is none) */
#define SPM_STREAM_REFILL 8u /* roulette kept the stream with q < 0.95: respawn refills it to N_a photons (interact.h) */

/* The queues of one wavefront iteration (METHOD.md 3). Each kernel moves a
 * stream to one next queue or ends it:
 *   live    -> march -> live -> interact -> deposit list (diffuse event),
 *              absorb list (medium event), live next (specular, null) or end;
 *   deposit -> absorb list, or end (the stream's last event);
 *   absorb  -> respawn queue;
 *   respawn -> live next, or end (no survivors);
 *   emit    -> respawn queue.
 * The deposit and absorb lists hold one entry per alive associated photon,
 * so that the per-photon kernels launch over exactly the photons with work.
 * Their sizes are the first counters: the host reads them once per
 * iteration, after interact, to size the launches, and every kernel also
 * reads its own queue's size on the device and returns past it. */
#define SPM_COUNT_LIVE 0       /* entries of the live queue march and interact run over */
#define SPM_COUNT_LIVE_NEXT 1  /* entries pushed to the next iteration's live queue */
#define SPM_COUNT_ABSORB 2     /* entries of the absorb list */
#define SPM_COUNT_ABSORBING 3  /* streams with photons in the absorb list: respawn's launch */
#define SPM_COUNT_RESPAWN 4    /* entries of the respawn queue */
#define SPM_COUNT_QUEUES 5     /* counters [0, SPM_COUNT_QUEUES) are queue sizes, not statistics */
/* Counters summed over the pass, for the host's checks and the profile. */
#define SPM_COUNT_VOLUME 5     /* volume records appended */
#define SPM_COUNT_SURFACE 6    /* surface records reserved = entries of the deposit lists */
#define SPM_COUNT_ERRORS 7     /* SPM_ERROR_* bits */
#define SPM_COUNT_CAPPED 8     /* streams ended by a safety cap */
#define SPM_COUNT_EV_MEDIUM 9
#define SPM_COUNT_EV_DIFFUSE 10
#define SPM_COUNT_EV_SPECULAR 11
#define SPM_COUNT_EV_NULL 12
#define SPM_COUNT_EV_ESCAPE 13
#define SPM_COUNT_EV_BLACK 14      /* absorbed at the black back of a one-sided surface */
#define SPM_COUNT_END_ROULETTE 15  /* streams ended by Russian roulette (METHOD.md 10) */
#define SPM_COUNT_END_DEPTH 16     /* streams ended by max_depth */
#define SPM_COUNT_END_BOUNCES 17   /* streams ended by max_bounces */
#define SPM_COUNT_STREAMS 18       /* streams emitted (counted on the host) */
#define SPM_COUNT_BEAMS 19         /* stream beams appended (METHOD.md 11) */
#define SPM_COUNTERS 20

/* Safety caps (METHOD.md 10): a stream ends after this many medium events or
 * events in all; the host reports how many streams the caps ended. Roulette
 * and max_depth end streams long before them in any scene a path tracer can
 * render. Events must stay below 2^16 for the surface record key
 * (depth << 16 | photon). */
#define SPM_MAX_MEDIUM_EVENTS 1024u
#define SPM_MAX_EVENTS 4096u

#ifdef __OPENCL_VERSION__
#define SPM_STREAM_PARAM(type, name) , __global type *st_##name
#define SPM_STREAM_PARAMS SPM_STREAM_STATE(SPM_STREAM_PARAM)

/* The same buffers bundled, for the library functions a kernel calls:
 * `const SpmStreams st = SPM_STREAMS;` inside a kernel with SPM_STREAM_PARAMS. */
#define SPM_STREAM_FIELD(type, name) __global type* name;
typedef struct SpmStreams {
  SPM_STREAM_STATE(SPM_STREAM_FIELD)
} SpmStreams;
#define SPM_STREAM_ARG(type, name) st_##name,
#define SPM_STREAMS {SPM_STREAM_STATE(SPM_STREAM_ARG)}
#endif

#endif
