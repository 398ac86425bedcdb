#include "util/text_file.h"

#include <fstream>

#include "util/errors.h"
#include "util/temp_file.h"

namespace spm {

void write_text(const std::string& path, const std::string& text) {
  TempFile tmp(path);
  {
    std::ofstream out(tmp.name(), std::ios::binary);
    out << text;
    if (!out) throw RuntimeError("cannot write " + path);
  }
  tmp.commit();
}

}  // namespace spm
