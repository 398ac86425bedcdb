#include "film/image_io.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <stb_image_write.h>

#include <algorithm>
#include <cmath>

#include "util/errors.h"
#include "util/temp_file.h"

namespace spm {

unsigned char to_srgb8(float linear) {
  const float c = std::clamp(std::isfinite(linear) ? linear : 0.0f, 0.0f, 1.0f);
  const float s = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
  return static_cast<unsigned char>(std::lround(s * 255.0f));
}

void write_exr(const std::string& path, const Image& image) {
  TempFile tmp(path);
  try {
    Imf::Header header(image.width, image.height);
    Imf::FrameBuffer fb;
    const size_t xs = 3 * sizeof(float), ys = xs * image.width;
    char* base = reinterpret_cast<char*>(const_cast<float*>(image.rgb.data()));
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
      header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
    }
    Imf::OutputFile file(tmp.name().c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(image.height);
  } catch (const std::exception& e) {
    throw RuntimeError("cannot write " + path + ": " + e.what());
  }
  tmp.commit();
}

Image read_exr(const std::string& path) {
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    Image image;
    image.width = dw.max.x - dw.min.x + 1;
    image.height = dw.max.y - dw.min.y + 1;
    image.rgb.assign(static_cast<size_t>(image.width) * image.height * 3, 0.0f);
    Imf::FrameBuffer fb;
    const size_t xs = 3 * sizeof(float), ys = xs * image.width;
    char* base = reinterpret_cast<char*>(image.rgb.data()) - (dw.min.x * xs + dw.min.y * ys);
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return image;
  } catch (const std::exception& e) {
    throw InputError(path, std::string("cannot read EXR: ") + e.what());
  }
}

void write_png(const std::string& path, const Image& image) {
  std::vector<unsigned char> bytes(image.rgb.size());
  std::transform(image.rgb.begin(), image.rgb.end(), bytes.begin(), to_srgb8);
  TempFile tmp(path);
  if (!stbi_write_png(tmp.name().c_str(), image.width, image.height, 3, bytes.data(), image.width * 3)) {
    throw RuntimeError("cannot write " + path);
  }
  tmp.commit();
}

}  // namespace spm
