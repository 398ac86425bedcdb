// libFuzzer target: the PLY reader (spm::parse_ply) on arbitrary bytes.
//
// spm::InputError is the expected outcome of a corrupt file; anything else
// (a crash, a sanitizer report, a hang, an out-of-memory, another exception)
// is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <typeinfo>

#include "scene/ply.h"
#include "util/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  for (bool vertex_normals : {true, false}) {
    try {
      const spm::Mesh mesh = spm::parse_ply(bytes, "fuzz.ply", vertex_normals, "fuzz.xml:1");
      // What the loader relies on: every index in range, normals and uvs per
      // vertex or none, at least one triangle.
      const size_t vertices = mesh.positions.size();
      for (const auto& t : mesh.triangles)
        if (t.x >= vertices || t.y >= vertices || t.z >= vertices) std::abort();
      if (!mesh.normals.empty() && (!vertex_normals || mesh.normals.size() != vertices)) std::abort();
      if (!mesh.uvs.empty() && mesh.uvs.size() != vertices) std::abort();
      if (mesh.triangles.empty()) std::abort();
    } catch (const spm::InputError&) {
      // Refused with a message: the expected outcome.
    } catch (const std::exception& e) {
      std::fprintf(stderr, "fuzz_ply: parse_ply threw a %s, not spm::InputError: %s\n", typeid(e).name(), e.what());
      std::abort();
    }
  }
  return 0;
}
