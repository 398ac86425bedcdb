// The gather's terms by name (spm render --terms): the SPM_TERM_* bits of
// kernels/spm_types.h, which the gather computes only when set, so that a
// render of some terms alone shows their part of the image and their cost
// (tools/gather_terms.py).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scene/integrator_options.h"
#include "util/errors.h"

namespace spm {

inline const NamedCodes kGatherTerms{"gather term",
                                     {{"emission", SPM_TERM_EMISSION},
                                      {"direct", SPM_TERM_DIRECT},
                                      {"inscatter", SPM_TERM_INSCATTER},
                                      {"volume", SPM_TERM_VOLUME},
                                      {"surface", SPM_TERM_SURFACE},
                                      {"gather_volume", SPM_TERM_GATHER_VOLUME},
                                      {"gather_direct", SPM_TERM_GATHER_DIRECT},
                                      {"gather_surface", SPM_TERM_GATHER_SURFACE}}};

// The bits of `names`; an unknown name is bad input (`flag` names it).
inline uint32_t gather_terms(const std::vector<std::string>& names, const std::string& flag) {
  uint32_t bits = 0;
  for (const std::string& n : names) {
    if (!kGatherTerms.has(n)) {
      throw InputError(flag, "unknown term '" + n + "' (one of " + kGatherTerms.listed() + ")");
    }
    bits |= kGatherTerms.code(n);
  }
  return bits;
}

}  // namespace spm
