#include "scene/serialized.h"

#include <zlib.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <vector>

#include "util/errors.h"

namespace spm {

namespace {

// The layout, as Mitsuba 3's serialized shape plugin reads it. A file starts
// with uint16 format id and uint16 version; every shape is such a header
// followed by one zlib stream (deflate with the zlib wrapper) holding: uint32
// flags, the shape's NUL-terminated name (version 4 only), uint64 vertex and
// triangle counts, positions, then normals, uvs and colors as flagged (3, 2
// and 3 reals per vertex, float or double), then 3 uint32 indices per
// triangle. The file ends with each shape's byte offset (uint64 in version 4,
// uint32 in version 3) and the uint32 shape count.
constexpr uint16_t kFormatId = 0x041C;
constexpr uint16_t kVersion3 = 3;
constexpr uint16_t kVersion4 = 4;

// Flag bits that decide the layout. Mitsuba 3 ignores the others: 0x0004
// (tangents, never written), 0x0010 (face normals: only the face_normals
// property drops normals) and 0x1000 (single precision, the default).
constexpr uint32_t kHasNormals = 0x0001;
constexpr uint32_t kHasUvs = 0x0002;
constexpr uint32_t kHasColors = 0x0008;
constexpr uint32_t kDoublePrecision = 0x2000;

// Deflate's densest code gives 258 bytes for a 1-bit length and a 1-bit
// distance code: 1032 output bytes per input byte at most. zlib may also hold
// a few input bytes in its bit accumulator and up to 258 bytes of a match it
// has decoded but not yet written out.
constexpr uint64_t kMaxInflateRatio = 1032;
constexpr uint64_t kHeldInputBytes = 16;
constexpr uint64_t kHeldOutputBytes = 258;

// A longer name means a missing NUL, not a name: refused before it costs memory.
constexpr size_t kMaxNameBytes = 65536;
// Decompressed bytes after what the flags and counts need: Mitsuba ignores
// them, a few are let through (padding), more mean flags or counts that do not
// describe the data.
constexpr size_t kTrailingSlack = 64;
// Arrays are decoded in blocks and grow with the data that actually
// decompressed, so that counts the data does not back cost no memory; this
// many elements are reserved up front at most.
constexpr size_t kBlockBytes = 1 << 16;
constexpr uint64_t kMaxReserve = 1 << 20;

// Throws the InputError of one shape of one file.
class Fail {
 public:
  Fail(const std::string& where, const std::string& prefix) : where_(where), prefix_(prefix) {}
  [[noreturn]] void operator()(const std::string& problem) const { throw InputError(where_, prefix_ + problem); }

 private:
  std::string where_, prefix_;
};

uint64_t sat_mul(uint64_t a, uint64_t b) {
  return b != 0 && a > std::numeric_limits<uint64_t>::max() / b ? std::numeric_limits<uint64_t>::max() : a * b;
}

uint64_t sat_add(uint64_t a, uint64_t b) {
  return a > std::numeric_limits<uint64_t>::max() - b ? std::numeric_limits<uint64_t>::max() : a + b;
}

// Little-endian unsigned integer of `n` bytes, whatever the host's byte order.
uint64_t load_le(const unsigned char* p, size_t n) {
  uint64_t v = 0;
  for (size_t i = n; i-- > 0;) v = (v << 8) | p[i];
  return v;
}

float load_float(const unsigned char* p) {
  const uint32_t bits = static_cast<uint32_t>(load_le(p, 4));
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

double load_double(const unsigned char* p) {
  const uint64_t bits = load_le(p, 8);
  double d;
  std::memcpy(&d, &bits, sizeof d);
  return d;
}

std::string hex16(unsigned v) {
  char s[8];
  std::snprintf(s, sizeof s, "0x%04x", v & 0xFFFFu);
  return s;
}

// One shape's zlib stream, inflated on demand into the caller's buffers, so
// that no more is ever decompressed than the caller asks for.
class Inflater {
 public:
  Inflater(const unsigned char* data, size_t size, const Fail& fail) : next_(data), left_(size), fail_(fail) {
    if (inflateInit(&zs_) != Z_OK) throw std::bad_alloc();
  }
  ~Inflater() { inflateEnd(&zs_); }
  Inflater(const Inflater&) = delete;
  Inflater& operator=(const Inflater&) = delete;

  uint64_t produced() const { return produced_; }

  // What the rest of the stream can decompress to at most.
  uint64_t max_output() const {
    return sat_add(sat_mul(sat_add(zs_.avail_in + left_, kHeldInputBytes), kMaxInflateRatio), kHeldOutputBytes);
  }

  // The stream's decompressed size that the flags and counts call for, for messages.
  void set_expected(uint64_t total) { expected_ = total; }

  // Exactly `n` bytes into `out`; fails when the stream ends first.
  void read(unsigned char* out, size_t n) {
    while (n > 0) {
      const size_t got = step(out, n);
      out += got;
      n -= got;
      if (ended_ && n > 0) {
        if (expected_ == 0)
          fail_("the zlib stream ends within the shape's header, after " + std::to_string(produced_) + " bytes");
        fail_("the zlib stream holds only " + std::to_string(produced_) + " bytes, but the flags and counts need " +
              std::to_string(expected_));
      }
    }
  }

  // The end of the data: at most kTrailingSlack more bytes, then the stream's
  // end, whose checksum zlib verifies.
  void finish() {
    unsigned char extra[kTrailingSlack + 1];
    size_t total = 0;
    while (!ended_ && total < sizeof extra) total += step(extra + total, sizeof extra - total);
    if (total > kTrailingSlack)
      fail_("the zlib stream holds more than the " + std::to_string(expected_) +
            " bytes that the flags and counts need");
  }

 private:
  // One inflate call into out[0, n), n > 0: the bytes it wrote. Fails for a
  // corrupt stream, or one that the file cuts short.
  size_t step(unsigned char* out, size_t n) {
    if (zs_.avail_in == 0 && left_ > 0) {
      const size_t chunk = std::min<size_t>(left_, UINT_MAX);
      zs_.next_in = const_cast<Bytef*>(next_);  // zlib only reads it; its API is not const-correct
      zs_.avail_in = static_cast<uInt>(chunk);
      next_ += chunk;
      left_ -= chunk;
    }
    zs_.next_out = out;
    zs_.avail_out = static_cast<uInt>(std::min<size_t>(n, UINT_MAX));
    const uInt room = zs_.avail_out;
    const int ret = inflate(&zs_, Z_NO_FLUSH);
    const size_t got = room - zs_.avail_out;
    produced_ += got;
    switch (ret) {
      case Z_OK:
        return got;
      case Z_STREAM_END:
        ended_ = true;
        return got;
      case Z_BUF_ERROR:
        // No progress with room to write: every input byte is consumed.
        fail_("the zlib stream is truncated (the file ends within it, after " + std::to_string(produced_) +
              " decompressed bytes)");
      case Z_MEM_ERROR:
        throw std::bad_alloc();
      default:
        fail_(std::string("corrupt zlib stream (") + (zs_.msg ? zs_.msg : "error " + std::to_string(ret)) + ")");
    }
  }

  z_stream zs_{};
  const unsigned char* next_;
  size_t left_;
  const Fail& fail_;
  uint64_t produced_ = 0;
  uint64_t expected_ = 0;
  bool ended_ = false;
};

// Calls item(i, bytes) for `count` items of `item_bytes` each, inflated a block at a time.
template <typename Item>
void for_each_item(Inflater& in, std::vector<unsigned char>& block, uint64_t count, size_t item_bytes, Item&& item) {
  const size_t per_block = block.size() / item_bytes;
  for (uint64_t done = 0; done < count;) {
    const size_t n = static_cast<size_t>(std::min<uint64_t>(per_block, count - done));
    in.read(block.data(), n * item_bytes);
    for (size_t k = 0; k < n; ++k) item(done + k, block.data() + k * item_bytes);
    done += n;
  }
}

// `count` vectors of N reals into `out`, or skipped when `out` is null.
template <int N>
void read_vectors(Inflater& in, std::vector<unsigned char>& block, uint64_t count, bool double_precision,
                  std::vector<glm::vec<N, float>>* out, const char* what, const Fail& fail) {
  const size_t real = double_precision ? 8 : 4;
  if (out) out->reserve(static_cast<size_t>(std::min(count, kMaxReserve)));
  for_each_item(in, block, count, N * real, [&](uint64_t i, const unsigned char* p) {
    if (!out) return;
    glm::vec<N, float> v;
    for (int k = 0; k < N; ++k) {
      const double d = double_precision ? load_double(p + k * real) : load_float(p + k * real);
      if (!(std::fabs(d) <= std::numeric_limits<float>::max()))
        fail("vertex " + std::to_string(i) + " has a non-finite " + what +
             (double_precision ? " (or one beyond float range)" : ""));
      v[k] = static_cast<float>(d);
    }
    out->push_back(v);
  });
}

// Mitsuba finds shape `index` > 0 through the table at the end of the file;
// the offset must lead to a shape header like the file's own.
uint64_t shape_offset(const unsigned char* data, uint64_t size, uint16_t version, int index, const Fail& fail) {
  if (size < 8) fail("the file has no room for its shape count (" + std::to_string(size) + " bytes)");
  const uint64_t count = load_le(data + size - 4, 4);
  if (static_cast<uint64_t>(index) >= count)
    fail("shape_index " + std::to_string(index) + " is out of range: the file has " + std::to_string(count) +
         (count == 1 ? " shape" : " shapes"));
  const uint64_t entry = version == kVersion4 ? 8 : 4;
  // The table, the count and the first shape's header must all fit.
  if (count * entry > size - 8)
    fail("the offset table of " + std::to_string(count) + " shapes does not fit in the file (" + std::to_string(size) +
         " bytes)");
  const uint64_t table = size - 4 - count * entry;
  const uint64_t offset = load_le(data + table + static_cast<uint64_t>(index) * entry, entry);
  if (offset > table - 4)
    fail("offset " + std::to_string(offset) + " is outside the shapes' data (bytes 0 to " + std::to_string(table) +
         " of the file)");
  if (load_le(data + offset, 2) != kFormatId || load_le(data + offset + 2, 2) != version)
    fail("offset " + std::to_string(offset) + " does not lead to a shape header");
  return offset;
}

}  // namespace

Mesh parse_serialized(const std::string& bytes, const std::string& name, int shape_index, bool vertex_normals,
                      const std::string& where) {
  const Fail fail(where, "serialized file " + name + ": shape " + std::to_string(shape_index) + ": ");
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const uint64_t size = bytes.size();
  if (size < 4) fail("the file has " + std::to_string(size) + " bytes, too few for its header");
  const auto format = static_cast<uint16_t>(load_le(data, 2));
  const auto version = static_cast<uint16_t>(load_le(data + 2, 2));
  if (format != kFormatId)
    fail("not a Mitsuba serialized mesh (format id " + hex16(format) + ", expected " + hex16(kFormatId) + ")");
  if (version != kVersion3 && version != kVersion4)
    fail("unsupported version " + std::to_string(version) + " (versions 3 and 4 are read)");
  if (shape_index < 0) fail("shape_index must not be negative");
  const uint64_t start = shape_index == 0 ? 0 : shape_offset(data, size, version, shape_index, fail);

  Inflater in(data + start + 4, static_cast<size_t>(size - start - 4), fail);
  unsigned char head[16];
  in.read(head, 4);
  const auto flags = static_cast<uint32_t>(load_le(head, 4));
  if (version == kVersion4) {
    // The name is not kept: the scene names the shape.
    for (size_t n = 0;; ++n) {
      if (n == kMaxNameBytes)
        fail("the shape's name is longer than " + std::to_string(kMaxNameBytes) + " bytes (no NUL ends it)");
      unsigned char c;
      in.read(&c, 1);
      if (c == 0) break;
    }
  }
  in.read(head, 16);
  const uint64_t vertices = load_le(head, 8), triangles = load_le(head + 8, 8);
  if (triangles == 0) fail("no triangles");
  // Mitsuba's format description gives uint64 indices to such meshes; Mitsuba
  // 3 itself, like this renderer, indexes with 32 bits.
  if (vertices > std::numeric_limits<uint32_t>::max())
    fail(std::to_string(vertices) + " vertices, more than 32-bit indices address");

  const bool double_precision = (flags & kDoublePrecision) != 0;
  const uint64_t reals =
      3 + ((flags & kHasNormals) ? 3 : 0) + ((flags & kHasUvs) ? 2 : 0) + ((flags & kHasColors) ? 3 : 0);
  const uint64_t need = sat_add(sat_mul(vertices, reals * (double_precision ? 8 : 4)), sat_mul(triangles, 12));
  in.set_expected(sat_add(in.produced(), need));
  // Before anything is allocated for them, the counts must be ones the rest
  // of the file can back.
  if (need > in.max_output())
    fail("its counts (" + std::to_string(vertices) + " vertices, " + std::to_string(triangles) + " triangles) need " +
         std::to_string(need) + " bytes, more than the rest of the file can decompress to (" +
         std::to_string(in.max_output()) + " at most)");

  Mesh mesh;
  std::vector<unsigned char> block(kBlockBytes);
  read_vectors<3>(in, block, vertices, double_precision, &mesh.positions, "position", fail);
  if (flags & kHasNormals)
    read_vectors<3>(in, block, vertices, double_precision, vertex_normals ? &mesh.normals : nullptr, "normal", fail);
  if (flags & kHasUvs) read_vectors<2>(in, block, vertices, double_precision, &mesh.uvs, "uv", fail);
  if (flags & kHasColors) read_vectors<3>(in, block, vertices, double_precision, nullptr, "color", fail);
  mesh.triangles.reserve(static_cast<size_t>(std::min(triangles, kMaxReserve)));
  for_each_item(in, block, triangles, 12, [&](uint64_t t, const unsigned char* p) {
    const glm::uvec3 tri(static_cast<uint32_t>(load_le(p, 4)), static_cast<uint32_t>(load_le(p + 4, 4)),
                         static_cast<uint32_t>(load_le(p + 8, 4)));
    for (int k = 0; k < 3; ++k)
      if (tri[k] >= vertices)
        fail("triangle " + std::to_string(t) + " refers to vertex " + std::to_string(tri[k]) + " but the shape has " +
             std::to_string(vertices) + " vertices");
    mesh.triangles.push_back(tri);
  });
  in.finish();
  return mesh;
}

}  // namespace spm
