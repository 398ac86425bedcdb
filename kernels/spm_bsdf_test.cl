/* Test entry points of the glossy lobes and the diffuse lobe's exit
 * (kernels/lib/bsdf.h), so that samples can be checked against their
 * densities, weights against evaluations and albedos against closed forms
 * (tests/test_glossy.cpp). Directions are local, z along
 * the normal; `radiance` picks the camera's transport over the photons'.
 * spm_bsdf_sample_test: one work-item per sample of material `material`
 *   from wi: (wo, pdf) in dirs, (f |cos| / pdf, 0) in weights.
 * spm_bsdf_eval_test: one per direction wo of wos: (f |cos|, pdf).
 * spm_diffuse_exit_test: one per cosine of cosines: diffuse_exit there. */
#include "spm_types.h"
#include "lib/bsdf.h"
#include "lib/rng.h"

__kernel void spm_bsdf_sample_test(const __global SpmMaterial* materials, uint material, float4 wi, uint radiance,
                                   uint seed, __global float4* dirs, __global float4* weights, uint count) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  float3 wo = (float3)(0.0f);
  float pdf;
  const float3 f = glossy_sample_local(&materials[material], wi.xyz, rng4(rng_make(seed, 0u, i, 0u), SPM_RNG_BSDF, 0).xyz,
                                       radiance != 0u, &wo, &pdf);
  dirs[i] = (float4)(wo, pdf);
  weights[i] = (float4)(f, 0.0f);
}

__kernel void spm_bsdf_eval_test(const __global SpmMaterial* materials, uint material, float4 wi, uint radiance,
                                 const __global float4* wos, __global float4* out, uint count) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  float pdf;
  const float3 f = glossy_eval_local(&materials[material], wi.xyz, wos[i].xyz, radiance != 0u, &pdf);
  out[i] = (float4)(f, pdf);
}

__kernel void spm_diffuse_exit_test(const __global SpmMaterial* materials, uint material,
                                    const __global float* cosines, __global float4* out, uint count) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  out[i] = (float4)(diffuse_exit(&materials[material], cosines[i]), 0.0f);
}
