#include "film/compare.h"

#include <cmath>
#include <string>

#include "util/errors.h"

namespace spm {

ImageDifference compare_images(const Image& image, const Image& reference, const std::string& what, double eps) {
  if (image.width != reference.width || image.height != reference.height) {
    throw InputError(what, "the image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                               " but the reference is " + std::to_string(reference.width) + "x" +
                               std::to_string(reference.height));
  }
  ImageDifference d;
  const size_t n = image.rgb.size();
  double squared = 0.0, relative = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double a = image.rgb[i], b = reference.rgb[i], e = a - b;
    squared += e * e;
    relative += e * e / (b * b + eps);
    d.mean[i % 3] += a;
    d.reference_mean[i % 3] += b;
  }
  if (n > 0) {
    d.rmse = std::sqrt(squared / n);
    d.relmse = relative / n;
    for (int c = 0; c < 3; ++c) {
      d.mean[c] /= double(n / 3);
      d.reference_mean[c] /= double(n / 3);
    }
  }
  return d;
}

}  // namespace spm
