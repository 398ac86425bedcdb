// libFuzzer target: the scene parser on arbitrary bytes.
//
// spm::InputError is the expected outcome of a bad file. Anything else is a
// finding: a crash or sanitizer report, a hang (libFuzzer's -timeout), or an
// exception of another type, which escapes as a std::terminate reported here.
//
// The input is loaded as if it were the file tests/data/scene/fuzz.xml, so
// that <include> and OBJ file names resolve to the test data next to it.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <typeinfo>

#include "scene/loader.h"
#include "util/errors.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // The loader warns about degenerate triangles on std::cerr: not a finding.
  std::cerr.rdbuf(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    spm::load_scene_string(text, SPM_FUZZ_DATA_DIR "/scene/fuzz.xml");
  } catch (const spm::InputError&) {
    // Refused with a message: the expected outcome.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_scene: the loader threw a %s, not spm::InputError: %s\n", typeid(e).name(), e.what());
    std::abort();
  }
  return 0;
}
