#include "scene/volume_grid.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "util/errors.h"
#include "util/temp_file.h"

namespace spm {

namespace {

namespace fs = std::filesystem;

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, ".vol files are little endian and read by memcpy");

constexpr size_t kHeaderBytes = 48;  // "VOL", version, encoding, 3 dimensions, channels, 6 bbox floats

template <typename T>
T load(const char* bytes) {
  T v;
  std::memcpy(&v, bytes, sizeof v);
  return v;
}

template <typename T>
void store(std::string& out, T v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

std::string number(float v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Mitsuba 0.6's encodings (its gridvolume documentation), named in the
// refusal of those we do not read.
std::string encoding_name(int32_t encoding) {
  switch (encoding) {
    case 2: return " (float16)";
    case 3: return " (uint8)";
    case 4: return " (quantized directions)";
    default: return "";
  }
}

// The grid a header describes, without its values: `head` holds the first
// min(48, file_size) bytes of a file of `file_size` bytes.
VolumeGrid parse_header(const std::string& name, const char* head, uint64_t file_size) {
  const auto fail = [&](const std::string& problem) { throw InputError(name, problem); };
  if (file_size == 0) fail("empty file, not a .vol file");
  if (std::memcmp(head, "VOL", std::min<uint64_t>(3, file_size)) != 0)
    fail("not a .vol file: it does not start with 'VOL'");
  if (file_size < kHeaderBytes)
    fail("truncated header: " + std::to_string(file_size) + " of " + std::to_string(kHeaderBytes) + " bytes");
  const int version = static_cast<unsigned char>(head[3]);
  if (version != 3) fail("version " + std::to_string(version) + " is not read, only version 3");
  const int32_t encoding = load<int32_t>(head + 4);
  if (encoding != 1)
    fail("encoding " + std::to_string(encoding) + encoding_name(encoding) + " is not read, only 1 (float32)");
  const int32_t dims[3] = {load<int32_t>(head + 8), load<int32_t>(head + 12), load<int32_t>(head + 16)};
  const int32_t channels = load<int32_t>(head + 20);
  const std::string size_text =
      std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " + std::to_string(dims[2]);
  if (channels != 1 && channels != 3) fail(std::to_string(channels) + " channels, only 1 or 3 are read");
  if (dims[0] <= 0 || dims[1] <= 0 || dims[2] <= 0) fail("grid size " + size_text + " is not positive");
  // Each factor is below 2^31 and the running product at most 2^31: no overflow.
  uint64_t values = static_cast<uint64_t>(channels);
  for (const int32_t d : dims) {
    values *= static_cast<uint64_t>(d);
    if (values > kMaxVolumeValues)
      fail("grid of " + size_text + " voxels x " + std::to_string(channels) + " channel(s) exceeds the limit of " +
           std::to_string(kMaxVolumeValues) + " values");
  }
  const uint64_t expected = kHeaderBytes + 4 * values;
  if (file_size != expected)
    fail("file is " + std::to_string(file_size) + " bytes, but a " + size_text + " grid of " +
         std::to_string(channels) + " channel(s) takes " + std::to_string(expected) + " (" +
         std::to_string(kHeaderBytes) + " header + " + std::to_string(4 * values) + " values)");
  VolumeGrid g;
  g.nx = static_cast<uint32_t>(dims[0]);
  g.ny = static_cast<uint32_t>(dims[1]);
  g.nz = static_cast<uint32_t>(dims[2]);
  g.channels = static_cast<uint32_t>(channels);
  float box[6];
  std::memcpy(box, head + 24, sizeof box);
  if (!std::all_of(box, box + 6, [](float v) { return std::isfinite(v); }))
    fail("bounding box (" + number(box[0]) + ", " + number(box[1]) + ", " + number(box[2]) + ") .. (" +
         number(box[3]) + ", " + number(box[4]) + ", " + number(box[5]) + ") is not finite");
  g.bbox_min = glm::vec3(box[0], box[1], box[2]);
  g.bbox_max = glm::vec3(box[3], box[4], box[5]);
  return g;
}

// Densities and albedos: every value finite and not negative.
void check_values(const std::string& name, const VolumeGrid& g) {
  const auto bad = std::find_if(g.data.begin(), g.data.end(), [](float v) { return !(std::isfinite(v) && v >= 0.0f); });
  if (bad == g.data.end()) return;
  const size_t i = static_cast<size_t>(bad - g.data.begin());
  const size_t voxel = i / g.channels;
  const std::string what = std::isnan(*bad) ? "NaN" : std::isinf(*bad) ? "infinite" : "negative (" + number(*bad) + ")";
  throw InputError(name, "value at voxel (" + std::to_string(voxel % g.nx) + ", " +
                             std::to_string(voxel / g.nx % g.ny) + ", " + std::to_string(voxel / g.nx / g.ny) +
                             ") channel " + std::to_string(i % g.channels) + " is " + what);
}

}  // namespace

float VolumeGrid::max_value() const { return data.empty() ? 0.0f : *std::max_element(data.begin(), data.end()); }

VolumeGrid parse_vol(const std::string& name, const std::string& bytes) {
  VolumeGrid g = parse_header(name, bytes.data(), bytes.size());
  g.data.resize(static_cast<size_t>(g.nx) * g.ny * g.nz * g.channels);
  std::memcpy(g.data.data(), bytes.data() + kHeaderBytes, g.data.size() * sizeof(float));
  check_values(name, g);
  return g;
}

// The header first, so that the size is checked before the values are
// allocated, and the values straight into the grid: no second copy of a
// file of up to 8 GiB.
VolumeGrid read_vol(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "file does not exist");
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "not a regular file");
  const uint64_t size = fs::file_size(path, ec);
  if (ec) throw InputError(path, "cannot read: " + ec.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, std::string("cannot read: ") + std::strerror(errno));
  char head[kHeaderBytes] = {};
  in.read(head, static_cast<std::streamsize>(std::min<uint64_t>(size, kHeaderBytes)));
  if (!in) throw InputError(path, std::string("cannot read: ") + std::strerror(errno));
  VolumeGrid g = parse_header(path, head, size);
  g.data.resize(static_cast<size_t>(g.nx) * g.ny * g.nz * g.channels);
  in.read(reinterpret_cast<char*>(g.data.data()), static_cast<std::streamsize>(g.data.size() * sizeof(float)));
  if (!in) throw InputError(path, "cannot read its " + std::to_string(size - kHeaderBytes) + " bytes of values");
  check_values(path, g);
  return g;
}

void write_vol(const std::string& path, const VolumeGrid& g) {
  if (g.nx == 0 || g.ny == 0 || g.nz == 0 || (g.channels != 1 && g.channels != 3) ||
      g.data.size() != static_cast<size_t>(g.nx) * g.ny * g.nz * g.channels)
    throw RuntimeError("cannot write " + path + ": the grid's size, channels and values disagree");
  std::string header = "VOL";
  header += static_cast<char>(3);
  for (const uint32_t v : {1u, g.nx, g.ny, g.nz, g.channels}) store(header, static_cast<int32_t>(v));
  for (int i = 0; i < 3; ++i) store(header, g.bbox_min[i]);
  for (int i = 0; i < 3; ++i) store(header, g.bbox_max[i]);
  TempFile tmp(path);
  {
    std::ofstream out(tmp.name(), std::ios::binary);
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    out.write(reinterpret_cast<const char*>(g.data.data()), static_cast<std::streamsize>(g.data.size() * sizeof(float)));
    if (!out) throw RuntimeError("cannot write " + path);
  }
  tmp.commit();
}

// drjit's Texture3f::eval_nonaccel (drjit 1.5, texture_impl.h tex_eval), which
// Mitsuba 3.9's gridvolume calls in its scalar variants: nearest takes texel
// floor(p * n); trilinear sets x = fma(p, n, -0.5), weights x - floor(x) and
// its complement, and sums the 8 corners, x fastest, each with the product of
// its weights (x first) by fma; "clamp" clamps every texel index to
// [0, n - 1]. With both fmas, as the Mitsuba 3.9.1 wheel computes, the
// lookups match it bit for bit (tools/check_gridvolume.py); unfused they are
// up to 2 ulp apart. Beyond 2^24 every float is whole, so that the weight
// is 0 and both taps clamp to one border texel: clamping x there changes no
// result, and keeps NaN and infinities out of the integer conversion (whose
// overflow past 2^31 makes Mitsuba's own lookups there garbage).
float grid_lookup(const VolumeGrid& g, glm::vec3 p, uint32_t channel, bool nearest) {
  const glm::uvec3 n(g.nx, g.ny, g.nz);
  const auto texel = [&](glm::uvec3 i) { return g.data[((size_t(i.z) * g.ny + i.y) * g.nx + i.x) * g.channels + channel]; };
  const auto index = [&](float f, int axis) {
    return static_cast<uint32_t>(std::fmin(std::fmax(f, 0.0f), static_cast<float>(n[axis] - 1)));
  };
  if (nearest) {
    glm::uvec3 i;
    for (int a = 0; a < 3; ++a) i[a] = index(std::floor(p[a] * static_cast<float>(n[a])), a);
    return texel(i);
  }
  glm::uvec3 lo, hi;
  glm::vec3 w1;
  for (int a = 0; a < 3; ++a) {
    constexpr float kWhole = 16777216.0f;
    const float x = std::fmin(std::fmax(std::fma(p[a], static_cast<float>(n[a]), -0.5f), -kWhole),
                              kWhole + static_cast<float>(n[a]));
    const float f = std::floor(x);
    w1[a] = x - f;
    lo[a] = index(f, a);
    hi[a] = index(f + 1.0f, a);
  }
  const glm::vec3 w0 = 1.0f - w1;
  float sum = 0.0f;
  for (uint32_t corner = 0; corner < 8; ++corner) {
    glm::uvec3 i;
    float weight = 1.0f;
    for (int a = 0; a < 3; ++a) {
      const bool up = (corner >> a) & 1;
      i[a] = up ? hi[a] : lo[a];
      weight *= up ? w1[a] : w0[a];
    }
    sum = std::fma(texel(i), weight, sum);
  }
  return sum;
}

}  // namespace spm
