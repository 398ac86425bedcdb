// Shared helpers of the test suite.
#pragma once

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "device/device.h"

namespace spm::test {

// The OpenCL device the tests run on: $SPM_TEST_DEVICE (a --device selector)
// or the default choice; one per test binary, so kernels build once.
inline Device& device() {
  static Device d(select_device(std::getenv("SPM_TEST_DEVICE") ? std::getenv("SPM_TEST_DEVICE") : ""), "");
  return d;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace spm::test
