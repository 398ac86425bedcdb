// libFuzzer target: the reader of Mitsuba's serialized meshes
// (spm::parse_serialized) on arbitrary bytes, twice: as a whole file, for
// shape_index 0 and 1, and as the decompressed content of one shape, which
// the target compresses into a valid file of version 3 and of version 4.
// Mutated compressed data almost never passes zlib's checks, so without the
// second form the fuzzer would seldom get past inflate into the mesh data.
//
// spm::InputError is the expected outcome of a corrupt file; anything else
// (a crash, a sanitizer report, a hang, another exception) is a finding.
#include <zlib.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <optional>
#include <string>
#include <typeinfo>

#include "scene/serialized.h"
#include "util/errors.h"

namespace {

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// What the loader relies on: every index in range, normals and uvs one per
// vertex or none, every number finite, at least one triangle.
void check(const spm::Mesh& mesh, bool vertex_normals) {
  const size_t n = mesh.positions.size();
  for (const auto& t : mesh.triangles)
    if (t.x >= n || t.y >= n || t.z >= n) std::abort();
  if (!mesh.normals.empty() && (mesh.normals.size() != n || !vertex_normals)) std::abort();
  if (!mesh.uvs.empty() && mesh.uvs.size() != n) std::abort();
  if (mesh.triangles.empty()) std::abort();
  for (const auto& p : mesh.positions)
    if (!finite(p)) std::abort();
  for (const auto& v : mesh.normals)
    if (!finite(v)) std::abort();
  for (const auto& uv : mesh.uvs)
    if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) std::abort();
}

std::optional<spm::Mesh> parse(const std::string& bytes, int shape_index, bool vertex_normals) {
  try {
    spm::Mesh mesh = spm::parse_serialized(bytes, "fuzz.serialized", shape_index, vertex_normals, "fuzz.xml:1");
    check(mesh, vertex_normals);
    return mesh;
  } catch (const spm::InputError&) {
    // Refused with a message: the expected outcome.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_serialized: parse_serialized threw a %s, not spm::InputError: %s\n", typeid(e).name(),
                 e.what());
    std::abort();
  }
  return std::nullopt;
}

bool same(const spm::Mesh& a, const spm::Mesh& b, bool normals) {
  return a.positions == b.positions && a.uvs == b.uvs && a.triangles == b.triangles &&
         (!normals || a.normals == b.normals);
}

// Both readings of a shape, the first returned: face_normals drops the normals
// and nothing else (it may accept what the other refuses, since dropped
// normals go unchecked).
std::optional<spm::Mesh> parse_both(const std::string& bytes, int shape_index) {
  std::optional<spm::Mesh> with = parse(bytes, shape_index, true);
  const std::optional<spm::Mesh> without = parse(bytes, shape_index, false);
  if (with && (!without || !same(*with, *without, false))) std::abort();
  return with;
}

std::string le(uint64_t v, int bytes) {
  std::string out;
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  for (int shape_index : {0, 1}) parse_both(bytes, shape_index);

  uLongf compressed_size = compressBound(size);
  std::string stream(compressed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(&stream[0]), &compressed_size, data, size, Z_BEST_SPEED) != Z_OK) std::abort();
  stream.resize(compressed_size);
  for (int version : {3, 4}) {
    // Two copies of the shape, so that shape 1 goes through the offset table.
    const std::string shape = le(0x041C, 2) + le(version, 2) + stream;
    const int entry = version == 4 ? 8 : 4;
    const std::string file = shape + shape + le(0, entry) + le(shape.size(), entry) + le(2, 4);
    const std::optional<spm::Mesh> first = parse_both(file, 0), second = parse_both(file, 1);
    if (first.has_value() != second.has_value() || (first && !same(*first, *second, true))) std::abort();
  }
  return 0;
}
