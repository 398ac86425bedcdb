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
  const spm::DeviceBuffer out = dev.buffer(sizeof(cl_uint) * host.size(), "layout", CL_MEM_WRITE_ONLY);
  cl::Buffer probe(dev.context(), CL_MEM_READ_ONLY, 256);
  cl::Kernel k = dev.kernel("spm_layout", "spm_layout");
  spm::set_args(k, spm::arg("out", out), spm::arg("probe", probe));
  dev.launch(k, 1);
  const auto device = dev.download<cl_uint>(out, host.size());
  for (size_t i = 0; i < host.size(); ++i) EXPECT_EQ(device[i], host[i].host) << host[i].name;
}

TEST(Layout, StructsAreMultiplesOf16BytesOrSmallPairs) {
  // Arrays of these structs stay 16-byte aligned element by element (STYLE.md).
#define SPM_CHECK_ALIGN(T, expected) EXPECT_TRUE(sizeof(T) % 16 == 0 || sizeof(T) == 8) << #T;
  SPM_LAYOUT_STRUCTS(SPM_CHECK_ALIGN)
}

}  // namespace

namespace {

// Every launch checks each bound argument's name against the kernel's own
// (set_args, check_arg_name), so all host bindings in the suite are
// compared with the kernels'. The check must really run on the test
// device, and a swapped pair or a missing argument must fail.
TEST(KernelArguments, NamesAreCheckedAtEveryBinding) {
  auto& dev = spm::test::device();
  cl::Kernel k = dev.kernel("spm_layout", "spm_layout");
  EXPECT_EQ(k.getArgInfo<CL_KERNEL_ARG_NAME>(0).c_str(), std::string("out")) << "programs lack -cl-kernel-arg-info";
  cl::Buffer out(dev.context(), CL_MEM_WRITE_ONLY, 256), probe(dev.context(), CL_MEM_READ_ONLY, 256);
  EXPECT_NO_THROW(spm::set_args(k, spm::arg("out", out), spm::arg("probe", probe)));
  try {
    spm::set_args(k, spm::arg("probe", probe), spm::arg("out", out));
    ADD_FAILURE() << "two swapped arguments were bound";
  } catch (const spm::RuntimeError& e) {
    EXPECT_NE(std::string(e.what()).find("argument 0 is 'out' in the kernel but the host binds 'probe'"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(spm::set_args(k, spm::arg("out", out)), spm::RuntimeError) << "one argument left unbound";
  // Two arguments of one type: swapping the two queues of a stream kernel
  // would run silently without the names.
  cl::Kernel respawn = dev.kernel("spm_respawn", "spm_respawn");
  EXPECT_EQ(respawn.getArgInfo<CL_KERNEL_ARG_NAME>(1).c_str(), std::string("respawn_queue"));
  EXPECT_THROW(spm::check_arg_name(respawn, 1, "live_next"), spm::RuntimeError);
  EXPECT_NO_THROW(spm::check_arg_name(respawn, 2, "live_next"));
}

}  // namespace
