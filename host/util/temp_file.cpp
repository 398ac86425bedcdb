#include "util/temp_file.h"

#include <unistd.h>

#include <filesystem>

#include "util/errors.h"

namespace spm {

namespace fs = std::filesystem;

TempFile::TempFile(const std::string& path) : path_(path), tmp_(path + ".tmp" + std::to_string(::getpid())) {
  const fs::path dir = fs::path(path).parent_path();
  std::error_code ec;
  if (!dir.empty()) fs::create_directories(dir, ec);
}

TempFile::~TempFile() {
  std::error_code ec;
  if (!committed_) fs::remove(tmp_, ec);
}

void TempFile::commit() {
  std::error_code ec;
  fs::rename(tmp_, path_, ec);
  if (ec) throw RuntimeError("cannot write " + path_ + ": " + ec.message());
  committed_ = true;
}

}  // namespace spm
