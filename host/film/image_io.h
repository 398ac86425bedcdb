// Image files: 32-bit float RGB OpenEXR (the render) and a clamped sRGB PNG
// preview. Both are written to a temporary name and renamed, so a failed or
// interrupted write never leaves a half-written file under the final name.
#pragma once

#include <string>
#include <vector>

namespace spm {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  // row-major, 3 floats per pixel, top row first
};

void write_exr(const std::string& path, const Image& image);
Image read_exr(const std::string& path);
void write_png(const std::string& path, const Image& image);

// Linear to sRGB-encoded 8-bit, clamped to [0, 1] first.
unsigned char to_srgb8(float linear);

}  // namespace spm
