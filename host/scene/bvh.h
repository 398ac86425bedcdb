// Bounding volume hierarchy over the scene's primitives, built on the host with
// binned SAH and flattened depth-first for the kernels (kernels/lib/intersect.h).
#pragma once

#include <vector>

#include "spm_types.h"

namespace spm {

struct Bvh {
  std::vector<SpmBvhNode> nodes;
};

// Reorders `prims` so that every leaf holds a contiguous range; never empty
// (a scene without primitives gets one empty leaf).
Bvh build_bvh(std::vector<SpmPrim>& prims);

}  // namespace spm
