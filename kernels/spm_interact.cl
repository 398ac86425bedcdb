/* spm_interact: what happens at the leader's event (METHOD.md 3; paper 3.1
 * step 2 and Streamed Photon Mapping's surface rules).
 * From: state SPM_EV_*. To: state SPM_ACT_* bits for deposit, absorb and
 * respawn; the leader's new origin, direction and medium.
 *
 * - medium event: ONE volumetric stream map record {x, direction, n phi}, new
 *   direction from the phase function, absorption with survival = mean albedo;
 * - diffuse surface: n surface records (deposit), bounce count + 1, the stream
 *   ends at max_bounces, else a cosine-weighted direction and absorption with
 *   survival = mean reflectance;
 * - mirror, dielectric: collapse (phi := n phi, n := 1), reflect or refract;
 * - null surface: pass through into the medium on the other side.
 * Medium, diffuse and specular events are path vertices (METHOD.md 10): a
 * record at vertex k makes camera paths of at least k + 1 segments, so it is
 * kept only within max_depth, and after vertex k the stream goes on only if
 * vertex k + 1 could still count, and from rr_depth on, only if it survives
 * Russian roulette. max_depth and max_bounces are SPM_NONE when unlimited. */
#include "spm_types.h"
#include "lib/bsdf.h"
#include "lib/phase.h"
#include "lib/stream.h"

/* Survival probability and survivors' flux factor for per-channel albedo or
 * reflectance c: survive with a = mean(c), flux times c / a, so the expected
 * flux per channel is conserved (METHOD.md 3, absorb). */
inline float4 survival(float3 c) {
  const float a = mean_comp(c);
  return a > 0.0f ? (float4)(c / a, a) : (float4)(0.0f);
}

/* A record at path vertex `depth` counts within max_depth (METHOD.md 10). */
inline bool depth_counts(uint depth, uint max_depth) { return max_depth == SPM_NONE || depth + 1u <= max_depth; }

/* After the event that made vertex `depth`, with `flux` the stream's expected
 * flux after it: 0 when the stream ends here (no later vertex counts within
 * max_depth, or Russian roulette from rr_depth on with survival
 * q = min(0.95, max_c flux_c / flux0)), else the survivors' weight 1 / q. */
inline float goes_on(uint depth, float3 flux, float flux0, uint max_depth, uint rr_depth, const SpmRng* rng,
                     __global uint* counters) {
  if (!depth_counts(depth + 1u, max_depth)) {
    atomic_inc(&counters[SPM_COUNT_END_DEPTH]);
    return 0.0f;
  }
  if (depth < rr_depth) return 1.0f;
  const float q = fmin(0.95f, max_comp(flux) / flux0);
  if (!(rng4(*rng, SPM_RNG_ROULETTE, 0).x < q)) {
    atomic_inc(&counters[SPM_COUNT_END_ROULETTE]);
    return 0.0f;
  }
  return 1.0f / q;
}

__kernel void spm_interact(SPM_SCENE_PARAMS, const __global uint* queue, uint count SPM_STREAM_PARAMS,
                           __global SpmVolumeRecord* volume, uint volume_capacity, uint surface_capacity,
                           __global uint* counters, uint max_bounces, uint max_depth, uint rr_depth, uint seed,
                           uint pass) {
  const uint q = get_global_id(0);
  if (q >= count) return;
  const uint s = queue[q];
  const SpmScene sc = SPM_SCENE;
  const uint event = st_events[s];
  const SpmRng rng = rng_make(seed, pass, st_id[s], event);
  const float3 o = st_origin[s].xyz;
  const float3 d = st_direction[s].xyz;
  const float4 hit = st_hit[s];
  uint n = st_alive[s];
  uint act = 0;
  if (!all(isfinite(st_phi[s].xyz))) atomic_or(&counters[SPM_COUNT_ERRORS], SPM_ERROR_NONFINITE);

  if (st_state[s] == SPM_EV_ESCAPE) {
    act = SPM_ACT_END;
    atomic_inc(&counters[SPM_COUNT_EV_ESCAPE]);
  } else if (st_state[s] == SPM_EV_MEDIUM) {
    const uint depth = st_depth[s] + 1u;
    atomic_inc(&counters[SPM_COUNT_EV_MEDIUM]);
    if (!depth_counts(depth, max_depth)) {
      act = SPM_ACT_END;
      atomic_inc(&counters[SPM_COUNT_END_DEPTH]);
    } else {
      const float3 x = o + hit.x * d;
      const __global SpmMedium* m = &sc.media[st_medium[s]];
      const uint slot = atomic_inc(&counters[SPM_COUNT_VOLUME]);
      const float3 flux = (float)n * st_phi[s].xyz;
      if (slot < volume_capacity) {
        __global SpmVolumeRecord* r = &volume[slot];
        vstore3(x, 0, r->position);
        vstore3(d, 0, r->direction);
        vstore3(flux, 0, r->flux);
        r->stream = st_id[s];
        r->depth = depth;
        r->medium = st_medium[s];
      } else {
        atomic_or(&counters[SPM_COUNT_ERRORS], SPM_ERROR_VOLUME_OVERFLOW);
      }
      st_depth[s] = depth;
      st_flags[s] |= SPM_STREAM_HAD_EVENT;
      const float3 albedo = load3(m->albedo);
      const float w = goes_on(depth, flux * albedo, st_flux0[s], max_depth, rr_depth, &rng, counters);
      if (w == 0.0f) {
        act = SPM_ACT_END;
      } else if (++st_medium_events[s] >= SPM_MAX_MEDIUM_EVENTS) {
        act = SPM_ACT_END;
        atomic_inc(&counters[SPM_COUNT_CAPPED]);
      } else {
        const float4 u = rng4(rng, SPM_RNG_PHASE, 0);
        const float g = m->phase == SPM_PHASE_HG ? m->g : 0.0f;
        st_direction[s] = (float4)(sample_phase(d, g, u.x, u.y), 0.0f);
        st_origin[s] = (float4)(x, 0.0f);
        st_event_pos[s] = (float4)(x, 0.0f);
        const float4 sv = survival(albedo);
        st_scale[s] = (float4)(sv.xyz * w, sv.w);
        act = SPM_ACT_ABSORB | SPM_ACT_SPHERE;
      }
    }
  } else {
    SpmHit h;
    h.t = hit.x;
    h.prim = as_uint(hit.y);
    h.u = hit.z;
    h.v = hit.w;
    const SpmSurface surf = scene_surface(&sc, o, d, h);
    const __global SpmShape* shape = &sc.shapes[surf.shape];
    const __global SpmMaterial* mat = &sc.materials[shape->material];
    const int here = st_medium[s];
    if (mat->type == SPM_MAT_NULL) {
      /* A medium boundary is no event: the stream just changes medium. */
      st_medium[s] = target_medium(shape, surf.ng, d, here);
      st_origin[s] = (float4)(leave_surface(&surf, d), 0.0f);
      atomic_inc(&counters[SPM_COUNT_EV_NULL]);
    } else if (mat->type != SPM_MAT_DIFFUSE) {
      /* Collapse: the associated photons' flux goes to the leader. */
      const uint depth = st_depth[s] + 1u;
      st_phi[s] *= (float4)((float)n, (float)n, (float)n, 1.0f);
      n = 1;
      st_alive[s] = 1;
      st_flags[s] |= SPM_STREAM_COLLAPSED;
      float3 next;
      if (specular_bounce(mat, &surf, d, rng4(rng, SPM_RNG_BSDF, 0).x, false, &next) == 0.0f) {
        act = SPM_ACT_END;
        atomic_inc(&counters[SPM_COUNT_EV_BLACK]);
      } else {
        atomic_inc(&counters[SPM_COUNT_EV_SPECULAR]);
        st_depth[s] = depth;
        st_flags[s] |= SPM_STREAM_HAD_EVENT;
        const float w = goes_on(depth, st_phi[s].xyz, st_flux0[s], max_depth, rr_depth, &rng, counters);
        if (w == 0.0f) {
          act = SPM_ACT_END;
        } else {
          st_phi[s] *= (float4)(w, w, w, 1.0f);
          st_direction[s] = (float4)(next, 0.0f);
          st_medium[s] = target_medium(shape, surf.ng, next, here);
          st_origin[s] = (float4)(leave_surface(&surf, next), 0.0f);
        }
      }
    } else if (!reflects_from(mat, &surf, d)) {
      /* The back of a one-sided diffuse surface is black (Mitsuba). */
      act = SPM_ACT_END;
      atomic_inc(&counters[SPM_COUNT_EV_BLACK]);
    } else {
      const uint depth = st_depth[s] + 1u;
      atomic_inc(&counters[SPM_COUNT_EV_DIFFUSE]);
      if (!depth_counts(depth, max_depth)) {
        act = SPM_ACT_END;
        atomic_inc(&counters[SPM_COUNT_END_DEPTH]);
      } else {
        const uint base = atomic_add(&counters[SPM_COUNT_SURFACE], n);
        if (base + n > surface_capacity) atomic_or(&counters[SPM_COUNT_ERRORS], SPM_ERROR_SURFACE_OVERFLOW);
        st_record_base[s] = base;
        st_event_pos[s] = (float4)(surf.p, 0.0f);
        st_event_dir[s] = (float4)(d, (st_flags[s] & SPM_STREAM_HAD_EVENT) ? 1.0f : 0.0f);
        st_event_normal[s] = (float4)(dot(d, surf.ng) < 0.0f ? surf.ng : -surf.ng, 0.0f);
        st_flags[s] |= SPM_STREAM_HAD_EVENT;
        st_depth[s] = depth;
        const float3 reflectance = load3(mat->reflectance);
        if (++st_bounces[s] >= max_bounces) {
          act = SPM_ACT_DEPOSIT | SPM_ACT_END;
          atomic_inc(&counters[SPM_COUNT_END_BOUNCES]);
        } else {
          const float w =
              goes_on(depth, (float)n * st_phi[s].xyz * reflectance, st_flux0[s], max_depth, rr_depth, &rng, counters);
          if (w == 0.0f) {
            act = SPM_ACT_DEPOSIT | SPM_ACT_END;
          } else {
            const float4 u = rng4(rng, SPM_RNG_BSDF, 0);
            const float3 next = to_world(sample_cosine_hemisphere(u.x, u.y), facing_normal(&surf, d));
            st_direction[s] = (float4)(next, 0.0f);
            st_medium[s] = target_medium(shape, surf.ng, next, here);
            st_origin[s] = (float4)(leave_surface(&surf, next), 0.0f);
            const float4 sv = survival(reflectance);
            st_scale[s] = (float4)(sv.xyz * w, sv.w);
            act = SPM_ACT_DEPOSIT | SPM_ACT_ABSORB | SPM_ACT_DISK;
          }
        }
      }
    }
  }
  st_events[s] = event + 1;
  if (event + 1 >= SPM_MAX_EVENTS && !(act & SPM_ACT_END)) {
    act |= SPM_ACT_END;
    atomic_inc(&counters[SPM_COUNT_CAPPED]);
  }
  st_alive_next[s] = (act & (SPM_ACT_ABSORB | SPM_ACT_END)) ? 0u : n;
  st_state[s] = act;
}
