// Mirror images of volume records across opaque walls, so that the beam
// radiance estimate does not darken where its disk reaches through a wall
// (README "Volume estimates that stop at walls").
//
// A record's kernel disk near a wall crosses it into space the record's
// medium has no photons in (the room's outside, a box's inside), so the
// estimate falls by up to half there: at every camera ray's and gather
// ray's end that meets the wall at a slant, and along every ray that runs
// beside it. As on surfaces (spm_deposit, surface_estimate), the reflection
// method of kernel density estimation (Silverman 1986, 2.10) fills that
// space with the mirror image of each record within r of the wall, over
// the wall's rectangle, and the estimate counts an image only from points
// on its record's side of the wall (kernels/lib/estimate.h, beam_estimate),
// so that a ray beyond the wall reads none.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "scene/gpu_scene.h"
#include "spm_types.h"

namespace spm {

class WallImages {
 public:
  // The walls: the patches (SceneTables::patches) of shapes that stop light,
  // diffuse or mirror; not null boundaries, which light crosses, nor glass.
  // `reach`: the largest radius add() will be asked for (the first pass's
  // volume radius: it shrinks over passes, METHOD.md 6).
  WallImages(const SceneTables& tables, float reach);

  // Appends to `records` the image of each record within `radius` (at most
  // the reach) of a wall's plane, on either side, whose foot on the plane
  // lies on the wall: the position and direction mirrored, the flux, depth
  // and medium kept, and `stream` set to SPM_RECORD_IMAGE | the wall's patch
  // index. Images follow their records' order, so the result is
  // deterministic.
  void add(std::vector<SpmVolumeRecord>& records, float radius) const;

  size_t walls() const { return walls_.size(); }

 private:
  struct Wall {
    glm::vec3 centre, u, v, normal;
    float half_u, half_v;
    uint32_t patch;
  };
  std::vector<Wall> walls_;
  // A uniform grid over the walls' bounds, each cell listing (CSR) the
  // walls whose slab of half-depth `reach_` meets it.
  float reach_;
  glm::vec3 lo_{0.0f}, cell_{1.0f};
  glm::ivec3 dims_{1};
  std::vector<uint32_t> cell_start_, cell_walls_;
};

}  // namespace spm
