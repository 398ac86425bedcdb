// The gather (METHOD.md 5): spm_gather over the image, tile by tile, each
// pixel's camera samples evaluating the beam radiance and surface estimates
// over the maps' grids (map_grids.h).
#pragma once

#include <cstdint>
#include <vector>

#include "device/device.h"
#include "scene/gpu_scene.h"
#include "spm/map_grids.h"
#include "spm_types.h"

namespace spm {

class Gather {
 public:
  // Device bytes per pixel of a tile: its film entry (radiance, and the
  // sphere tests in w) and whether its emission comes from emission chains
  // (spm_chain_pixels).
  static constexpr size_t kBytesPerPixel = sizeof(cl_float4) + sizeof(cl_uchar);

  // An image `width` pixels wide of `pixels` pixels, gathered in launches of
  // at most kMaxTile pixels whose buffers fit the device's largest
  // allocation and `share` bytes of its memory.
  Gather(Device& device, const GpuScene& scene, size_t width, size_t pixels, size_t share);

  size_t bytes() const { return tile_ * kBytesPerPixel + sizeof(cl_uint); }

  // Adds the mean radiance of each pixel's samples over `grids` to rgb
  // (pixels x 3); returns the sphere tests the estimates made. `params`'s
  // tile (first_pixel, count) is set here.
  uint64_t run(const MapGrids& grids, SpmGatherParams params, std::vector<float>& rgb) {
    return run(grids, params, rgb, 0, pixels_);
  }

  // The same for the `count` pixels from `first` alone (in image order),
  // the launches profiled as `label` (the kernel's name where null).
  uint64_t run(const MapGrids& grids, SpmGatherParams params, std::vector<float>& rgb, size_t first, size_t count,
               const char* label = nullptr);

  // Whether a pixel's radiance was NaN or infinite since the last call.
  bool nonfinite();

 private:
  Device& device_;
  const GpuScene& scene_;
  size_t width_ = 0, pixels_ = 0, tile_ = 0;
  cl::Kernel kernel_, chain_kernel_;
  DeviceBuffer film_, errors_, chain_pixels_;
  // The first pixel of the tile whose flags chain_pixels_ holds; none yet.
  size_t chain_tile_ = SIZE_MAX;
};

}  // namespace spm
