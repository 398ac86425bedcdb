#include "spm/maps_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include "util/errors.h"
#include "util/temp_file.h"

namespace spm {

namespace {

template <class Record>
void write_ply(const std::string& path, const std::vector<Record>& records) {
  float peak = 0.0f;
  for (const auto& r : records) peak = std::max(peak, (r.flux[0] + r.flux[1] + r.flux[2]) / 3.0f);
  TempFile tmp(path);
  {
    std::ofstream out(tmp.name(), std::ios::binary);
    out << "ply\nformat binary_little_endian 1.0\ncomment spm photon map\nelement vertex " << records.size()
        << "\nproperty float x\nproperty float y\nproperty float z\n"
           "property float flux_r\nproperty float flux_g\nproperty float flux_b\n"
           "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
    for (const auto& r : records) {
      out.write(reinterpret_cast<const char*>(r.position), 3 * sizeof(float));
      out.write(reinterpret_cast<const char*>(r.flux), 3 * sizeof(float));
      for (int c = 0; c < 3; ++c) {
        const float v = peak > 0.0f ? std::clamp(r.flux[c] / peak, 0.0f, 1.0f) : 0.0f;
        const auto byte = static_cast<unsigned char>(std::lround(255.0f * v));
        out.put(static_cast<char>(byte));
      }
    }
    if (!out) throw RuntimeError("cannot write " + path);
  }
  tmp.commit();
}

}  // namespace

void write_maps_ply(const std::string& prefix, const PhotonMaps& maps) {
  write_ply(prefix + "_volume.ply", maps.volume);
  write_ply(prefix + "_surface.ply", maps.surface);
}

}  // namespace spm
