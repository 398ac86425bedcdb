// The reader of Mitsuba's serialized meshes (spm::parse_serialized): files of
// format versions 3 and 4 written here, every flag, shape selection, and one
// refusal per kind of corrupt file, checked by its message.
#include <gtest/gtest.h>
#include <zlib.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "scene/serialized.h"
#include "util/errors.h"

namespace spm {
namespace {

constexpr uint32_t kNormals = 0x0001, kUvs = 0x0002, kColors = 0x0008, kFaceNormals = 0x0010;
constexpr uint32_t kSingle = 0x1000, kDouble = 0x2000;
const std::string kData = std::string(SPM_TEST_DATA_DIR) + "/serialized";

// One shape as the writer below stores it; the counts default to the arrays' sizes.
struct ShapeSpec {
  uint32_t flags = kSingle;
  std::string name = "mesh";
  std::vector<double> positions, normals, uvs, colors;  // 3, 3, 2 and 3 per vertex
  std::vector<uint32_t> indices;                        // 3 per triangle
  std::optional<uint64_t> vertex_count, triangle_count;
  std::string extra;  // raw bytes after the indices, inside the stream
};

std::string le(uint64_t v, int bytes) {
  std::string out;
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
  return out;
}

std::string real(double v, bool double_precision) {
  if (double_precision) {
    uint64_t bits;
    std::memcpy(&bits, &v, 8);
    return le(bits, 8);
  }
  const float f = static_cast<float>(v);
  uint32_t bits;
  std::memcpy(&bits, &f, 4);
  return le(bits, 4);
}

// The decompressed content of a shape's stream.
std::string payload(const ShapeSpec& s, int version) {
  const bool dp = (s.flags & kDouble) != 0;
  std::string out = le(s.flags, 4);
  if (version == 4) out += s.name + std::string(1, '\0');
  out += le(s.vertex_count.value_or(s.positions.size() / 3), 8);
  out += le(s.triangle_count.value_or(s.indices.size() / 3), 8);
  for (const auto* array : {&s.positions, &s.normals, &s.uvs, &s.colors})
    for (double v : *array) out += real(v, dp);
  for (uint32_t i : s.indices) out += le(i, 4);
  return out + s.extra;
}

std::string compress(const std::string& raw) {
  uLongf size = compressBound(raw.size());
  std::string out(size, '\0');
  EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(&out[0]), &size, reinterpret_cast<const Bytef*>(raw.data()), raw.size(),
                      Z_BEST_COMPRESSION),
            Z_OK);
  out.resize(size);
  return out;
}

std::string header(int version) { return le(0x041C, 2) + le(version, 2); }

// A file of the given compressed streams: each behind its header, then the
// offset table and the shape count.
std::string file_of_streams(const std::vector<std::string>& streams, int version) {
  std::string out;
  std::vector<uint64_t> offsets;
  for (const std::string& stream : streams) {
    offsets.push_back(out.size());
    out += header(version) + stream;
  }
  for (uint64_t offset : offsets) out += le(offset, version == 4 ? 8 : 4);
  return out + le(offsets.size(), 4);
}

std::string file_of(const std::vector<ShapeSpec>& shapes, int version = 4) {
  std::vector<std::string> streams;
  for (const ShapeSpec& s : shapes) streams.push_back(compress(payload(s, version)));
  return file_of_streams(streams, version);
}

// A unit triangle in z = 0, with uvs at its corners and normals up.
ShapeSpec triangle(uint32_t flags) {
  ShapeSpec s;
  s.flags = flags;
  s.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  if (flags & kNormals) s.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  if (flags & kUvs) s.uvs = {0, 0, 1, 0, 0, 1};
  if (flags & kColors) s.colors = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  s.indices = {0, 1, 2};
  return s;
}

// A quad of 4 vertices and 2 triangles at height `z`: tells shapes apart.
ShapeSpec quad(double z) {
  ShapeSpec s;
  s.positions = {0, 0, z, 1, 0, z, 1, 1, z, 0, 1, z};
  s.indices = {0, 1, 2, 0, 2, 3};
  return s;
}

Mesh parse(const std::string& bytes, int shape_index = 0, bool vertex_normals = true) {
  return parse_serialized(bytes, "mesh.serialized", shape_index, vertex_normals, "scene.xml:7");
}

// The message of the InputError that parsing throws; "" (and a failure) if it throws none.
std::string refusal(const std::string& bytes, int shape_index = 0, bool vertex_normals = true) {
  try {
    parse(bytes, shape_index, vertex_normals);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted";
  return "";
}

std::string read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Serialized, ReadsVersion4SinglePrecisionWithNormalsAndUvs) {
  ShapeSpec s = triangle(kSingle | kNormals | kUvs);
  s.positions = {0.5, -1.25, 3, 1e-3, 7, -2, 100, 0, 0.1};
  s.normals = {0, 0, 1, 0.6, 0.8, 0, -1, 0, 0};
  s.uvs = {0.25, 0.75, 1, 0, 0.3, 0.9};
  s.indices = {2, 0, 1};
  const Mesh m = parse(file_of({s}));
  ASSERT_EQ(m.positions.size(), 3u);
  EXPECT_EQ(m.positions[0], glm::vec3(0.5f, -1.25f, 3.0f));
  EXPECT_EQ(m.positions[1], glm::vec3(1e-3f, 7.0f, -2.0f));
  EXPECT_EQ(m.positions[2], glm::vec3(100.0f, 0.0f, 0.1f));
  ASSERT_EQ(m.normals.size(), 3u);
  EXPECT_EQ(m.normals[1], glm::vec3(0.6f, 0.8f, 0.0f));
  ASSERT_EQ(m.uvs.size(), 3u);
  EXPECT_EQ(m.uvs[2], glm::vec2(0.3f, 0.9f));
  ASSERT_EQ(m.triangles.size(), 1u);
  EXPECT_EQ(m.triangles[0], glm::uvec3(2, 0, 1));
}

TEST(Serialized, ReadsVersion3DoublePrecisionWithoutNormals) {
  ShapeSpec s = triangle(kDouble | kUvs);
  s.positions[4] = 0.1;  // a double that rounds to the nearest float
  const Mesh m = parse(file_of({s}, 3));
  ASSERT_EQ(m.positions.size(), 3u);
  EXPECT_EQ(m.positions[1], glm::vec3(1.0f, 0.1f, 0.0f));
  EXPECT_TRUE(m.normals.empty());  // the loader computes smooth ones
  ASSERT_EQ(m.uvs.size(), 3u);
  EXPECT_EQ(m.uvs[1], glm::vec2(1.0f, 0.0f));
  EXPECT_EQ(m.triangles, std::vector<glm::uvec3>{glm::uvec3(0, 1, 2)});
}

TEST(Serialized, WithoutPrecisionFlagsReadsSinglePrecision) {
  // Mitsuba reads doubles only when 0x2000 is set.
  const Mesh m = parse(file_of({triangle(0)}));
  EXPECT_EQ(m.positions[2], glm::vec3(0.0f, 1.0f, 0.0f));
}

TEST(Serialized, ColorsAreReadAndDropped) {
  for (uint32_t precision : {kSingle, kDouble}) {
    const Mesh m = parse(file_of({triangle(precision | kNormals | kUvs | kColors)}));
    EXPECT_EQ(m.positions.size(), 3u);
    EXPECT_EQ(m.normals.size(), 3u);
    EXPECT_EQ(m.uvs[1], glm::vec2(1.0f, 0.0f));
    EXPECT_EQ(m.triangles, std::vector<glm::uvec3>{glm::uvec3(0, 1, 2)});
  }
}

TEST(Serialized, FaceNormalsPropertyDropsNormals) {
  ShapeSpec s = triangle(kSingle | kNormals | kUvs);
  s.normals[0] = std::numeric_limits<double>::quiet_NaN();  // dropped, so not checked
  const Mesh m = parse(file_of({s}), 0, false);
  EXPECT_TRUE(m.normals.empty());
  EXPECT_EQ(m.uvs.size(), 3u);
  EXPECT_EQ(m.positions[1], glm::vec3(1.0f, 0.0f, 0.0f));
}

TEST(Serialized, FaceNormalsFlagInTheFileIsIgnored) {
  // As in Mitsuba 3: only the face_normals property drops normals.
  const Mesh m = parse(file_of({triangle(kSingle | kNormals | kFaceNormals)}));
  EXPECT_EQ(m.normals.size(), 3u);
}

TEST(Serialized, SelectsShapesByIndex) {
  for (int version : {3, 4}) {
    SCOPED_TRACE(version);
    ShapeSpec first = quad(1), second = triangle(kDouble | kNormals), third = quad(3);
    second.name = "middle";
    const std::string bytes = file_of({first, second, third}, version);
    const Mesh m0 = parse(bytes, 0), m1 = parse(bytes, 1), m2 = parse(bytes, 2);
    EXPECT_EQ(m0.positions[2], glm::vec3(1.0f, 1.0f, 1.0f));
    EXPECT_EQ(m0.triangles.size(), 2u);
    EXPECT_EQ(m1.positions.size(), 3u);
    EXPECT_EQ(m1.normals[2], glm::vec3(0.0f, 0.0f, 1.0f));
    EXPECT_EQ(m2.positions[2], glm::vec3(1.0f, 1.0f, 3.0f));
    EXPECT_EQ(m2.triangles[1], glm::uvec3(0, 2, 3));
  }
}

TEST(Serialized, ShapeZeroNeedsNoOffsetTable) {
  // Mitsuba reads shape 0 from the start of the file without the table.
  const std::string bytes = header(4) + compress(payload(quad(2), 4));
  EXPECT_EQ(parse(bytes).positions[0], glm::vec3(0.0f, 0.0f, 2.0f));
}

TEST(Serialized, Utf8NameIsSkipped) {
  ShapeSpec s = quad(0);
  s.name = "\xC3\xA9t\xC3\xA9 \xE2\x9C\x93";
  EXPECT_EQ(parse(file_of({s})).triangles.size(), 2u);
}

TEST(Serialized, ReadsMeshesLargerThanOneBlock) {
  // 30000 vertices of doubles (720 kB of positions) in a strip of triangles.
  ShapeSpec s;
  s.flags = kDouble | kUvs;
  const uint32_t n = 30000;
  for (uint32_t i = 0; i < n; ++i) {
    s.positions.insert(s.positions.end(), {double(i), double(i % 2), 0.5});
    s.uvs.insert(s.uvs.end(), {i / double(n), 1.0});
  }
  for (uint32_t i = 0; i + 2 < n; ++i) s.indices.insert(s.indices.end(), {i, i + 1, i + 2});
  const Mesh m = parse(file_of({s}));
  ASSERT_EQ(m.positions.size(), n);
  ASSERT_EQ(m.uvs.size(), n);
  ASSERT_EQ(m.triangles.size(), n - 2);
  EXPECT_EQ(m.positions[n - 1], glm::vec3(float(n - 1), 1.0f, 0.5f));
  EXPECT_EQ(m.uvs[12345], glm::vec2(float(12345.0 / n), 1.0f));
  EXPECT_EQ(m.triangles[n - 3], glm::uvec3(n - 3, n - 2, n - 1));
}

TEST(Serialized, TheRealFileLoads) {
  const std::string bytes = read(kData + "/two_shapes.serialized");
  ASSERT_FALSE(bytes.empty());
  const Mesh tetrahedron = parse_serialized(bytes, "two_shapes.serialized", 0, true, "s.xml:1");
  ASSERT_EQ(tetrahedron.positions.size(), 4u);
  EXPECT_EQ(tetrahedron.positions[1], glm::vec3(1.0f, -1.0f, -1.0f));
  ASSERT_EQ(tetrahedron.normals.size(), 4u);
  const float s = static_cast<float>(1.0 / std::sqrt(3.0));
  EXPECT_EQ(tetrahedron.normals[3], glm::vec3(-s, -s, s));
  EXPECT_TRUE(tetrahedron.uvs.empty());
  EXPECT_EQ(tetrahedron.triangles, (std::vector<glm::uvec3>{{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}}));
  // Every face winds outward: its normal points away from the centre.
  for (const glm::uvec3& t : tetrahedron.triangles) {
    const glm::vec3 a = tetrahedron.positions[t.x], b = tetrahedron.positions[t.y], c = tetrahedron.positions[t.z];
    EXPECT_GT(glm::dot(glm::cross(b - a, c - a), a + b + c), 0.0f);
  }

  const Mesh quad = parse_serialized(bytes, "two_shapes.serialized", 1, true, "s.xml:1");
  EXPECT_EQ(quad.positions, (std::vector<glm::vec3>{{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}}));
  EXPECT_TRUE(quad.normals.empty());
  EXPECT_EQ(quad.uvs, (std::vector<glm::vec2>{{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
  EXPECT_EQ(quad.triangles, (std::vector<glm::uvec3>{{0, 1, 2}, {0, 2, 3}}));
  EXPECT_NE(refusal(bytes, 2).find("the file has 2 shapes"), std::string::npos);
}

TEST(Serialized, MessagesNameThePlaceTheFileAndTheShape) {
  const std::string m = refusal(file_of({quad(0), quad(1)}), 5);
  EXPECT_EQ(m.rfind("scene.xml:7: serialized file mesh.serialized: shape 5: ", 0), 0u) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos);
}

TEST(Serialized, RefusesWrongMagic) {
  std::string bytes = file_of({quad(0)});
  bytes[0] = 0x04;
  bytes[1] = 0x1C;  // the byte-swapped id
  EXPECT_NE(refusal(bytes).find("not a Mitsuba serialized mesh (format id 0x1c04, expected 0x041c)"),
            std::string::npos);
  EXPECT_NE(refusal("ply\nformat ascii 1.0\n").find("not a Mitsuba serialized mesh"), std::string::npos);
}

TEST(Serialized, RefusesUnknownVersions) {
  for (int version : {0, 2, 5, 0x0400}) {
    std::string bytes = file_of({quad(0)});
    bytes.replace(2, 2, le(version, 2));
    EXPECT_NE(refusal(bytes).find("unsupported version " + std::to_string(version)), std::string::npos);
  }
}

TEST(Serialized, RefusesFilesTooShortForTheHeader) {
  EXPECT_NE(refusal("").find("the file has 0 bytes, too few for its header"), std::string::npos);
  EXPECT_NE(refusal(header(4).substr(0, 3)).find("3 bytes"), std::string::npos);
  EXPECT_NE(refusal(header(4)).find("truncated"), std::string::npos);
  EXPECT_NE(refusal(header(4), 1).find("no room for its shape count"), std::string::npos);
}

TEST(Serialized, RefusesTruncatedFiles) {
  const std::string stream = compress(payload(quad(0), 4));
  const std::string bytes = header(4) + stream.substr(0, stream.size() / 2);
  EXPECT_NE(refusal(bytes).find("the zlib stream is truncated"), std::string::npos) << refusal(bytes);
  // Cut within the second shape: the table is gone, so shape 1 cannot be found.
  const std::string two = file_of({quad(0), quad(1)});
  EXPECT_NE(refusal(two.substr(0, two.size() - 20), 1), "");
}

TEST(Serialized, RefusesBadOffsetTables) {
  const std::string good = file_of({quad(0), quad(1)});
  const size_t table = good.size() - 4 - 16;
  std::string beyond = good;
  beyond.replace(table + 8, 8, le(good.size() + 100, 8));
  EXPECT_NE(refusal(beyond, 1).find("offset " + std::to_string(good.size() + 100) + " is outside the shapes' data"),
            std::string::npos);
  std::string huge = good;
  huge.replace(table + 8, 8, le(~uint64_t(0), 8));
  EXPECT_NE(refusal(huge, 1).find("is outside the shapes' data"), std::string::npos);
  std::string into_table = good;
  into_table.replace(table + 8, 8, le(table - 2, 8));
  EXPECT_NE(refusal(into_table, 1).find("is outside the shapes' data"), std::string::npos);
  std::string astray = good;
  astray.replace(table + 8, 8, le(7, 8));
  EXPECT_NE(refusal(astray, 1).find("offset 7 does not lead to a shape header"), std::string::npos);
  std::string count = good;
  count.replace(good.size() - 4, 4, le(1000000, 4));
  EXPECT_NE(refusal(count, 1).find("the offset table of 1000000 shapes does not fit in the file"), std::string::npos);
  // A version 3 table read as version 4's is off by its width.
  std::string v3 = file_of({quad(0), quad(1)}, 3);
  v3.replace(2, 2, le(4, 2));
  EXPECT_NE(refusal(v3, 1), "");
}

TEST(Serialized, RefusesShapeIndicesOutOfRange) {
  const std::string bytes = file_of({quad(0), quad(1)});
  EXPECT_NE(refusal(bytes, 2).find("shape_index 2 is out of range: the file has 2 shapes"), std::string::npos);
  EXPECT_NE(refusal(bytes, 1000).find("the file has 2 shapes"), std::string::npos);
  EXPECT_NE(refusal(bytes, -1).find("shape -1: shape_index must not be negative"), std::string::npos);
  EXPECT_NE(refusal(file_of({quad(0)}), 1).find("the file has 1 shape"), std::string::npos);
}

TEST(Serialized, RefusesCorruptZlibStreams) {
  std::string bytes = file_of({quad(0)});
  bytes[4] = 0x79;  // the zlib header's check bits no longer hold
  EXPECT_NE(refusal(bytes).find("corrupt zlib stream (incorrect header check)"), std::string::npos);
  const std::string stream = compress(payload(quad(0), 4));
  std::string checksum = header(4) + stream;
  checksum.back() ^= 0x01;  // the Adler-32 of the data
  EXPECT_NE(refusal(checksum).find("corrupt zlib stream (incorrect data check)"), std::string::npos);
  // Raw deflate without the zlib wrapper, as some writers might produce.
  EXPECT_NE(refusal(header(4) + stream.substr(2)).find("corrupt zlib stream"), std::string::npos);
  std::string garbage = header(4) + std::string(64, '\x5A');
  EXPECT_NE(refusal(garbage).find("corrupt zlib stream"), std::string::npos);
}

TEST(Serialized, RefusesStreamsShorterThanTheirCounts) {
  ShapeSpec s = quad(0);
  s.vertex_count = 5;  // one vertex more than written
  const size_t needed = payload(quad(0), 4).size() + 12;
  EXPECT_NE(refusal(file_of({s}))
                .find("the zlib stream holds only " + std::to_string(needed - 12) +
                      " bytes, but the flags and counts need " + std::to_string(needed)),
            std::string::npos)
      << refusal(file_of({s}));
  ShapeSpec flagged = quad(0);
  flagged.flags |= kNormals;  // normals flagged, none written
  EXPECT_NE(refusal(file_of({flagged})).find("holds only"), std::string::npos);
  // A stream that ends inside its header.
  EXPECT_NE(refusal(header(4) + compress(le(kSingle, 4) + "name")).find("ends within the shape's header"),
            std::string::npos);
}

TEST(Serialized, RefusesStreamsLongerThanTheirCounts) {
  ShapeSpec slack = quad(0);
  slack.extra = std::string(64, '\0');  // a little padding is let through
  EXPECT_EQ(parse(file_of({slack})).triangles.size(), 2u);
  ShapeSpec more = quad(0);
  more.extra = std::string(65, '\0');
  EXPECT_NE(refusal(file_of({more}))
                .find("the zlib stream holds more than the " + std::to_string(payload(quad(0), 4).size()) +
                      " bytes that the flags and counts need"),
            std::string::npos);
  ShapeSpec colors = triangle(kSingle);
  colors.colors = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // written but not flagged: the indices come out wrong
  EXPECT_NE(refusal(file_of({colors})), "");
  // A zip bomb: a megabyte of zeros after a valid mesh stops after the slack.
  ShapeSpec bomb = quad(0);
  bomb.extra = std::string(1 << 20, '\0');
  EXPECT_NE(refusal(file_of({bomb})).find("holds more than"), std::string::npos);
}

TEST(Serialized, RefusesIndicesOutOfRange) {
  ShapeSpec s = quad(0);
  s.indices[4] = 4;
  EXPECT_NE(refusal(file_of({s})).find("triangle 1 refers to vertex 4 but the shape has 4 vertices"),
            std::string::npos);
  s.indices[4] = 0xFFFFFFFFu;
  EXPECT_NE(refusal(file_of({s})).find("refers to vertex 4294967295"), std::string::npos);
  ShapeSpec none = quad(0);
  none.positions.clear();
  EXPECT_NE(refusal(file_of({none})).find("triangle 0 refers to vertex 0 but the shape has 0 vertices"),
            std::string::npos);
}

TEST(Serialized, HugeCountsFailFastWithoutAllocating) {
  const auto start = std::chrono::steady_clock::now();
  ShapeSpec vertices = quad(0);
  vertices.vertex_count = uint64_t(1) << 40;
  EXPECT_NE(refusal(file_of({vertices})).find("1099511627776 vertices, more than 32-bit indices address"),
            std::string::npos);
  // Counts that fit 32 bits but not the data: refused before anything is
  // allocated for them (ASan would report an allocation of that size).
  ShapeSpec many = quad(0);
  many.vertex_count = uint64_t(1) << 31;
  EXPECT_NE(refusal(file_of({many}))
                .find("its counts (2147483648 vertices, 2 triangles) need 25769803800 bytes, "
                      "more than the rest of the file can decompress to"),
            std::string::npos)
      << refusal(file_of({many}));
  for (uint64_t triangles : {uint64_t(1) << 40, ~uint64_t(0)}) {
    ShapeSpec s = quad(0);
    s.triangle_count = triangles;
    EXPECT_NE(refusal(file_of({s})).find("more than the rest of the file can decompress to"), std::string::npos);
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(Serialized, RefusesNonFiniteNumbers) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  ShapeSpec position = triangle(kSingle | kNormals | kUvs);
  position.positions[4] = nan;
  EXPECT_NE(refusal(file_of({position})).find("vertex 1 has a non-finite position"), std::string::npos);
  ShapeSpec normal = triangle(kSingle | kNormals | kUvs);
  normal.normals[8] = -inf;
  EXPECT_NE(refusal(file_of({normal})).find("vertex 2 has a non-finite normal"), std::string::npos);
  ShapeSpec uv = triangle(kDouble | kUvs);
  uv.uvs[0] = inf;
  EXPECT_NE(refusal(file_of({uv})).find("vertex 0 has a non-finite uv"), std::string::npos);
  ShapeSpec beyond = triangle(kDouble);
  beyond.positions[0] = 1e300;  // finite as a double, not as a float
  EXPECT_NE(refusal(file_of({beyond})).find("vertex 0 has a non-finite position (or one beyond float range)"),
            std::string::npos);
  ShapeSpec color = triangle(kSingle | kColors);
  color.colors[0] = nan;  // dropped, so not checked
  EXPECT_EQ(parse(file_of({color})).positions.size(), 3u);
}

TEST(Serialized, RefusesShapesWithoutTriangles) {
  ShapeSpec s = quad(0);
  s.indices.clear();
  EXPECT_NE(refusal(file_of({s})).find("shape 0: no triangles"), std::string::npos);
}

TEST(Serialized, RefusesNamesWithoutEnd) {
  ShapeSpec s = quad(0);
  s.name = std::string(70000, 'a');
  EXPECT_NE(refusal(file_of({s})).find("the shape's name is longer than 65536 bytes"), std::string::npos);
}

}  // namespace
}  // namespace spm
