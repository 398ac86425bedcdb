// The two kinds of failure a user can meet, and their exit codes.
#pragma once

#include <stdexcept>
#include <string>

namespace spm {

// Bad input or usage: exit code 2, one line "file:line: problem".
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& where, const std::string& problem)
      : std::runtime_error(where.empty() ? problem : where + ": " + problem) {}
};

// Device or runtime failure: exit code 1, naming the OpenCL call and error.
class RuntimeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

constexpr int kExitInput = 2;
constexpr int kExitRuntime = 1;

}  // namespace spm
