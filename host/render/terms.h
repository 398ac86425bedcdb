// The gather's terms by name (spm render --terms): the SPM_TERM_* bits of
// kernels/spm_types.h, which the gather computes only when set, so that a
// render of some terms alone shows their part of the image and their cost
// (tools/gather_terms.py).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "spm_types.h"
#include "util/errors.h"

namespace spm {

struct GatherTerm {
  const char* name;
  uint32_t bit;
};

inline constexpr std::array<GatherTerm, 8> kGatherTerms{{
    {"emission", SPM_TERM_EMISSION},
    {"direct", SPM_TERM_DIRECT},
    {"inscatter", SPM_TERM_INSCATTER},
    {"volume", SPM_TERM_VOLUME},
    {"surface", SPM_TERM_SURFACE},
    {"gather_volume", SPM_TERM_GATHER_VOLUME},
    {"gather_direct", SPM_TERM_GATHER_DIRECT},
    {"gather_surface", SPM_TERM_GATHER_SURFACE},
}};

// The bits of `names`; an unknown name is bad input (`flag` names it).
inline uint32_t gather_terms(const std::vector<std::string>& names, const std::string& flag) {
  uint32_t bits = 0;
  for (const std::string& n : names) {
    uint32_t bit = 0;
    for (const GatherTerm& t : kGatherTerms) {
      if (n == t.name) bit = t.bit;
    }
    if (bit == 0) {
      std::string known;
      for (const GatherTerm& t : kGatherTerms) known += std::string(known.empty() ? "" : ", ") + t.name;
      throw InputError(flag, "unknown term '" + n + "' (one of " + known + ")");
    }
    bits |= bit;
  }
  return bits;
}

}  // namespace spm
