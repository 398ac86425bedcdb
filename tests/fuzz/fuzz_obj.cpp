// libFuzzer target: the OBJ reader (spm::parse_obj) on arbitrary bytes, with
// tinyobjloader compiled in here, instrumented, instead of the shared library.
//
// spm::InputError is the expected outcome of a corrupt file; anything else
// (a crash, a sanitizer report, a hang, another exception) is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <typeinfo>

#include "scene/obj.h"
#include "util/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (bool vertex_normals : {true, false}) {
    try {
      const spm::Mesh mesh = spm::parse_obj(text, "fuzz.obj", vertex_normals, "fuzz.xml:1");
      // What the loader relies on: every index in range, normals per vertex or none.
      for (const auto& t : mesh.triangles)
        if (t.x >= mesh.positions.size() || t.y >= mesh.positions.size() || t.z >= mesh.positions.size()) std::abort();
      if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) std::abort();
      if (mesh.triangles.empty()) std::abort();
    } catch (const spm::InputError&) {
      // Refused with a message: the expected outcome.
    } catch (const std::exception& e) {
      std::fprintf(stderr, "fuzz_obj: parse_obj threw a %s, not spm::InputError: %s\n", typeid(e).name(), e.what());
      std::abort();
    }
  }
  return 0;
}
