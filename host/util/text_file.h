// Small text outputs (JSON, CSV), written to a temporary name and renamed.
#pragma once

#include <string>

namespace spm {

void write_text(const std::string& path, const std::string& text);

}  // namespace spm
