/* The scene tables every tracing kernel receives, in one fixed order. The host
 * binds them with GpuScene (host/scene/gpu_scene.h) in the same order. */
#ifndef SPM_LIB_SCENE_H
#define SPM_LIB_SCENE_H

#include "../spm_types.h"
#include "intersect.h"

#define SPM_SCENE_PARAMS                                                                          \
  const __global SpmBvhNode *scene_nodes, const __global SpmPrim *scene_prims,                    \
      const __global SpmPrimNormals *scene_normals, const __global SpmPatch *scene_patches,       \
      const __global SpmShape *scene_shapes,                                                      \
      const __global SpmMaterial *scene_materials, const __global SpmMedium *scene_media,         \
      const __global SpmLight *scene_lights, const __global SpmLightPrim *scene_light_prims,      \
      const __global float *scene_light_cdf, const __global SpmGridVolume *scene_grids,           \
      const __global float *scene_grid_data, uint scene_num_prims, uint scene_num_lights

#define SPM_SCENE                                                                                 \
  make_scene(scene_nodes, scene_prims, scene_normals, scene_patches, scene_shapes, scene_materials,   \
             scene_media, scene_lights, scene_light_prims, scene_light_cdf, scene_grids, scene_grid_data, scene_num_prims, \
             scene_num_lights)

/* The medium tables kernels/lib/medium.h reads. */
typedef struct SpmMedia {
  const __global SpmMedium* media;
  const __global SpmGridVolume* grids;
  const __global float* grid_data;
} SpmMedia;

typedef struct SpmScene {
  const __global SpmBvhNode* nodes;
  const __global SpmPrim* prims;
  const __global SpmPrimNormals* normals;
  const __global SpmPatch* patches;
  const __global SpmShape* shapes;
  const __global SpmMaterial* materials;
  const __global SpmLight* lights;
  const __global SpmLightPrim* light_prims;
  const __global float* light_cdf; /* inclusive CDF over lights by power */
  const __global float* light_data; /* after it: the environment maps (lib/lights.h) */
  SpmMedia md;                     /* media with their grids (medium.h) */
  uint num_prims;
  uint num_lights;
  float extent; /* largest absolute coordinate of the BVH's bounds (offset_origin) */
} SpmScene;

inline SpmScene make_scene(const __global SpmBvhNode* nodes, const __global SpmPrim* prims,
                           const __global SpmPrimNormals* normals, const __global SpmPatch* patches,
                           const __global SpmShape* shapes,
                           const __global SpmMaterial* materials, const __global SpmMedium* media,
                           const __global SpmLight* lights, const __global SpmLightPrim* light_prims,
                           const __global float* light_cdf, const __global SpmGridVolume* grids,
                           const __global float* grid_data, uint num_prims, uint num_lights) {
  SpmScene s;
  s.nodes = nodes;
  s.prims = prims;
  s.normals = normals;
  s.patches = patches;
  s.shapes = shapes;
  s.materials = materials;
  s.lights = lights;
  s.light_prims = light_prims;
  s.light_cdf = light_cdf;
  s.light_data = light_cdf + num_lights;
  s.md.media = media;
  s.md.grids = grids;
  s.md.grid_data = grid_data;
  s.num_prims = num_prims;
  s.num_lights = num_lights;
  s.extent = 0.0f;
  if (num_prims > 0) {
    const float3 lo = fabs(vload3(0, nodes[0].lo)), hi = fabs(vload3(0, nodes[0].hi));
    s.extent = max_comp(fmax(lo, hi));
  }
  return s;
}

inline bool scene_intersect(const SpmScene* s, float3 o, float3 d, float tmax, SpmHit* hit) {
  return trace_closest(s->nodes, s->prims, s->num_prims, o, d, tmax, hit);
}

inline SpmSurface scene_surface(const SpmScene* s, float3 o, float3 d, SpmHit h) {
  return surface_at(s->prims, s->normals, s->shapes, s->extent, o, d, h);
}

/* First index i with cdf[i] > u (cdf inclusive, last entry 1). */
inline uint pick_from_cdf(const __global float* cdf, uint n, float u) {
  uint lo = 0, hi = n - 1;
  while (lo < hi) {
    const uint mid = (lo + hi) / 2;
    if (cdf[mid] > u) hi = mid;
    else lo = mid + 1;
  }
  return lo;
}

#endif
