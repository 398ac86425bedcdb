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

// The pixels spm reads from an image at most (read_image): 2^26, 768 MiB
// as float RGB.
constexpr long long kMaxImageTexels = 1LL << 26;

// An image as linear RGB: OpenEXR and Radiance HDR as they are, 8- and
// 16-bit files (PNG, JPEG, ...) decoded from sRGB. Throws InputError naming
// the file when it cannot be read or is larger than kMaxImageTexels.
Image read_image(const std::string& path);

// sRGB-encoded in [0, 1] to linear.
float from_srgb(float encoded);

// Linear to sRGB-encoded 8-bit, clamped to [0, 1] first.
unsigned char to_srgb8(float linear);

}  // namespace spm
