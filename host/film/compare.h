// An image against a reference, with the measures tools/compare.py prints:
// for judging a render where Python and its OpenEXR module are missing (a
// device machine without a package registry, tools/device_run.sh).
#pragma once

#include <array>

#include "film/image_io.h"

namespace spm {

struct ImageDifference {
  double rmse = 0.0;
  double relmse = 0.0;  // mean over pixels and channels of (a - b)^2 / (b^2 + eps)
  std::array<double, 3> mean{}, reference_mean{};
};

// `image` and `reference` must have one size (InputError naming `what` otherwise).
ImageDifference compare_images(const Image& image, const Image& reference, const std::string& what,
                               double eps = 1e-2);

}  // namespace spm
