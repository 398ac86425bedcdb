/* Stream state (METHOD.md 1 and 3), structure of arrays, listed ONCE: the
 * kernels take it as SPM_STREAM_PARAMS (right after the queue and its count:
 * `queue, count SPM_STREAM_PARAMS`) and the host allocates and binds it from
 * the same list (host/spm/stream_state.h), so they cannot disagree.
 * X(type, name): one buffer of `type` per stream slot of a batch. */
#ifndef SPM_STREAMS_H
#define SPM_STREAMS_H

#define SPM_STREAM_STATE(X)                                                                    \
  X(float4, origin)       /* leader position (w unused) */                                     \
  X(float4, direction)    /* leader direction of travel (w unused) */                          \
  X(float4, phi)          /* flux of each associated photon, RGB (w unused) */                 \
  X(float4, hit)          /* march: event distance t, primitive (bits), barycentrics u, v */   \
  X(float4, event_pos)    /* interact: where the event happened */                             \
  X(float4, event_dir)    /* interact: arriving direction; w: 1 if the stream had an event */  \
  X(float4, event_normal) /* interact: surface normal on the arriving side */                  \
  X(float4, offsets)      /* respawn: disk normal; w: (event << 1) | ball, spm_respawn.cl */  \
  X(float4, scale)        /* absorb: survivors' flux factor per channel; w: survival prob. */  \
  X(uint, alive)          /* n: alive associated photons */                                    \
  X(uint, alive_next)     /* absorb: survivors of this event */                                \
  X(int, medium)          /* medium the leader travels in, -1: none */                         \
  X(uint, bounces)        /* diffuse bounces so far */                                         \
  X(uint, events)         /* events so far = RNG event index of the next one */                \
  X(uint, depth)          /* path vertices so far, as Mitsuba counts them (METHOD.md 10) */    \
  X(float, flux0)         /* max over RGB of the emitted stream flux N_a phi (roulette) */     \
  X(uint, medium_events)  /* medium interactions so far (safety cap) */                        \
  X(uint, state)          /* march: SPM_EV_*; interact onwards: SPM_ACT_* bits */              \
  X(uint, flags)          /* SPM_STREAM_HAD_EVENT, SPM_STREAM_COLLAPSED */                     \
  X(uint, record_base)    /* first surface-map slot of this event's deposit */                 \
  X(uint, id)             /* stream id within the pass: the RNG counter */

/* march outcomes */
#define SPM_EV_MEDIUM 1u
#define SPM_EV_SURFACE 2u
#define SPM_EV_ESCAPE 3u

/* What the per-photon kernels do after interact (bits). */
#define SPM_ACT_DEPOSIT 1u /* deposit: one surface record per alive photon */
#define SPM_ACT_ABSORB 2u  /* absorb: each photon survives with probability scale.w */
#define SPM_ACT_SPHERE 4u  /* respawn: survivors uniform in the sphere of radius w */
#define SPM_ACT_DISK 8u    /* respawn: survivors uniform in the disk of radius w */
#define SPM_ACT_END 16u    /* the stream ends after this event */

#define SPM_STREAM_HAD_EVENT 1u
#define SPM_STREAM_COLLAPSED 2u /* a specular event collapsed the stream (METHOD.md 4) */

/* Counters shared by the stream kernels and read by the host each iteration. */
#define SPM_COUNT_LIVE 0    /* streams in the next queue */
#define SPM_COUNT_VOLUME 1  /* volume records appended */
#define SPM_COUNT_SURFACE 2 /* surface records reserved */
#define SPM_COUNT_ERRORS 3  /* SPM_ERROR_* bits */
#define SPM_COUNT_CAPPED 4  /* streams ended by a safety cap */
#define SPM_COUNT_EV_MEDIUM 5
#define SPM_COUNT_EV_DIFFUSE 6
#define SPM_COUNT_EV_SPECULAR 7
#define SPM_COUNT_EV_NULL 8
#define SPM_COUNT_EV_ESCAPE 9
#define SPM_COUNT_EV_BLACK 10 /* absorbed at the black back of a one-sided surface */
#define SPM_COUNT_END_ROULETTE 11 /* streams ended by Russian roulette (METHOD.md 10) */
#define SPM_COUNT_END_DEPTH 12    /* streams ended by max_depth */
#define SPM_COUNT_END_BOUNCES 13  /* streams ended by max_bounces */
#define SPM_COUNT_STREAMS 14      /* streams emitted (counted on the host) */
#define SPM_COUNTERS 16


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
#endif

#endif
