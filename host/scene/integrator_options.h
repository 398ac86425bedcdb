// The integrator's named options (SCENES.md: estimator, kernel, direct) and
// their codes in the kernels (kernels/spm_types.h), in one table that the
// loader, the command line and the host binding all read.
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

struct IntegratorOption {
  const char* property;  // the <integrator type="spm"> property
  const char* what;      // for messages
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

inline const IntegratorOption kEstimatorOption{
    "estimator", "estimator", {{"bre", SPM_ESTIMATOR_BRE}, {"beams", SPM_ESTIMATOR_BEAMS}, {"paper", SPM_ESTIMATOR_PAPER}}};
inline const IntegratorOption kDensityKernelOption{
    "kernel", "kernel", {{"uniform", SPM_KERNEL_UNIFORM}, {"epanechnikov", SPM_KERNEL_EPANECHNIKOV}}};
inline const IntegratorOption kDirectOption{
    "direct", "direct lighting", {{"nee", SPM_DIRECT_NEE}, {"photons", SPM_DIRECT_PHOTONS}}};

}  // namespace spm
