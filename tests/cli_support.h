// Running the spm executable from tests: a scratch directory per test, the
// exit code and standard error of each run.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace spm::test {

struct Outcome {
  int code;
  std::string err;
};

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("spm_" + std::string(info->test_suite_name()) + "_" + std::string(info->name()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
    return path(name);
  }

  // Runs `prefix spm args` (prefix: environment or a wrapper such as oclgrind).
  Outcome run(const std::string& args, const std::string& prefix = "") const {
    const std::string err = path("stderr.txt");
    const std::string cmd =
        prefix + " " + std::string(SPM_BINARY) + " " + args + " >/dev/null 2>" + err + " </dev/null";
    const int status = std::system(cmd.c_str());
    std::ifstream in(err);
    std::stringstream s;
    s << in.rdbuf();
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, s.str()};
  }

  std::filesystem::path dir_;
};

}  // namespace spm::test
