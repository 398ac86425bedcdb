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

typedef struct SpmRng {
  uint seed;
  uint pass;
  uint id;
  uint event;
} SpmRng;

inline SpmRng rng_make(uint seed, uint pass, uint id, uint event) {
  SpmRng r;
  r.seed = seed;
  r.pass = pass;
  r.id = id;
  r.event = event;
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

#endif
