#include "film/image_io.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <stb_image.h>
#include <stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <memory>

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

float from_srgb(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

Image read_image(const std::string& path) {
  const auto too_large = [&](long long w, long long h) {
    if (w * h > kMaxImageTexels)
      throw InputError(path, "image of " + std::to_string(w) + " x " + std::to_string(h) +
                                 " pixels is larger than spm reads (" + std::to_string(kMaxImageTexels) + ")");
  };
  const std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  if (ext == ".exr" || ext == ".EXR") {
    try {
      const Imath::Box2i dw = Imf::InputFile(path.c_str()).header().dataWindow();
      too_large(dw.max.x - dw.min.x + 1LL, dw.max.y - dw.min.y + 1LL);
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError(path, std::string("cannot read EXR: ") + e.what());
    }
    return read_exr(path);
  }
  int w = 0, h = 0, channels = 0;
  if (!stbi_info(path.c_str(), &w, &h, &channels))
    throw InputError(path, std::string("cannot read image: ") + stbi_failure_reason());
  too_large(w, h);
  Image image;
  image.width = w;
  image.height = h;
  image.rgb.resize(size_t(w) * h * 3);
  if (stbi_is_hdr(path.c_str())) {
    // Radiance .hdr: linear already.
    std::unique_ptr<float, void (*)(void*)> data(stbi_loadf(path.c_str(), &w, &h, &channels, 3), stbi_image_free);
    if (!data) throw InputError(path, std::string("cannot read image: ") + stbi_failure_reason());
    std::copy(data.get(), data.get() + image.rgb.size(), image.rgb.begin());
    return image;
  }
  // 8 or 16 bits per channel, sRGB-encoded as PNG and JPEG files are.
  std::unique_ptr<stbi_us, void (*)(void*)> data(stbi_load_16(path.c_str(), &w, &h, &channels, 3), stbi_image_free);
  if (!data) throw InputError(path, std::string("cannot read image: ") + stbi_failure_reason());
  for (size_t k = 0; k < image.rgb.size(); ++k) image.rgb[k] = from_srgb(data.get()[k] / 65535.0f);
  return image;
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
