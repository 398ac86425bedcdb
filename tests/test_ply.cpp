// The PLY reader (spm::parse_ply): meshes written here byte by byte in each
// format come back exactly, and each kind of corrupt file is refused with a
// one-line InputError naming the problem.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "scene/ply.h"
#include "util/errors.h"

namespace spm {
namespace {

// Appends `v` to `out` in the byte order of the file.
template <typename T>
void put(std::string& out, T v, bool big_endian) {
  char raw[sizeof(T)];
  std::memcpy(raw, &v, sizeof(T));
  const uint16_t one = 1;
  char first;
  std::memcpy(&first, &one, 1);
  const bool host_big = first == 0;
  if (host_big != big_endian) std::reverse(raw, raw + sizeof(T));
  out.append(raw, sizeof(T));
}

// A triangle and a quad sharing an edge, in a file of each format, with
// normals and uvs, so that each reading can be checked against these values.
const std::vector<glm::vec3> kPositions = {
    {0.0f, 0.0f, 0.0f}, {1.5f, 0.0f, -2.25f}, {1.0f, 1.0f, 0.125f}, {-0.5f, 3.0f, 1e-3f}, {0.25f, -1e5f, 7.0f}};
const std::vector<glm::vec3> kNormals = {
    {0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.6f, 0.8f, 0.0f}, {0.0f, -0.6f, 0.8f}};
const std::vector<glm::vec2> kUvs = {{0.0f, 0.0f}, {1.0f, 0.0f}, {1.0f, 1.0f}, {0.25f, 0.75f}, {0.5f, -2.0f}};
const std::vector<std::vector<uint32_t>> kFaces = {{0, 1, 2}, {1, 3, 4, 2}};
// The quad fan-triangulated: (0, 1, 2), (0, 2, 3) of its corners.
const std::vector<glm::uvec3> kTriangles = {{0, 1, 2}, {1, 3, 4}, {1, 4, 2}};

std::string header(const std::string& format, bool normals, bool uvs, const std::string& uv_names = "u v") {
  const std::string u = uv_names.substr(0, uv_names.find(' ')), v = uv_names.substr(uv_names.find(' ') + 1);
  std::string h =
      "ply\nformat " + format + " 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) h += "property float nx\nproperty float ny\nproperty float nz\n";
  if (uvs) h += "property float " + u + "\nproperty float " + v + "\n";
  return h + "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string ascii_ply(bool normals, bool uvs, const std::string& uv_names = "u v") {
  std::ostringstream s;
  s.precision(9);
  s << header("ascii", normals, uvs, uv_names);
  for (size_t i = 0; i < kPositions.size(); ++i) {
    s << kPositions[i].x << ' ' << kPositions[i].y << ' ' << kPositions[i].z;
    if (normals) s << ' ' << kNormals[i].x << ' ' << kNormals[i].y << ' ' << kNormals[i].z;
    if (uvs) s << ' ' << kUvs[i].x << ' ' << kUvs[i].y;
    s << '\n';
  }
  for (const auto& face : kFaces) {
    s << face.size();
    for (uint32_t index : face) s << ' ' << index;
    s << '\n';
  }
  return s.str();
}

std::string binary_ply(bool big_endian, bool normals, bool uvs, const std::string& uv_names = "u v") {
  std::string out = header(big_endian ? "binary_big_endian" : "binary_little_endian", normals, uvs, uv_names);
  for (size_t i = 0; i < kPositions.size(); ++i) {
    for (int k = 0; k < 3; ++k) put(out, kPositions[i][k], big_endian);
    if (normals)
      for (int k = 0; k < 3; ++k) put(out, kNormals[i][k], big_endian);
    if (uvs)
      for (int k = 0; k < 2; ++k) put(out, kUvs[i][k], big_endian);
  }
  for (const auto& face : kFaces) {
    put(out, static_cast<uint8_t>(face.size()), big_endian);
    for (uint32_t index : face) put(out, static_cast<int32_t>(index), big_endian);
  }
  return out;
}

void expect_mesh(const Mesh& mesh, bool normals, bool uvs) {
  EXPECT_EQ(mesh.positions, kPositions);
  EXPECT_EQ(mesh.normals, normals ? kNormals : std::vector<glm::vec3>());
  EXPECT_EQ(mesh.uvs, uvs ? kUvs : std::vector<glm::vec2>());
  EXPECT_EQ(mesh.triangles, kTriangles);
}

// The message of the InputError that parsing `bytes` throws; "" (and a
// failure) if it throws none.
std::string message_of(const std::string& bytes, bool vertex_normals) {
  try {
    parse_ply(bytes, "t.ply", vertex_normals, "s.xml:4");
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted, vertex_normals " << vertex_normals;
  return "";
}

// The same, with the file's normals used or dropped alike. Every message is
// one line.
std::string refusal(const std::string& bytes) {
  const std::string message = message_of(bytes, true);
  EXPECT_EQ(message_of(bytes, false), message);
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_EQ(message.rfind("s.xml:4: PLY file t.ply", 0), 0u) << message;
  return message;
}

#define EXPECT_REFUSED(bytes, text)                                \
  do {                                                             \
    const std::string message_ = refusal(bytes);                   \
    EXPECT_NE(message_.find(text), std::string::npos) << message_; \
  } while (0)

TEST(Ply, AsciiWithAndWithoutNormalsAndUvs) {
  for (bool normals : {false, true}) {
    for (bool uvs : {false, true}) {
      SCOPED_TRACE(std::string(normals ? "normals " : "") + (uvs ? "uvs" : ""));
      expect_mesh(parse_ply(ascii_ply(normals, uvs), "t.ply", true, "s.xml:1"), normals, uvs);
    }
  }
}

TEST(Ply, BinaryLittleAndBigEndianWithAndWithoutNormalsAndUvs) {
  for (bool big_endian : {false, true}) {
    for (bool normals : {false, true}) {
      for (bool uvs : {false, true}) {
        SCOPED_TRACE(std::string(big_endian ? "big endian " : "little endian ") + (normals ? "normals " : "") +
                     (uvs ? "uvs" : ""));
        expect_mesh(parse_ply(binary_ply(big_endian, normals, uvs), "t.ply", true, "s.xml:1"), normals, uvs);
      }
    }
  }
}

TEST(Ply, FaceNormalsDropTheFilesNormals) {
  expect_mesh(parse_ply(ascii_ply(true, true), "t.ply", false, "s.xml:1"), false, true);
  expect_mesh(parse_ply(binary_ply(true, true, false), "t.ply", false, "s.xml:1"), false, false);
}

// Mitsuba's names for texture coordinates; v is kept as written (Mitsuba
// flips it only with flip_tex_coords).
TEST(Ply, UvPropertyNames) {
  for (const char* names : {"u v", "s t", "texture_u texture_v", "texture_s texture_t"}) {
    SCOPED_TRACE(names);
    expect_mesh(parse_ply(ascii_ply(false, true, names), "t.ply", true, "s.xml:1"), false, true);
    expect_mesh(parse_ply(binary_ply(false, false, true, names), "t.ply", true, "s.xml:1"), false, true);
  }
}

TEST(Ply, PolygonsAreFanTriangulated) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar uint vertex_index\nend_header\n"
      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n-1 1 0\n-1 0 0\n"
      "4 0 1 2 3\n"
      "6 5 0 1 2 3 4\n";
  const Mesh mesh = parse_ply(ply, "t.ply", true, "s.xml:1");
  const std::vector<glm::uvec3> expected = {{0, 1, 2}, {0, 2, 3}, {5, 0, 1}, {5, 1, 2}, {5, 2, 3}, {5, 3, 4}};
  EXPECT_EQ(mesh.triangles, expected);
  EXPECT_EQ(mesh.positions.size(), 6u);
}

// Elements other than vertex and face, and unused properties (lists among
// them), are skipped by their size, wherever they are in the file.
TEST(Ply, OtherElementsAndPropertiesAreSkipped) {
  const std::string head =
      "ply\nformat FORMAT 1.0\n"
      "element material 2\nproperty uchar red\nproperty list ushort float weights\nproperty double shine\n"
      "element face 1\nproperty int flags\nproperty list uint8 uint16 texcoord\n"
      "property list uint8 uint16 vertex_indices\nproperty float quality\n"
      "element vertex 3\nproperty double x\nproperty list int8 int8 labels\nproperty double y\n"
      "property uchar alpha\nproperty double z\n"
      "element edge 0\nproperty int vertex1\nproperty int vertex2\n"
      "end_header\n";
  const std::vector<glm::vec3> positions = {{1.0f, 2.0f, 3.0f}, {-4.0f, 5.5f, 0.0f}, {0.0f, 0.0f, -8.0f}};

  std::string ascii = head;
  ascii.replace(ascii.find("FORMAT"), 6, "ascii");
  ascii += "255 3 0.5 0.25 1 2.5\n7 0 1e3\n";
  ascii += "-3 4 1 2 3 4 3 2 1 0 0.5\n";
  ascii += "1 2 -1 -2 2 0 3\n-4 0 5.5 255 0\n0 1 9 0 0 -8\n";

  for (bool big_endian : {false, true}) {
    std::string binary = head;
    binary.replace(binary.find("FORMAT"), 6, big_endian ? "binary_big_endian" : "binary_little_endian");
    for (int m = 0; m < 2; ++m) {
      put(binary, static_cast<uint8_t>(200), big_endian);
      put(binary, static_cast<uint16_t>(m), big_endian);
      for (int k = 0; k < m; ++k) put(binary, 0.5f, big_endian);
      put(binary, 2.5, big_endian);
    }
    put(binary, static_cast<int32_t>(-3), big_endian);
    put(binary, static_cast<uint8_t>(1), big_endian);
    put(binary, static_cast<uint16_t>(9), big_endian);
    put(binary, static_cast<uint8_t>(3), big_endian);
    for (uint16_t i : {2, 1, 0}) put(binary, i, big_endian);
    put(binary, 0.5f, big_endian);
    for (const glm::vec3& p : positions) {
      put(binary, static_cast<double>(p.x), big_endian);
      put(binary, static_cast<int8_t>(2), big_endian);
      put(binary, static_cast<int8_t>(-1), big_endian);
      put(binary, static_cast<int8_t>(-2), big_endian);
      put(binary, static_cast<double>(p.y), big_endian);
      put(binary, static_cast<uint8_t>(255), big_endian);
      put(binary, static_cast<double>(p.z), big_endian);
    }

    const Mesh mesh = parse_ply(binary, "t.ply", true, "s.xml:1");
    EXPECT_EQ(mesh.positions, positions);
    EXPECT_EQ(mesh.triangles, std::vector<glm::uvec3>{glm::uvec3(2, 1, 0)});
  }
  const Mesh mesh = parse_ply(ascii, "t.ply", true, "s.xml:1");
  EXPECT_EQ(mesh.positions, positions);
  EXPECT_EQ(mesh.triangles, std::vector<glm::uvec3>{glm::uvec3(2, 1, 0)});
  EXPECT_TRUE(mesh.normals.empty());
  EXPECT_TRUE(mesh.uvs.empty());
}

// Every type, by both its names, as positions, normals, uvs and list types:
// integer values are taken as numbers.
TEST(Ply, EveryTypeName) {
  for (bool big_endian : {false, true}) {
    std::string ply = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                      " 1.0\nelement vertex 3\n"
                      "property char x\nproperty int16 y\nproperty int z\n"
                      "property uchar nx\nproperty ushort ny\nproperty uint32 nz\n"
                      "property double texture_u\nproperty float64 texture_v\n"
                      "property int8 a\nproperty uint8 b\nproperty short c\nproperty uint16 d\nproperty int32 e\n"
                      "property uint f\nproperty float32 g\nproperty float h\n"
                      "element face 1\nproperty list ushort uint vertex_indices\nend_header\n";
    for (int i = 0; i < 3; ++i) {
      put(ply, static_cast<int8_t>(-100 + i), big_endian);
      put(ply, static_cast<int16_t>(-30000 + i), big_endian);
      put(ply, static_cast<int32_t>(-2000000 + i), big_endian);
      put(ply, static_cast<uint8_t>(200 + i), big_endian);
      put(ply, static_cast<uint16_t>(60000 + i), big_endian);
      put(ply, static_cast<uint32_t>(4000000 + i), big_endian);
      put(ply, 0.125 * i, big_endian);
      put(ply, -0.5 * i, big_endian);
      put(ply, static_cast<int8_t>(1), big_endian);
      put(ply, static_cast<uint8_t>(2), big_endian);
      put(ply, static_cast<int16_t>(3), big_endian);
      put(ply, static_cast<uint16_t>(4), big_endian);
      put(ply, static_cast<int32_t>(5), big_endian);
      put(ply, static_cast<uint32_t>(6), big_endian);
      put(ply, 7.0f, big_endian);
      put(ply, 8.0f, big_endian);
    }
    put(ply, static_cast<uint16_t>(3), big_endian);
    for (uint32_t i : {0u, 2u, 1u}) put(ply, i, big_endian);
    const Mesh mesh = parse_ply(ply, "t.ply", true, "s.xml:1");
    ASSERT_EQ(mesh.positions.size(), 3u);
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(mesh.positions[i], glm::vec3(-100 + i, -30000 + i, -2000000 + i));
      EXPECT_EQ(mesh.normals[i], glm::vec3(200 + i, 60000 + i, 4000000 + i));
      EXPECT_EQ(mesh.uvs[i], glm::vec2(0.125f * i, -0.5f * i));
    }
    EXPECT_EQ(mesh.triangles, std::vector<glm::uvec3>{glm::uvec3(0, 2, 1)});
  }
}

TEST(Ply, HeaderCommentsAndCrLfLineEnds) {
  std::string ascii = ascii_ply(true, true);
  ascii.insert(ascii.find("element"), "comment made by hand\nobj_info not used\n\n");
  std::string crlf;
  for (char c : ascii) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  expect_mesh(parse_ply(crlf, "t.ply", true, "s.xml:1"), true, true);

  // A binary file's header with \r\n: the data starts after the \n.
  const std::string binary = binary_ply(false, true, false);
  const size_t data = binary.find("end_header\n") + 11;
  std::string head;
  for (char c : binary.substr(0, data)) head += c == '\n' ? std::string("\r\n") : std::string(1, c);
  head.insert(head.find("element"), "comment a comment\r\n");
  expect_mesh(parse_ply(head + binary.substr(data), "t.ply", true, "s.xml:1"), true, false);
}

TEST(Ply, FaceElementBeforeVertexElement) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
      "3 2 0 1\n0 0 0\n1 0 0\n0 1 0\n";
  const Mesh mesh = parse_ply(ply, "t.ply", true, "s.xml:1");
  EXPECT_EQ(mesh.triangles, std::vector<glm::uvec3>{glm::uvec3(2, 0, 1)});
  EXPECT_EQ(mesh.positions[1], glm::vec3(1, 0, 0));
}

// A binary mesh as big as real scans: a grid of 2 x 300 x 300 triangles.
TEST(Ply, LargeBinaryGrid) {
  const uint32_t n = 301;
  std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(n * n) +
                    "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                    std::to_string((n - 1) * (n - 1)) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i)
      for (float v : {float(i), float(j), 0.0f}) put(ply, v, false);
  for (uint32_t j = 0; j + 1 < n; ++j) {
    for (uint32_t i = 0; i + 1 < n; ++i) {
      put(ply, static_cast<uint8_t>(4), false);
      for (uint32_t v : {j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i}) put(ply, v, false);
    }
  }
  const Mesh mesh = parse_ply(ply, "t.ply", true, "s.xml:1");
  ASSERT_EQ(mesh.positions.size(), n * n);
  ASSERT_EQ(mesh.triangles.size(), 2u * (n - 1) * (n - 1));
  EXPECT_EQ(mesh.positions[n * n - 1], glm::vec3(n - 1, n - 1, 0));
  EXPECT_EQ(mesh.triangles.back(), glm::uvec3(n * n - n - 2, n * n - n - 1 + n, n * n - 2));
}

// The Stanford bunny as Mitsuba's data repository ships it, the mesh of
// scenes/bunny_fog.xml (scenes/meshes/README.md).
TEST(Ply, StanfordBunny) {
  std::ifstream in(SPM_SCENES_DIR "/meshes/bunny.ply", std::ios::binary);
  ASSERT_TRUE(in) << SPM_SCENES_DIR "/meshes/bunny.ply";
  std::stringstream s;
  s << in.rdbuf();
  const Mesh mesh = parse_ply(s.str(), "bunny.ply", true, "s.xml:1");
  EXPECT_EQ(mesh.positions.size(), 35947u);
  EXPECT_EQ(mesh.triangles.size(), 69451u);
  EXPECT_TRUE(mesh.normals.empty());
  EXPECT_TRUE(mesh.uvs.empty());
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const glm::vec3 expected_lo(-0.095f, 0.033f, -0.062f), expected_hi(0.061f, 0.187f, 0.059f);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(lo[k], expected_lo[k], 0.001f) << k;
    EXPECT_NEAR(hi[k], expected_hi[k], 0.001f) << k;
  }
}

// The fuzzer's seeds (tools/fuzz.sh fuzz_ply), one per format: a quad and a
// triangle.
TEST(Ply, FuzzSeedsAreValid) {
  int seeds = 0;
  for (const auto& entry : std::filesystem::directory_iterator(SPM_TEST_DATA_DIR "/ply")) {
    SCOPED_TRACE(entry.path().string());
    std::ifstream in(entry.path(), std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    const Mesh mesh = parse_ply(s.str(), entry.path().filename().string(), true, "s.xml:1");
    EXPECT_EQ(mesh.positions.size(), 5u);
    EXPECT_EQ(mesh.triangles.size(), 3u);
    ++seeds;
  }
  EXPECT_EQ(seeds, 3);
}

// ---- refused files ----------------------------------------------------------

// `ply` with the first `from` replaced by `to`.
std::string edited(std::string ply, const std::string& from, const std::string& to) {
  const size_t at = ply.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return ply.replace(at, from.size(), to);
}

TEST(Ply, NotAPly) {
  EXPECT_REFUSED("solid cube\nfacet normal 0 0 1\n", "t.ply: not a PLY file");
  EXPECT_REFUSED("", "not a PLY file");
  EXPECT_REFUSED("plyformat ascii 1.0\n", "not a PLY file");
}

TEST(Ply, BadHeaders) {
  const std::string ply = ascii_ply(false, false);
  EXPECT_REFUSED(edited(ply, "ascii", "binary_middle_endian"), "t.ply:2: unknown format 'binary_middle_endian'");
  EXPECT_REFUSED(edited(ply, "1.0", "2.0"), "t.ply:2: unknown PLY version '2.0'");
  EXPECT_REFUSED(edited(ply, "format ascii 1.0\n", ""), "t.ply:2: an element before the format line");
  EXPECT_REFUSED(ply.substr(0, ply.find("end_header")), "t.ply:8: the header has no end_header line");
  EXPECT_REFUSED(edited(ply, "end_header", "end_header now"), "t.ply:9: unexpected words after end_header");
  EXPECT_REFUSED(edited(ply, "element vertex 5\n", "property float w\nelement vertex 5\n"),
                 "t.ply:3: a property before any element");
  EXPECT_REFUSED(edited(ply, "property float y", "property float x"), "t.ply:5: a second property 'x'");
  EXPECT_REFUSED(edited(ply, "element vertex 5", "element vertex five"), "t.ply:3: element count 'five' is not");
  EXPECT_REFUSED(edited(ply, "element vertex 5", "element vertex 99999999999999999999999"), "is too large");
  EXPECT_REFUSED(edited(ply, "element vertex 5", "element vertex -5"), "element count '-5' is not a whole number");
  EXPECT_REFUSED(edited(ply, "property float y", "property float16 y"), "t.ply:5: unknown property type 'float16'");
  EXPECT_REFUSED(edited(ply, "list uchar int", "list uchar int128"), "t.ply:8: unknown property type 'int128'");
  EXPECT_REFUSED(edited(ply, "list uchar int", "list float int"), "length type must be an integer type, not float");
  EXPECT_REFUSED(edited(ply, "end_header", "end_header\x01\x02\xff"),
                 "t.ply:9: unknown header keyword 'end_header\\x01\\x02\\xff'");
  EXPECT_REFUSED(edited(ply, "element face", "elements face"), "t.ply:7: unknown header keyword 'elements'");
  EXPECT_REFUSED(edited(ply, "element face", "\x7f\x01\n face"), "unknown header keyword '\\x7f\\x01'");
}

TEST(Ply, MissingPositionsOrPartialNormals) {
  const std::string ply = ascii_ply(true, false);
  EXPECT_REFUSED(edited(ply, "property float y\n", ""), "t.ply:3: the vertex element has no 'y' property");
  EXPECT_REFUSED(edited(ply, "property float x\n", "property float w\n"), "has no 'x' property");
  EXPECT_REFUSED(edited(ply, "property float ny\n", "property float w\n"),
                 "t.ply:3: vertex normals need nx, ny and nz; the vertex element lacks ny");
  EXPECT_REFUSED(edited(edited(ply, "property float ny\n", ""), "property float nz\n", ""), "lacks ny and nz");
  EXPECT_REFUSED(edited(ply, "property float z", "property list uchar float z"),
                 "t.ply:6: vertex property 'z' is a list");
  EXPECT_REFUSED(edited(ply, "element vertex 5\n", "element point 5\n"), "the file has no vertex element");
}

TEST(Ply, BadFaceElement) {
  const std::string ply = ascii_ply(false, false);
  EXPECT_REFUSED(edited(ply, "vertex_indices", "indices"), "t.ply:7: the face element has no vertex_indices");
  EXPECT_REFUSED(edited(ply, "list uchar int vertex_indices", "int vertex_indices"),
                 "t.ply:8: face property vertex_indices is not a list");
  EXPECT_REFUSED(edited(ply, "list uchar int", "list uchar float"),
                 "has float items (vertex indices must be integers)");
}

TEST(Ply, NoFaces) {
  const std::string ply = ascii_ply(false, false);
  const std::string no_face_element = ply.substr(0, ply.find("element face")) + "end_header\n0 0 0\n1 0 0\n";
  EXPECT_REFUSED(edited(no_face_element, "element vertex 5", "element vertex 2"), "t.ply: the file has no faces");
  EXPECT_REFUSED(edited(ply, "element face 2", "element face 0").substr(0, ply.find("end_header") + 11) +
                     "0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n",
                 "t.ply: the file has no faces");
}

TEST(Ply, TruncatedBinaryData) {
  const std::string ply = binary_ply(false, true, true);
  // Inside the last face's indices: the header's minimum sizes still fit.
  EXPECT_EQ(refusal(ply.substr(0, ply.size() - 2)),
            "s.xml:4: PLY file t.ply: the data ends inside face 1 (truncated file)");
  // Inside the vertices: refused by the counts, before reading.
  EXPECT_REFUSED(ply.substr(0, ply.find("end_header") + 11 + 100),
                 "t.ply:3: the file is too short for 5 vertex records (at least 32 bytes each, 100 bytes left)");
  EXPECT_REFUSED(ply.substr(0, ply.find("end_header") + 11), "too short for 5 vertex records");
  // A list length beyond the data.
  std::string long_list = ply.substr(0, ply.size() - 17);
  put(long_list, static_cast<uint8_t>(200), false);
  put(long_list, static_cast<int32_t>(1), false);
  EXPECT_REFUSED(long_list, "the data ends inside face 1 (truncated file)");
  // 4 billion items in a skipped list.
  std::string huge_list =
      edited(ply, "element vertex 5\n", "element junk 1\nproperty list uint double junk\nelement vertex 5\n");
  const size_t data = huge_list.find("end_header") + 11;
  std::string with_list = huge_list.substr(0, data);
  put(with_list, UINT32_MAX, false);
  EXPECT_REFUSED(with_list + huge_list.substr(data), "the data ends inside junk 0 (truncated file)");
}

TEST(Ply, TruncatedAsciiData) {
  const std::string ply = ascii_ply(false, false);
  EXPECT_REFUSED(ply.substr(0, ply.size() - 10), "t.ply:15: the data ends before face 1 (truncated file)");
  EXPECT_REFUSED(edited(ply, "element face 2", "element face 3"),
                 "t.ply:16: the data ends before face 2 (truncated file)");
  EXPECT_REFUSED(ply.substr(0, ply.find("end_header") + 11 + 20),
                 "t.ply:3: the file is too short for 5 vertex records");
}

TEST(Ply, CountTooLargeForTheFile) {
  // 2^40 vertices in a small file: refused without trying to allocate them.
  EXPECT_REFUSED(edited(binary_ply(false, false, false), "element vertex 5", "element vertex 1099511627776"),
                 "t.ply:3: the file is too short for 1099511627776 vertex records");
  EXPECT_REFUSED(edited(ascii_ply(false, false), "element vertex 5", "element vertex 1099511627776"),
                 "too short for 1099511627776 vertex records");
  EXPECT_REFUSED(edited(binary_ply(false, false, false), "element face 2", "element face 18446744073709551615"),
                 "too short for 18446744073709551615 face records");
  // Skipped elements count as well.
  EXPECT_REFUSED(edited(binary_ply(false, false, false), "element vertex 5\n",
                        "element junk 4294967296\nproperty uchar j\nelement vertex 5\n"),
                 "t.ply:3: the file is too short for 4294967296 junk records");
  // An element without properties takes no bytes, however many.
  const Mesh mesh = parse_ply(edited(binary_ply(false, false, false), "element vertex 5\n",
                                     "element nothing 18446744073709551615\nelement vertex 5\n"),
                              "t.ply", true, "s.xml:1");
  expect_mesh(mesh, false, false);
}

TEST(Ply, IndexOutOfRange) {
  std::string ply = binary_ply(false, false, false);
  ply.replace(ply.size() - 8, 4, std::string("\x05\x00\x00\x00", 4));
  EXPECT_EQ(refusal(ply), "s.xml:4: PLY file t.ply: face 1: vertex index 5 out of range (5 vertices)");
  ply.replace(ply.size() - 8, 4, std::string("\xff\xff\xff\xff", 4));
  EXPECT_EQ(refusal(ply), "s.xml:4: PLY file t.ply: face 1: negative vertex index -1");
  ply = edited(binary_ply(true, false, false), "uchar int", "uchar uint");
  ply.replace(ply.size() - 4, 4, std::string("\xff\xff\xff\xfe", 4));
  EXPECT_EQ(refusal(ply), "s.xml:4: PLY file t.ply: face 1: vertex index 4294967294 out of range (5 vertices)");
  EXPECT_EQ(refusal(edited(ascii_ply(false, false), "4 1 3 4 2", "4 1 3 99 2")),
            "s.xml:4: PLY file t.ply:16: face 1: vertex index 99 out of range (5 vertices)");
}

TEST(Ply, FaceWithTwoIndices) {
  EXPECT_REFUSED(edited(ascii_ply(false, false), "3 0 1 2", "2 0 1"),
                 "t.ply:15: face 0: 2 vertex indices (a face needs at least 3)");
  std::string ply = binary_ply(true, false, false);
  const size_t face0 = ply.size() - 17 - 13;
  ply[face0] = 2;
  ply.erase(face0 + 9, 4);
  EXPECT_REFUSED(ply, "t.ply: face 0: 2 vertex indices");
  ply[face0] = 0;
  EXPECT_REFUSED(ply, "t.ply: face 0: 0 vertex indices");
}

TEST(Ply, NegativeListLength) {
  std::string ply = edited(binary_ply(false, false, false), "list uchar int", "list char int");
  ply[ply.size() - 17 - 13] = '\xff';
  EXPECT_REFUSED(ply, "t.ply: face 0: negative length -1 of list 'vertex_indices'");
  EXPECT_REFUSED(edited(edited(ascii_ply(false, false), "list uchar int", "list int8 int"), "3 0 1 2", "-3 0 1 2"),
                 "t.ply:15: face 0: negative length -3 of list 'vertex_indices'");
}

TEST(Ply, NonFiniteValues) {
  const std::string ascii = ascii_ply(true, true);
  EXPECT_REFUSED(edited(ascii, "1.5 0 -2.25", "1.5 nan -2.25"), "t.ply:16: vertex 1: non-finite y (nan)");
  EXPECT_REFUSED(edited(ascii, "1.5 0 -2.25", "1.5 0 -inf"), "t.ply:16: vertex 1: non-finite z (-inf)");
  EXPECT_REFUSED(edited(ascii, "1.5 0 -2.25", "1.5 0 1e39"), "non-finite z as a float (1e+39 is beyond its range)");
  EXPECT_REFUSED(edited(ascii, "1.5 0 -2.25", "1.5 0 1e999"), "vertex 1: '1e999' is out of range ('z')");
  std::string binary = binary_ply(false, true, true);
  const size_t vertex2 = binary.find("end_header\n") + 11 + 2 * 32;
  const float inf = std::numeric_limits<float>::infinity();
  std::memcpy(&binary[vertex2 + 4 * 5], &inf, 4);
  EXPECT_EQ(message_of(binary, true), "s.xml:4: PLY file t.ply: vertex 2: non-finite nz (inf)");
  // Normals that face_normals drops are not read.
  EXPECT_NO_THROW(parse_ply(binary, "t.ply", false, "s.xml:1"));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&binary[vertex2 + 4 * 7], &nan, 4);
  std::memcpy(&binary[vertex2 + 4 * 5], &kNormals[2].z, 4);
  EXPECT_REFUSED(binary, "t.ply: vertex 2: non-finite v (nan)");
}

TEST(Ply, AsciiLinesOfTheWrongLength) {
  const std::string ply = ascii_ply(true, false);
  EXPECT_REFUSED(edited(ply, "1.5 0 -2.25 0 1 0", "1.5 0 -2.25 0 1"),
                 "t.ply:14: vertex 1: too few values on the line (none for 'nz')");
  EXPECT_REFUSED(edited(ply, "4 1 3 4 2", "4 1 3 4"),
                 "t.ply:19: face 1: too few values on the line (none for 'vertex_indices')");
  EXPECT_REFUSED(edited(ply, "1.5 0 -2.25 0 1 0", "1.5 0 -2.25 0 1 0 7"),
                 "t.ply:14: vertex 1: more values on the line than the vertex element has");
  EXPECT_REFUSED(edited(ply, "4 1 3 4 2", "3 1 3 4 2"), "face 1: more values on the line");
  EXPECT_REFUSED(edited(ply, "1.5 0 -2.25", "1.5 0,5 -2.25"), "vertex 1: '0,5' is not a number ('y')");
  EXPECT_REFUSED(edited(ply, "4 1 3 4 2", "4 1 3.0 4 2"), "face 1: '3.0' is not of type int ('vertex_indices')");
  EXPECT_REFUSED(edited(ply, "4 1 3 4 2", "256 1 3 4 2"), "face 1: '256' is not of type uchar ('vertex_indices')");
  EXPECT_REFUSED(edited(ply, "4 1 3 4 2", "-4 1 3 4 2"), "face 1: '-4' is not of type uchar");
}

TEST(Ply, TrailingContent) {
  EXPECT_REFUSED(ascii_ply(false, false) + "\n  \n1 2 3\n", "t.ply:19: data after the last element (trailing content)");
  EXPECT_NO_THROW(parse_ply(ascii_ply(false, false) + "\n \r\n", "t.ply", true, "s.xml:1"));
  EXPECT_REFUSED(binary_ply(false, false, false) + "\n", "t.ply: 1 byte of data after the last element");
}

}  // namespace
}  // namespace spm
