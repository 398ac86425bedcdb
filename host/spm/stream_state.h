// The stream state buffers of a batch, expanded from the one list in
// kernels/spm_streams.h, and bound in that order after (queue, count).
#pragma once

#include "device/device.h"
#include "spm_streams.h"

namespace spm {

struct StreamState {
#define SPM_STREAM_BUFFER(type, name) DeviceBuffer name;
  SPM_STREAM_STATE(SPM_STREAM_BUFFER)
#undef SPM_STREAM_BUFFER

  StreamState() = default;
  StreamState(Device& device, size_t slots) {
#define SPM_STREAM_ALLOC(type, name) name = device.buffer(sizeof(cl_##type) * slots, "stream state " #name);
    SPM_STREAM_STATE(SPM_STREAM_ALLOC)
#undef SPM_STREAM_ALLOC
  }

  static constexpr size_t bytes_per_slot() {
    size_t bytes = 0;
#define SPM_STREAM_SIZE(type, name) bytes += sizeof(cl_##type);
    SPM_STREAM_STATE(SPM_STREAM_SIZE)
#undef SPM_STREAM_SIZE
    return bytes;
  }

  cl_uint bind(cl::Kernel& kernel, cl_uint index) const {
#define SPM_STREAM_BIND(type, name) bind_arg(kernel, index++, "st_" #name, name);
    SPM_STREAM_STATE(SPM_STREAM_BIND)
#undef SPM_STREAM_BIND
    return index;
  }
};

}  // namespace spm
