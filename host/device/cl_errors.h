// OpenCL error codes by name, for messages like "clBuildProgram: CL_BUILD_PROGRAM_FAILURE".
#pragma once

#include <string>

namespace spm {

const char* cl_error_name(int code);

}  // namespace spm
