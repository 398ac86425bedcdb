// Shared helpers of the test suite.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
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

// Lines of `s` (newline characters).
inline int count_lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

// Line (1-based) of the comment <!--here--> in `text`: where an error must be
// reported.
inline int marked_line(const std::string& text) {
  const size_t at = text.find("<!--here-->");
  EXPECT_NE(at, std::string::npos) << "text without <!--here-->";
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

}  // namespace spm::test
