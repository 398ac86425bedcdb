// The integrator's named options (SCENES.md: estimator, kernel, direct) and
// their codes in the kernels (kernels/spm_types.h), in one table that the
// loader, the command line and the host binding all read; NamedCodes also
// names the gather's terms (render/terms.h).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "spm_types.h"

namespace spm {

struct OptionValue {
  const char* name;
  spm_uint code;
};

// Names and their kernel codes, for messages and lookups.
struct NamedCodes {
  const char* what;  // for messages
  std::vector<OptionValue> values;

  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const OptionValue& v : values) out.emplace_back(v.name);
    return out;
  }

  // "a, b": the names, for messages.
  std::string listed() const {
    std::string out;
    for (const OptionValue& v : values) out += (out.empty() ? "" : ", ") + std::string(v.name);
    return out;
  }

  bool has(const std::string& name) const {
    for (const OptionValue& v : values) {
      if (name == v.name) return true;
    }
    return false;
  }

  // The code of `name`; the loader and the command line let only names of
  // the table through, so another one is a bug.
  spm_uint code(const std::string& name) const {
    for (const OptionValue& v : values) {
      if (name == v.name) return v.code;
    }
    throw std::logic_error(std::string("unknown ") + what + " '" + name + "'");
  }
};

struct IntegratorOption : NamedCodes {
  const char* property;  // the <integrator type="spm"> property
};

inline const IntegratorOption kEstimatorOption{
    {"estimator", {{"bre", SPM_ESTIMATOR_BRE}, {"beams", SPM_ESTIMATOR_BEAMS}, {"paper", SPM_ESTIMATOR_PAPER}}},
    "estimator"};
inline const IntegratorOption kDensityKernelOption{
    {"kernel", {{"uniform", SPM_KERNEL_UNIFORM}, {"epanechnikov", SPM_KERNEL_EPANECHNIKOV}}}, "kernel"};
inline const IntegratorOption kDirectOption{
    {"direct lighting", {{"nee", SPM_DIRECT_NEE}, {"photons", SPM_DIRECT_PHOTONS}}}, "direct"};

}  // namespace spm
