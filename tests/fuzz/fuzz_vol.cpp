// libFuzzer target: the .vol reader (spm::parse_vol, which read_vol calls
// after reading the file) on arbitrary bytes, and lookups on what it accepts.
//
// spm::InputError is the expected outcome of a corrupt file; anything else
// (a crash, a sanitizer report, a hang, another exception) is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <string>
#include <typeinfo>

#include "scene/volume_grid.h"
#include "util/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    const spm::VolumeGrid g = spm::parse_vol("fuzz.vol", bytes);
    // What the loader and the kernels rely on: the values the header says,
    // 1 or 3 channels, every value finite and not negative.
    if (g.data.empty() || g.data.size() != size_t(g.nx) * g.ny * g.nz * g.channels) std::abort();
    if (g.channels != 1 && g.channels != 3) std::abort();
    for (const float v : g.data)
      if (!(std::isfinite(v) && v >= 0.0f)) std::abort();
    // A lookup anywhere, NaN included, is a value of the grid's range: a
    // blend of its values, so up to rounding, relative and (for subnormal
    // values) absolute.
    const float bound = g.max_value() * 1.0001f + std::numeric_limits<float>::min();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (const glm::vec3 p : {glm::vec3(0.5f), glm::vec3(0.0f), glm::vec3(1.0f), glm::vec3(-3.0f, 0.3f, 1e30f),
                              glm::vec3(nan, 0.7f, -std::numeric_limits<float>::infinity())}) {
      for (uint32_t c = 0; c < g.channels; ++c) {
        for (const bool nearest : {false, true}) {
          const float v = spm::grid_lookup(g, p, c, nearest);
          if (!(v >= 0.0f && v <= bound)) std::abort();
        }
      }
    }
  } catch (const spm::InputError&) {
    // Refused with a message: the expected outcome.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_vol: parse_vol threw a %s, not spm::InputError: %s\n", typeid(e).name(), e.what());
    std::abort();
  }
  return 0;
}
