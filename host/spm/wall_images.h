// Mirror images of volume records across opaque walls and across the
// boundaries where a medium ends, so that the beam radiance estimate does
// not darken where its disk reaches through a wall or out of the medium
// (docs/experiments/volume-kernels.md "Volume estimates that stop at walls", "... and at the fog's edge").
//
// A record's kernel disk near a wall crosses it into space the record's
// medium has no photons in (the room's outside, a box's inside), so the
// estimate falls by up to half there: at every camera ray's and gather
// ray's end that meets the wall at a slant, and along every ray that runs
// beside it. As on surfaces (spm_deposit, surface_estimate), the reflection
// method of kernel density estimation (Silverman 1986, 2.10) fills that
// space with the mirror image of each record within r of the wall, over
// the wall's rectangle, and the estimate counts a record near a wall only
// from points on its side, and its image only from points on the record's
// side (kernels/lib/estimate.h, beam_estimate), so that a ray beyond the
// wall reads neither.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "scene/gpu_scene.h"
#include "spm_types.h"

namespace spm {

class WallImages {
 public:
  // The walls: the patches (SceneTables::patches) of shapes that stop light,
  // diffuse or mirror, and the medium boundaries: null patches with a medium
  // on one side and none on the other, where the records' density ends as
  // it does at a wall. Not null patches between two media, which light
  // crosses, nor glass.
  // `reach`: the largest radius add() will be asked for (the first pass's
  // volume radius: it shrinks over passes, METHOD.md 6).
  WallImages(const SceneTables& tables, float reach);
  WallImages() = default;  // no walls

  // Appends to `records` the image of each record within `radius` (at most
  // the reach) of a wall's plane, on either side, whose foot on the plane
  // lies on the wall: the position and direction mirrored, the flux, depth
  // and medium kept, and `stream` set to SPM_RECORD_WALL | SPM_RECORD_IMAGE |
  // the wall's patch index; across a medium boundary only where no opaque
  // wall stands between the record and the boundary. Each such record's own
  // `stream` becomes SPM_RECORD_WALL | the patch index of its nearest such
  // opaque wall, so that it counts only on its side of it: where a sheet has
  // fog on both sides, a disk reaching through it would otherwise read the
  // other side's records as well as the images that stand in for them (no
  // estimate is asked for beyond a medium boundary, where no medium is).
  // The stream ids are not read after this (spm_types.h). Images follow
  // their records' order, so the result is deterministic.
  void add(std::vector<SpmVolumeRecord>& records, float radius) const;

  size_t walls() const { return walls_.size(); }

 private:
  struct Wall {
    glm::vec3 centre, u, v, normal;
    float half_u, half_v;
    uint32_t patch;
    bool boundary;  // a medium boundary, not an opaque wall
    // Whether the point `offset` from the centre, in the wall's plane or
    // projected onto it, lies on the rectangle.
    bool covers(glm::vec3 offset) const {
      return std::abs(glm::dot(offset, u)) <= half_u && std::abs(glm::dot(offset, v)) <= half_v;
    }
  };
  // Whether the segment a-b, within the reach of grid cell `cell`, crosses
  // an opaque wall.
  bool crosses_opaque_wall(size_t cell, glm::vec3 a, glm::vec3 b) const;
  std::vector<Wall> walls_;
  // A uniform grid over the walls' bounds, each cell listing (CSR) the
  // walls whose slab of half-depth `reach_` meets it.
  float reach_ = 0.0f;
  glm::vec3 lo_{0.0f}, cell_{1.0f};
  glm::ivec3 dims_{1};
  std::vector<uint32_t> cell_start_, cell_walls_;
};

}  // namespace spm
