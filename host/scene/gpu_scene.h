// The scene as the kernels see it: flat tables of the shared structs
// (kernels/spm_types.h), and their device buffers bound in the order of
// SPM_SCENE_PARAMS (kernels/lib/scene.h).
#pragma once

#include <vector>

#include "device/device.h"
#include "scene/scene.h"
#include "spm_types.h"

namespace spm {

struct SceneTables {
  std::vector<SpmBvhNode> nodes;
  std::vector<SpmPrim> prims;  // in BVH leaf order
  std::vector<SpmPrimNormals> normals;
  std::vector<SpmPatch> patches;  // the rectangles flat triangles lie on (SPM_PRIM_PATCH)
  std::vector<spm_uint> patch_shapes;  // per patch: the shape it belongs to
  std::vector<SpmShape> shapes;
  std::vector<SpmMaterial> materials;
  std::vector<SpmMedium> media;
  std::vector<SpmLight> lights;
  std::vector<SpmLightPrim> light_prims;
  std::vector<float> light_cdf;  // inclusive, by power
  std::vector<SpmGridVolume> grids;
  std::vector<float> grid_data;  // every grid's values, then its majorants (SpmGridVolume)
  SpmCamera camera{};
  double bvh_seconds = 0.0;
};

// Flattens `scene` for film size width x height. Throws InputError when the
// scene cannot be rendered (no light with positive power, ...).
SceneTables flatten_scene(const Scene& scene, int width, int height);

// Appends a gridvolume's values and its majorant grid (METHOD.md 12) to the
// grid data, and its SpmGridVolume (flatten_scene does it for every volume).
void append_grid(SceneTables& t, const GridVolume& v);

class GpuScene {
 public:
  GpuScene(Device& device, const SceneTables& tables);

  // Binds the SPM_SCENE_PARAMS arguments from `index` on; returns the next index.
  cl_uint bind(cl::Kernel& kernel, cl_uint index) const;

  const cl::Buffer& camera() const { return camera_; }
  const cl::Buffer& patches() const { return patches_; }

  size_t bytes() const { return bytes_; }  // device memory of the tables

 private:
  size_t bytes_ = 0;
  DeviceBuffer nodes_, prims_, normals_, patches_, shapes_, materials_, media_, lights_, light_prims_, light_cdf_, grids_, grid_data_,
      camera_;
  cl_uint num_prims_ = 0, num_lights_ = 0;
};

}  // namespace spm
