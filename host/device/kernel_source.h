// Kernel sources: expanded from kernels/*.cl with every #include "..." inlined.
#pragma once

#include <string>
#include <vector>

namespace spm {

// Reads `path` and recursively inlines each #include "name" (searched next to
// the including file, then in `search_dirs`), with #line markers so that device
// compiler messages name the original file and line. Includes that are not
// found, and angle-bracket includes, are left for the device compiler. Throws
// RuntimeError when a file cannot be read.
std::string expand_kernel_source(const std::string& path, const std::vector<std::string>& search_dirs);

// The expanded source of program `name` (e.g. "spm_gather" for spm_gather.cl):
// from `kernel_dir` when it is not empty (spm --kernel-dir, for kernel
// development), else the copy embedded at build time.
std::string kernel_program_source(const std::string& name, const std::string& kernel_dir);

}  // namespace spm
