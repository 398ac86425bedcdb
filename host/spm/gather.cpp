#include "spm/gather.h"

#include <algorithm>
#include <cstring>

namespace spm {

namespace {

// Pixels per gather launch at most: bounds the film buffer and a launch's length.
constexpr size_t kMaxTile = size_t(1) << 22;

size_t tile_size(const Device& device, size_t pixels, size_t share) {
  const size_t tile = std::min<size_t>({pixels, device.info().max_alloc / sizeof(cl_float4), kMaxTile});
  return std::min(tile, std::max<size_t>(1, share / Gather::kBytesPerPixel));
}

}  // namespace

Gather::Gather(Device& device, const GpuScene& scene, size_t width, size_t pixels, size_t share)
    : device_(device),
      scene_(scene),
      width_(width),
      pixels_(pixels),
      tile_(tile_size(device, pixels, share)),
      kernel_(device.kernel("spm_gather", "spm_gather")),
      chain_kernel_(device.kernel("spm_gather", "spm_chain_pixels")),
      film_(device.buffer(sizeof(cl_float4) * tile_, "film", CL_MEM_WRITE_ONLY)),
      errors_(device.buffer(sizeof(cl_uint), "errors")),
      chain_pixels_(device.buffer(sizeof(cl_uchar) * tile_, "chain_pixels")) {
  const cl_uint no_error = 0;
  device_.queue().enqueueWriteBuffer(errors_, CL_TRUE, 0, sizeof no_error, &no_error);
}

uint64_t Gather::run(const MapGrids& grids, SpmGatherParams params, std::vector<float>& rgb, size_t from,
                     size_t pixels, const char* label) {
  // The film of a whole image may not fit one allocation: tiles of pixels.
  uint64_t tests = 0;
  const size_t end = std::min(pixels_, from + pixels);
  for (size_t first = from; first < end; first += tile_) {
    const size_t count = std::min(tile_, end - first);
    // The flags do not depend on the pass: an image of one tile probes once.
    if (params.emission_chains > 0 && chain_tile_ != first) {
      set_args(chain_kernel_, scene_, arg("camera", scene_.camera()), arg("chain_pixels", chain_pixels_),
               arg("first_pixel", cl_uint(first)), arg("count", cl_uint(count)));
      device_.launch(chain_kernel_, count);
      chain_tile_ = first;
    }
    params.first_pixel = cl_uint(first);
    params.count = cl_uint(count);
    set_args(kernel_, scene_, arg("params", params), arg("camera", scene_.camera()), arg("film", film_),
             arg("errors", errors_), arg("chain_pixels", chain_pixels_), grids);
    // A work-item per block of SPM_GATHER_BLOCK^2 pixels, over the block
    // rows the tile touches (spm_gather.cl).
    const size_t block_rows = (first + count - 1) / width_ / SPM_GATHER_BLOCK - first / width_ / SPM_GATHER_BLOCK + 1;
    device_.launch(kernel_, block_rows * ((width_ + SPM_GATHER_BLOCK - 1) / SPM_GATHER_BLOCK), label);
    const auto film = device_.download<cl_float4>(film_, count);
    for (size_t i = 0; i < count; ++i) {
      for (int c = 0; c < 3; ++c) rgb[3 * (first + i) + c] += film[i].s[c];
      cl_uint n;
      std::memcpy(&n, &film[i].s[3], sizeof n);
      tests += n;
    }
  }
  return tests;
}

bool Gather::nonfinite() {
  const bool bad = device_.download<cl_uint>(errors_, 1)[0] & SPM_ERROR_NONFINITE;
  const cl_uint no_error = 0;
  device_.queue().enqueueWriteBuffer(errors_, CL_TRUE, 0, sizeof no_error, &no_error);
  return bad;
}

}  // namespace spm
