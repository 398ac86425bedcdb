/* Counter-based random numbers (METHOD.md section 7): Philox4x32-10 from
 * Random123, key = (seed, pass), counter = (item id, event index, purpose, 0).
 * No state lives in work-item order, so every device and work-group size draws
 * the same numbers for the same photon or pixel sample. The camera samples
 * draw under their own key (rng_gather), apart from the streams'. */
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
#define SPM_RNG_EMISSION 15u

/* sample, strata: a camera sample's index among its pixel's samples of the
 * whole render, and the scrambled sequence it reads (stratify2; 0 and 0
 * outside the gather). */
typedef struct SpmRng {
  uint seed;
  uint pass;
  uint id;
  uint event;
  uint sample;
  uint strata;
} SpmRng;

inline SpmRng rng_make(uint seed, uint pass, uint id, uint event) {
  SpmRng r;
  r.seed = seed;
  r.pass = pass;
  r.id = id;
  r.event = event;
  r.sample = 0u;
  r.strata = 0u;
  return r;
}

/* The camera samples' key: the pass with its top bit set (METHOD.md 7).
 * Keyed alike by (seed, pass), as photons are, a pixel's counter (pixel,
 * 256 sample + vertex, purpose, lane) is a stream's (id, event, purpose,
 * lane) whenever the numbers match: pixel p's first sample would read, at
 * vertex v, the very uniforms stream p drew at event v, so an estimate and
 * one of the photons it reads would share their random choices. Passes stay
 * below 2^31 (the host counts them in 31 bits). */
#define SPM_RNG_GATHER_DOMAIN 0x80000000u

inline SpmRng rng_gather(uint seed, uint pass, uint pixel, uint event) {
  return rng_make(seed, pass | SPM_RNG_GATHER_DOMAIN, pixel, event);
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

/* The 8 bits of b in reverse order, by the 64-bit multiply-and-mask of
 * Bit Twiddling Hacks; x's 32 bits in reverse order from its bytes. The
 * usual shift-and-mask swaps are no good here: clang turns them into
 * llvm.bitreverse, which Oclgrind cannot run. */
inline uint reverse_byte(uint b) {
  return (uint)((((ulong)b * 0x0802UL & 0x22110UL) | ((ulong)b * 0x8020UL & 0x88440UL)) * 0x10101UL >> 16) & 0xffu;
}

inline uint reverse_bits(uint x) {
  return (reverse_byte(x & 0xffu) << 24) | (reverse_byte((x >> 8) & 0xffu) << 16) |
         (reverse_byte((x >> 16) & 0xffu) << 8) | reverse_byte(x >> 24);
}

/* Laine and Karras's hash of x, chosen by `seed`: on bit-reversed values
 * each bit is permuted by the bits below it, so that between two
 * reversals it is a nested uniform (Owen) scramble (Burley 2020,
 * "Practical Hash-based Owen Scrambling"). */
inline uint laine_karras(uint x, uint seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

/* The nested uniform scramble of the 32-bit fraction x chosen by `seed`.
 * On an index it maps every aligned block of 2^k indices onto another. */
inline uint owen_scramble(uint x, uint seed) { return reverse_bits(laine_karras(reverse_bits(x), seed)); }

/* The second dimension of Sobol's sequence as a 32-bit fraction, in
 * reversed bit order (its generator matrix is Pascal's triangle mod 2,
 * whose columns reversed start at 1 and go on by v ^= v << 1; the first
 * dimension, reversed, is the index itself). Both dimensions are then
 * scrambled on their reversed bits, which saves reversing them twice. */
inline uint sobol_second_reversed(uint i) {
  uint r = 0u;
  for (uint v = 1u; i != 0u; i >>= 1, v ^= v << 1) {
    if (i & 1u) r ^= v;
  }
  return r;
}

/* The two uniforms of one 2D decision of camera sample r.sample of its
 * pixel: point r.sample of the first two dimensions of Sobol's sequence, a
 * (0,2)-sequence, with the index shuffled and each coordinate
 * Owen-scrambled by seeds keyed by (pixel, vertex, decision, r.strata)
 * and not by the pass (Burley 2020's shuffled scrambled Sobol'). Every
 * sample is uniform on the unit square, so no estimate changes its mean,
 * while each aligned run of 2^k of a pixel's samples, the passes' and the
 * whole render's, puts one point in every elementary box of area 2^-k: the
 * final gather's direction, a light's point and the pixel filter are
 * stratified across passes. Each decision has its own seeds, so their
 * strata are independent (padding). The vertex is the event's offset in
 * the sample's block of 256 (spm_gather). */
inline float2 stratify2(SpmRng r, uint purpose, uint lane) {
  philox4x32_key_t k = {{r.seed, r.strata}};
  philox4x32_ctr_t c = {{r.id, r.event & 255u, SPM_RNG_STRATA, (purpose << 8) | lane}};
  const philox4x32_ctr_t p = philox4x32(c, k);
  const uint i = owen_scramble(r.sample, p.v[0]);
  return SPM_F2(u01(reverse_bits(laine_karras(i, p.v[1]))),
                u01(reverse_bits(laine_karras(sobol_second_reversed(i), p.v[2]))));
}

#endif
