/* Counter-based random numbers (METHOD.md section 7): Philox4x32-10 from
 * Random123, key = (seed, pass), counter = (item id, event index, purpose, 0).
 * No state lives in work-item order, so every device and work-group size draws
 * the same numbers for the same photon or pixel sample. */
#ifndef SPM_LIB_RNG_H
#define SPM_LIB_RNG_H

#include "Random123/philox.h"
#include "math.h"

/* Purposes: one counter lane each, so that draws for different decisions of
 * the same event never share numbers. */
#define SPM_RNG_CAMERA 0u
#define SPM_RNG_LIGHT_PICK 1u
#define SPM_RNG_LIGHT_POINT 2u
#define SPM_RNG_BSDF 3u
#define SPM_RNG_DISTANCE 4u
#define SPM_RNG_PHASE 5u
#define SPM_RNG_ABSORB 6u
#define SPM_RNG_RESPAWN 7u
#define SPM_RNG_EMIT 8u
#define SPM_RNG_ROULETTE 10u
#define SPM_RNG_MEDIUM_NEE 11u
#define SPM_RNG_FINAL_GATHER 12u
#define SPM_RNG_TRANSMITTANCE 13u
#define SPM_RNG_STRATA 14u

/* sample, samples: a pixel's camera sample in its pass and how many the pass
 * takes (0 and 1 elsewhere), for stratify2. */
typedef struct SpmRng {
  uint seed;
  uint pass;
  uint id;
  uint event;
  uint sample;
  uint samples;
} SpmRng;

inline SpmRng rng_make(uint seed, uint pass, uint id, uint event) {
  SpmRng r;
  r.seed = seed;
  r.pass = pass;
  r.id = id;
  r.event = event;
  r.sample = 0u;
  r.samples = 1u;
  return r;
}

/* Uniform float in [0, 1) from the top 24 bits. */
inline float u01(uint x) { return (float)(x >> 8) * (1.0f / 16777216.0f); }

/* Four uniforms for (this item, this event, purpose, lane). */
inline float4 rng4(SpmRng r, uint purpose, uint lane) {
  philox4x32_key_t k = {{r.seed, r.pass}};
  philox4x32_ctr_t c = {{r.id, r.event, purpose, lane}};
  philox4x32_ctr_t x = philox4x32(c, k);
  return SPM_F4(u01(x.v[0]), u01(x.v[1]), u01(x.v[2]), u01(x.v[3]));
}

/* Element i of a pseudo-random permutation of 0 .. n - 1 chosen by key p
 * (Kensler 2013, "Correlated Multi-Jittered Sampling", its permute: a
 * hash that is a bijection on the next power of two, cycle-walked into
 * [0, n)). */
inline uint permute(uint i, uint n, uint p) {
  uint w = n - 1u;
  w |= w >> 1;
  w |= w >> 2;
  w |= w >> 4;
  w |= w >> 8;
  w |= w >> 16;
  do {
    i ^= p;
    i *= 0xe170893du;
    i ^= p >> 16;
    i ^= (i & w) >> 4;
    i ^= p >> 8;
    i *= 0x0929eb3fu;
    i ^= p >> 23;
    i ^= (i & w) >> 1;
    i *= 1u | p >> 27;
    i *= 0x6935fa69u;
    i ^= (i & w) >> 11;
    i *= 0x74dcb303u;
    i ^= (i & w) >> 2;
    i *= 0x9e501cc3u;
    i ^= (i & w) >> 2;
    i *= 0xc860a3dfu;
    i &= w;
    i ^= i >> 5;
  } while (i >= n);
  return (i + p) % n;
}

/* Two uniforms u of one decision moved into a Latin hypercube over a
 * pixel's r.samples camera samples of the pass: each coordinate of sample
 * r.sample falls in its own 1/samples stratum, the strata shuffled by a
 * permutation per coordinate keyed by (pixel, vertex, purpose, lane), the
 * same for all the pixel's samples. Each sample stays uniform on the unit
 * square, so every estimate keeps its mean, while the pixel's samples of a
 * pass spread evenly over the square (the 2D integrands of the final
 * gather's direction, a light's point and the pixel filter lose the
 * variance of their one-dimensional parts). The vertex is the event's
 * offset in the sample's block of 256 (spm_gather). */
inline float2 stratify2(SpmRng r, uint purpose, uint lane, float2 u) {
  if (r.samples <= 1u) return u;
  philox4x32_key_t k = {{r.seed, r.pass}};
  philox4x32_ctr_t c = {{r.id, r.event & 255u, SPM_RNG_STRATA, (purpose << 8) | lane}};
  const philox4x32_ctr_t p = philox4x32(c, k);
  const float n = (float)r.samples;
  return SPM_F2(((float)permute(r.sample, r.samples, p.v[0]) + u.x) / n,
                ((float)permute(r.sample, r.samples, p.v[1]) + u.y) / n);
}

#endif
