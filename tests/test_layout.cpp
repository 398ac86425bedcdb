// Host and device agree on every shared struct (kernels/spm_layout.h).
#include <gtest/gtest.h>

#include <cstddef>
#include <string>
#include <vector>

#include "spm_layout.h"
#include "test_support.h"

namespace {

struct Entry {
  std::string name;
  cl_uint host;
};

std::vector<Entry> host_layout() {
  std::vector<Entry> out;
#define SPM_HOST_SIZE(T, expected) out.push_back({"sizeof(" #T ")", static_cast<cl_uint>(sizeof(T))});
#define SPM_HOST_OFFSET(T, f) out.push_back({"offsetof(" #T ", " #f ")", static_cast<cl_uint>(offsetof(T, f))});
  SPM_LAYOUT_STRUCTS(SPM_HOST_SIZE)
  SPM_LAYOUT_FIELDS(SPM_HOST_OFFSET)
  return out;
}

TEST(Layout, DeviceSeesTheHostLayout) {
  auto& dev = spm::test::device();
  const auto host = host_layout();
  cl::Buffer out(dev.context(), CL_MEM_WRITE_ONLY, sizeof(cl_uint) * host.size());
  cl::Buffer probe(dev.context(), CL_MEM_READ_ONLY, 256);
  cl::Kernel k = dev.kernel("spm_layout", "spm_layout");
  spm::set_args(k, out, probe);
  dev.launch("layout", k, 1);
  const auto device = dev.download<cl_uint>(out, host.size());
  for (size_t i = 0; i < host.size(); ++i) EXPECT_EQ(device[i], host[i].host) << host[i].name;
}

TEST(Layout, StructsAreMultiplesOf16BytesOrSmallPairs) {
  // Arrays of these structs stay 16-byte aligned element by element (STYLE.md).
#define SPM_CHECK_ALIGN(T, expected) EXPECT_TRUE(sizeof(T) % 16 == 0 || sizeof(T) == 8) << #T;
  SPM_LAYOUT_STRUCTS(SPM_CHECK_ALIGN)
}

}  // namespace
