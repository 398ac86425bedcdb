/* What spm_interact does at each kind of event (METHOD.md 3, 4 and 10;
 * paper 3.1 step 2 and Streamed Photon Mapping's surface rules). Each
 * function updates stream s's leader and returns where the stream goes
 * next (SPM_TO_*); a stream that ends has its st->end set.
 * Medium, diffuse and specular events are path vertices (METHOD.md 10): a
 * record at vertex k makes camera paths of at least k + 1 segments, so it is
 * kept only within max_depth, and after vertex k the stream goes on only if
 * vertex k + 1 could still count, and from rr_depth on, only if it survives
 * Russian roulette. max_depth and max_bounces are SPM_NONE when unlimited. */
#ifndef SPM_LIB_INTERACT_H
#define SPM_LIB_INTERACT_H

#include "bsdf.h"
#include "medium.h"
#include "phase.h"
#include "stream.h"

/* Where interact sends a stream. */
#define SPM_TO_END 0u     /* nothing more to do: st->end says why */
#define SPM_TO_LIVE 1u    /* straight to the next iteration (specular, null) */
#define SPM_TO_ABSORB 2u  /* its photons to the absorb list (medium event) */
#define SPM_TO_DEPOSIT 3u /* its photons to the deposit list (diffuse event); on to absorb unless it ends */

/* Survival probability and survivors' flux factor for per-channel albedo or
 * reflectance c: survive with a = mean(c), flux times c / a, so the expected
 * flux per channel is conserved (METHOD.md 3, absorb). */
inline float4 survival(float3 c) {
  const float a = mean_comp(c);
  return a > 0.0f ? (float4)(c / a, a) : (float4)(0.0f);
}

/* Ends stream s for `why`, counted in counts[counter]. */
inline uint end_stream(SpmStreams st, uint s, uint why, __global uint* counts, uint counter) {
  st.end[s] = why;
  atomic_inc(&counts[counter]);
  return SPM_TO_END;
}

/* After the event that made vertex `depth`, with `phi` the flux each of the
 * stream's n photons carries after it if it survives absorption: 0 when the
 * stream ends here (no later vertex counts within max_depth, or Russian
 * roulette from rr_depth on), with st->end set, else the survivors' weight
 * 1 / q. q = min(0.95, n max_c phi_c / (N_a phi0)), phi0 a photon's emitted
 * flux: the stream's flux over its emitted flux, were its n photons all to
 * survive. A stream kept with q < 0.95 is refilled: respawn gives it N_a
 * photons that share its survivors' flux (SPM_STREAM_REFILL), so that the
 * streams that lost photons end, as METHOD.md 10 means, while the photons
 * of those that go on keep about phi0.
 * Without the refill (the rule METHOD.md 10 replaced), the survivors of a
 * stream cut down to n photons carried N_a / n times their flux, so that
 * a pass's few late photons held most of its maps' squared flux (cornell_fog at 100
 * associated photons: one surface record 13,000 times the mean, the top 1%
 * of records 99.7% of the squared flux; with the refill 138 times and 20%,
 * the rest the red wall's per-channel factor). The refill is exact: the
 * survivors' offsets are drawn afresh at each respawn anyway, uniform in the
 * ball or disk, so N_a photons sharing the flux are drawn as n would be.
 * A collapsed stream (n = 1, phi = N_a phi0 at most) is never refilled. */
inline float goes_on(const SpmStreamParams* p, SpmStreams st, uint s, uint depth, float3 phi, SpmRng rng,
                     __global uint* counts) {
  if (!depth_counts(depth + 1u, p->max_depth)) {
    end_stream(st, s, SPM_END_DEPTH, counts, SPM_COUNT_END_DEPTH);
    return 0.0f;
  }
  if (depth < p->rr_depth) return 1.0f;
  const bool collapsed = (st.flags[s] & SPM_STREAM_COLLAPSED) != 0u;
  const float n = collapsed ? (float)p->associated : (float)st.alive[s];
  const float q = fmin(0.95f, n * max_comp(phi) / ((float)p->associated * st.flux0[s]));
  if (!(rng4(rng, SPM_RNG_ROULETTE, 0).x < q)) {
    end_stream(st, s, SPM_END_ROULETTE, counts, SPM_COUNT_END_ROULETTE);
    return 0.0f;
  }
  if (!collapsed && q < 0.95f) st.flags[s] |= SPM_STREAM_REFILL;
  return 1.0f / q;
}

/* Medium event at distance t along the leader's ray: ONE volumetric stream
 * map record {x, direction, n phi} (none when the gather reads stream
 * beams, beam_capacity > 0: it would not read the record), a new direction
 * from the phase function, and absorption with survival = mean albedo. */
inline uint medium_event(const SpmScene* sc, const SpmStreamParams* p, SpmStreams st, uint s, float t, SpmRng rng,
                         __global SpmVolumeRecord* volume, __global uint* counts) {
  const uint depth = st.depth[s] + 1u;
  atomic_inc(&counts[SPM_COUNT_EV_MEDIUM]);
  if (!depth_counts(depth, p->max_depth)) return end_stream(st, s, SPM_END_DEPTH, counts, SPM_COUNT_END_DEPTH);
  const float3 d = st.direction[s].xyz;
  const float3 x = st.origin[s].xyz + t * d;
  const __global SpmMedium* m = &sc->md.media[st.medium[s]];
  const float3 flux = (float)st.alive[s] * st.phi[s].xyz;
  if (p->beam_capacity == 0) {
    const uint slot = atomic_inc(&counts[SPM_COUNT_VOLUME]);
    if (slot < p->volume_capacity) {
      __global SpmVolumeRecord* r = &volume[slot];
      vstore3(x, 0, r->position);
      vstore3(d, 0, r->direction);
      vstore3(flux, 0, r->flux);
      r->stream = st.id[s];
      r->depth = depth;
      r->medium = st.medium[s];
      r->flags = (st.flags[s] & SPM_STREAM_AFTER_SPECULAR) ? SPM_RECORD_CAUSTIC : 0u;
      r->pad[0] = r->pad[1] = r->pad[2] = 0u;
    } else {
      atomic_or(&counts[SPM_COUNT_ERRORS], SPM_ERROR_VOLUME_OVERFLOW);
    }
  }
  st.depth[s] = depth;
  st.flags[s] = (st.flags[s] | SPM_STREAM_HAD_EVENT) & ~SPM_STREAM_AFTER_SPECULAR;
  const float3 albedo = medium_albedo(&sc->md, st.medium[s], x);
  const float4 sv = survival(albedo);
  const float w = goes_on(p, st, s, depth, st.phi[s].xyz * sv.xyz, rng, counts);
  if (w == 0.0f) return SPM_TO_END;
  if (++st.medium_events[s] >= SPM_MAX_MEDIUM_EVENTS) return end_stream(st, s, SPM_END_CAPPED, counts, SPM_COUNT_CAPPED);
  const float4 u = rng4(rng, SPM_RNG_PHASE, 0);
  const float g = m->phase == SPM_PHASE_HG ? m->g : 0.0f;
  st.direction[s] = (float4)(sample_phase(d, g, u.x, u.y), 0.0f);
  st.origin[s] = (float4)(x, 0.0f);
  st.scale[s] = (float4)(sv.xyz * w, sv.w);
  return SPM_TO_ABSORB;
}

/* The leader leaves the surface along `next`, into the medium on that side. */
inline void leave_along(SpmStreams st, uint s, const SpmSurface* surf, const __global SpmShape* shape, float3 next) {
  st.direction[s] = (float4)(next, 0.0f);
  st.medium[s] = target_medium(shape, surf->ng, next, st.medium[s]);
  st.origin[s] = (float4)(leave_surface(surf, next), 0.0f);
}

/* A delta or glossy surface: collapse (phi := n phi, n := 1; METHOD.md 4
 * and 13), then reflect or refract, by the delta bounce or a sample of the
 * glossy lobe, the flux times its weight. For a plastic, the coat's
 * reflection, which surface_event picked with probability F on the side
 * that reflects, so that only its specular_reflectance weighs. */
inline uint specular_event(const SpmStreamParams* p, SpmStreams st, uint s, const SpmSurface* surf,
                           const __global SpmShape* shape, const __global SpmMaterial* mat, SpmRng rng,
                           __global uint* counts) {
  const float3 d = st.direction[s].xyz;
  const uint depth = st.depth[s] + 1u;
  st.phi[s] *= (float4)((float)st.alive[s], (float)st.alive[s], (float)st.alive[s], 1.0f);
  st.alive[s] = 1;
  st.flags[s] |= SPM_STREAM_COLLAPSED;
  const float4 u = rng4(rng, SPM_RNG_BSDF, 0);
  float3 next = d, f = (float3)(0.0f);
  if (is_glossy(mat->type)) {
    float3 n;
    if (glossy_frame(mat, surf, d, &n)) {
      float pdf;
      f = glossy_sample_local(mat, to_local(-d, n), u.xyz, false, &next, &pdf);
      next = to_world(next, n);
    }
  } else if (mat->type == SPM_MAT_PLASTIC) {
    f = load3(mat->specular);
    next = normalize(d - 2.0f * dot(d, surf->ns) * surf->ns);
  } else {
    f = specular_bounce(mat, surf, d, u.x, false, &next);
  }
  if (!(max_comp(f) > 0.0f)) return end_stream(st, s, SPM_END_BLACK, counts, SPM_COUNT_EV_BLACK);
  atomic_inc(&counts[SPM_COUNT_EV_SPECULAR]);
  st.depth[s] = depth;
  st.flags[s] |= SPM_STREAM_HAD_EVENT | SPM_STREAM_AFTER_SPECULAR;
  st.phi[s] *= (float4)(f, 1.0f);
  const float w = goes_on(p, st, s, depth, st.phi[s].xyz, rng, counts);
  if (w == 0.0f) return SPM_TO_END;
  st.phi[s] *= (float4)(w, w, w, 1.0f);
  leave_along(st, s, surf, shape, next);
  return SPM_TO_LIVE;
}

/* A diffuse lobe (a diffuse surface, a plastic's base): the stream's
 * photons are deposited (spm_deposit), the bounce count grows, the stream
 * ends at max_bounces, else it leaves in a cosine-weighted direction and
 * its photons are absorbed with survival = the mean of what the lobe lets
 * out that way (diffuse_exit). */
inline uint diffuse_event(const SpmStreamParams* p, SpmStreams st, uint s, const SpmSurface* surf,
                          const __global SpmShape* shape, const __global SpmMaterial* mat, SpmRng rng,
                          __global uint* counts) {
  const float3 d = st.direction[s].xyz;
  const uint depth = st.depth[s] + 1u;
  atomic_inc(&counts[SPM_COUNT_EV_DIFFUSE]);
  if (!depth_counts(depth, p->max_depth)) return end_stream(st, s, SPM_END_DEPTH, counts, SPM_COUNT_END_DEPTH);
  st.event_pos[s] = (float4)(surf->p, as_float(surf->patch)); /* w: the patch spm_deposit folds into */
  const uint flags = st.flags[s];
  const uint record = ((flags & SPM_STREAM_HAD_EVENT) ? SPM_RECORD_HAD_EVENT : 0u) |
                      ((flags & SPM_STREAM_AFTER_SPECULAR) ? SPM_RECORD_CAUSTIC : 0u);
  st.event_dir[s] = (float4)(d, (float)record);
  st.event_normal[s] = (float4)(dot(d, surf->ng) < 0.0f ? surf->ng : -surf->ng, 0.0f);
  st.flags[s] = (flags | SPM_STREAM_HAD_EVENT) & ~SPM_STREAM_AFTER_SPECULAR;
  st.depth[s] = depth;
  if (++st.bounces[s] >= p->max_bounces) {
    end_stream(st, s, SPM_END_BOUNCES, counts, SPM_COUNT_END_BOUNCES);
    return SPM_TO_DEPOSIT;
  }
  /* The direction first: a plastic's base lets out (1 - F_o) of what it
   * reflects, so its factor depends on it (diffuse_exit). */
  const float4 u = rng4(rng, SPM_RNG_BSDF, 0);
  const float3 wo = sample_cosine_hemisphere(u.x, u.y);
  const float4 sv = survival(diffuse_exit(mat, wo.z));
  const float w = goes_on(p, st, s, depth, st.phi[s].xyz * sv.xyz, rng, counts);
  if (w == 0.0f) return SPM_TO_DEPOSIT;
  leave_along(st, s, surf, shape, to_world(wo, facing_normal(surf, d)));
  st.scale[s] = (float4)(sv.xyz * w, sv.w);
  return SPM_TO_DEPOSIT;
}

/* A surface event: what the material at the hit makes of it. */
inline uint surface_event(const SpmScene* sc, const SpmStreamParams* p, SpmStreams st, uint s, SpmRng rng,
                          __global uint* counts) {
  const float4 hit = st.hit[s];
  SpmHit h;
  h.t = hit.x;
  h.prim = as_uint(hit.y);
  h.u = hit.z;
  h.v = hit.w;
  const float3 d = st.direction[s].xyz;
  const SpmSurface surf = scene_surface(sc, st.origin[s].xyz, d, h);
  const __global SpmShape* shape = &sc->shapes[surf.shape];
  const __global SpmMaterial* mat = &sc->materials[shape->material];
  if (mat->type == SPM_MAT_NULL) {
    /* A medium boundary is no event: the stream just changes medium. */
    st.medium[s] = target_medium(shape, surf.ng, d, st.medium[s]);
    st.origin[s] = (float4)(leave_surface(&surf, d), 0.0f);
    atomic_inc(&counts[SPM_COUNT_EV_NULL]);
    return SPM_TO_LIVE;
  }
  /* A plastic's coat reflects with probability F, else the light enters
   * its diffuse base (METHOD.md 13). */
  if (mat->type == SPM_MAT_PLASTIC && reflects_from(mat, &surf, d) &&
      rng4(rng, SPM_RNG_BSDF, 1).x >= coat_transmission(mat, -dot(d, facing_normal(&surf, d)))) {
    return specular_event(p, st, s, &surf, shape, mat, rng, counts);
  }
  if (!has_diffuse(mat->type)) return specular_event(p, st, s, &surf, shape, mat, rng, counts);
  /* The back of a one-sided diffuse surface is black (Mitsuba). */
  if (!reflects_from(mat, &surf, d)) return end_stream(st, s, SPM_END_BLACK, counts, SPM_COUNT_EV_BLACK);
  return diffuse_event(p, st, s, &surf, shape, mat, rng, counts);
}

#endif
