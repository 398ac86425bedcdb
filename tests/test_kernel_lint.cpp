// Static checks of every OpenCL C program in kernels/ with clang: its
// uninitialised-use warnings and its static analyser (whose core.uninitialized
// checkers follow values across function calls). They complement the memcheck
// render in test_devices.cpp, which sees only what a run executes, and stand in
// for oclgrind's --uninitialized, which cannot run these kernels in oclgrind
// 21.10 (docs/TESTING.md "Tests"). A seeded file proves the checks report what they are
// for.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace {

struct Output {
  int code;
  std::string text;
};

Output run(const std::string& command) {
  Output out{-1, ""};
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return out;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.text.append(buffer.data(), n);
  const int status = pclose(pipe);
  out.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

// As an OpenCL 1.2 device compiler sees the programs: the SPIR target (so
// that Random123 takes its OpenCL path, not the host's intrinsics), OpenCL C's
// built-in declarations, and __OPENCL_VERSION__, which device compilers define
// and clang's front end alone does not.
std::string clang(const std::string& mode, const std::string& file) {
  return std::string(SPM_CLANG) + " " + mode +
         " --target=spir64-unknown-unknown -x cl -cl-std=CL1.2 -Xclang -finclude-default-header"
         " -D__OPENCL_VERSION__=120 -D__ENDIAN_LITTLE__=1 -I" SPM_KERNEL_SOURCE_DIR " -I" SPM_RANDOM123_DIR " " +
         file;
}

// Unused parameters are left out: every stream kernel takes the whole stream
// state list (kernels/spm_streams.h) and uses part of it.
const std::string kWarnings =
    "-fsyntax-only -Wall -Wextra -Wno-unused-parameter -Wuninitialized -Wsometimes-uninitialized "
    "-Wconditional-uninitialized";
const std::string kAnalyzer = "--analyze -o /dev/null";

std::vector<std::string> programs() {
  std::vector<std::string> out;
  for (const auto& entry : std::filesystem::directory_iterator(SPM_KERNEL_SOURCE_DIR)) {
    if (entry.path().extension() == ".cl") out.push_back(entry.path().string());
  }
  return out;
}

TEST(KernelLint, ClangIsThere) {
  // tools/install-deps.sh installs clang-14.
  ASSERT_EQ(run(std::string(SPM_CLANG) + " --version").code, 0) << SPM_CLANG << " not found";
}

TEST(KernelLint, EveryProgramCompilesWithoutWarnings) {
  const auto files = programs();
  EXPECT_GE(files.size(), 9u);
  for (const auto& file : files) {
    const Output out = run(clang(kWarnings, file));
    EXPECT_EQ(out.code, 0) << file << "\n" << out.text;
    EXPECT_EQ(out.text.find("warning"), std::string::npos) << file << "\n" << out.text;
  }
}

TEST(KernelLint, TheStaticAnalyzerFindsNothing) {
  for (const auto& file : programs()) {
    const Output out = run(clang(kAnalyzer, file));
    EXPECT_EQ(out.code, 0) << file << "\n" << out.text;
    EXPECT_EQ(out.text.find("warning"), std::string::npos) << file << "\n" << out.text;
  }
}

TEST(KernelLint, TheChecksReportSeededUninitialisedValues) {
  const std::string seeded = std::string(SPM_TEST_DATA_DIR) + "/lint/uninitialized.cl";
  const Output warnings = run(clang(kWarnings, seeded));
  EXPECT_NE(warnings.text.find("uninitialized.cl:4:7: warning: variable 'v' is used uninitialized"),
            std::string::npos)
      << warnings.text;
  const Output analyzer = run(clang(kAnalyzer, seeded));
  EXPECT_NE(analyzer.text.find("uninitialized.cl:5:10: warning: Assigned value is garbage or undefined"),
            std::string::npos)
      << analyzer.text;
  // Across a call: a struct returned with a field never written.
  EXPECT_NE(analyzer.text.find("uninitialized.cl:21:10: warning: Assigned value is garbage or undefined"),
            std::string::npos)
      << analyzer.text;
}

}  // namespace
