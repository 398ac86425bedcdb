// Output files are written to a sibling temporary name and renamed on success,
// so a failed or interrupted write never leaves a half-written file under the
// final name.
#pragma once

#include <string>

namespace spm {

class TempFile {
 public:
  explicit TempFile(const std::string& path);  // creates the parent directory
  ~TempFile();                                 // removes the temporary unless committed
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;

  const std::string& name() const { return tmp_; }
  void commit();  // renames the temporary over the final path

 private:
  std::string path_, tmp_;
  bool committed_ = false;
};

}  // namespace spm
