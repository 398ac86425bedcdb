// OpenCL devices: enumeration, selection, one context + profiling queue per
// device, program builds from the embedded kernel sources (compiled once per
// device model in a process), labelled launches.
#pragma once

#include <CL/opencl.hpp>

#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "util/errors.h"

namespace spm {

struct DeviceInfo {
  int platform = 0;
  int index = 0;  // within its platform
  std::string platform_name;
  std::string name;
  std::string type;  // "GPU", "CPU", "accelerator", "other"
  std::string version;
  cl_uint compute_units = 0;
  cl_ulong global_memory = 0;
  cl_ulong max_alloc = 0;
  size_t max_work_group = 0;
  cl::Device device;
};

// Every device of every platform, in platform order. An empty list (no ICD, no
// platform) is not an error here; selection reports it.
std::vector<DeviceInfo> list_devices();

// `selector`: "" (first GPU, else first CPU, else the first device), "P:D", or a
// case-insensitive substring of the device name. Throws InputError when nothing
// matches, RuntimeError when there is no OpenCL device at all.
DeviceInfo select_device(const std::string& selector);

// A comma-separated list of selectors, or "all" for every device.
std::vector<DeviceInfo> select_devices(const std::string& selector);

// One enqueued command with its label, kept for the profile.
struct Launch {
  std::string label;
  cl::Event event;
  size_t global = 0;  // work-items launched (padded)
  size_t items = 0;   // items that had work
  std::chrono::steady_clock::time_point enqueued;  // host clock, to place device times on the host's
};

// A device buffer that holds its size against its device's memory budget
// while any copy of it lives (Device::buffer): the count falls when the last
// copy goes, whenever the driver frees the memory itself.
class DeviceBuffer : public cl::Buffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(cl::Buffer buffer, std::shared_ptr<void> lease, std::string name)
      : cl::Buffer(std::move(buffer)), lease_(std::move(lease)), name_(std::move(name)) {}

  // What the buffer holds, as Device::buffer was told: it names the
  // buffer's transfers in the profile.
  const std::string& name() const { return name_; }

 private:
  std::shared_ptr<void> lease_;
  std::string name_;
};

// A device buffer's contents on the host in parts that upload one after
// another into one buffer (Device::upload): the grid table's rows, each
// built on a thread of its own, are never copied together on the host.
template <class T>
struct Pieces {
  std::vector<std::vector<T>> parts;

  void append(std::vector<T> part) { parts.push_back(std::move(part)); }
  size_t size() const {
    size_t n = 0;
    for (const auto& p : parts) n += p.size();
    return n;
  }
  const T& operator[](size_t i) const { return const_cast<Pieces*>(this)->operator[](i); }
  T& operator[](size_t i) {
    for (auto& p : parts) {
      if (i < p.size()) return p[i];
      i -= p.size();
    }
    throw std::out_of_range("Pieces: element past the end");
  }
};

class Device {
 public:
  Device(const DeviceInfo& info, std::string kernel_dir);

  const DeviceInfo& info() const { return info_; }
  cl::Context& context() { return context_; }
  cl::CommandQueue& queue() { return queue_; }

  // The kernel `name` of program `program` (kernels/<program>.cl), building the
  // program on first use: from the source, or from the binary another device
  // of the same model built in this process. A build failure throws
  // RuntimeError with the log.
  cl::Kernel kernel(const std::string& program, const std::string& name);

  // Enqueues `kernel` over `items` work-items: the global size is padded to a
  // multiple of the work-group size (OpenCL 1.2 has no non-uniform groups), so
  // every kernel takes its item count and returns early past it. The launch
  // is labelled `label`, or with the kernel's CL_KERNEL_FUNCTION_NAME less
  // its "spm_"; returns its index among the launches since take_launches.
  size_t launch(cl::Kernel& kernel, size_t items, const char* label = nullptr);

  // Sets how many of launch `index`'s work-items had work, when the host
  // learns it after the launch (a queue whose size was on the device).
  void set_items(size_t index, size_t items) { launches_.at(index).items = items; }

  // A device buffer of `bytes`, checked against the device's largest
  // allocation and against the memory budget, summed over every buffer of
  // this device still held (DeviceBuffer): RuntimeError naming `what`
  // rather than a late allocation failure.
  DeviceBuffer buffer(size_t bytes, const std::string& what, cl_mem_flags flags = CL_MEM_READ_WRITE);

  // The bytes all live buffers together may hold (--device-memory); 0: the
  // device's global memory.
  void set_memory_budget(size_t bytes);
  size_t memory_budget() const { return budget_; }
  size_t memory_in_use() const { return live_->load(); }
  size_t memory_free() const {
    const size_t used = memory_in_use();
    return used < budget_ ? budget_ - used : 0;
  }

  // A read-only buffer holding `data`, named `name` (Device::buffer).
  template <class T>
  DeviceBuffer upload(const std::string& name, const std::vector<T>& data, cl_mem_flags flags = CL_MEM_READ_ONLY) {
    // A zero-sized buffer is invalid in OpenCL; empty tables get one element.
    const size_t bytes = sizeof(T) * (data.empty() ? 1 : data.size());
    DeviceBuffer b = buffer(bytes, name, flags);
    if (!data.empty()) {
      cl::Event e;
      queue_.enqueueWriteBuffer(b, CL_TRUE, 0, sizeof(T) * data.size(), data.data(), nullptr, &e);
      launches_.push_back({"upload " + name, e, 0, 0, std::chrono::steady_clock::now()});
    }
    return b;
  }

  // A read-only buffer holding `data`'s parts one after another.
  template <class T>
  DeviceBuffer upload(const std::string& name, const Pieces<T>& data, cl_mem_flags flags = CL_MEM_READ_ONLY) {
    const size_t size = data.size();
    DeviceBuffer b = buffer(sizeof(T) * (size == 0 ? 1 : size), name, flags);
    size_t offset = 0;
    for (const std::vector<T>& part : data.parts) {
      if (part.empty()) continue;
      cl::Event e;
      queue_.enqueueWriteBuffer(b, CL_TRUE, sizeof(T) * offset, sizeof(T) * part.size(), part.data(), nullptr, &e);
      launches_.push_back({"upload " + name, e, 0, 0, std::chrono::steady_clock::now()});
      offset += part.size();
    }
    return b;
  }

  // The first `count` elements of `buffer`, labelled with its name.
  template <class T>
  std::vector<T> download(const DeviceBuffer& buffer, size_t count) {
    std::vector<T> out;
    download_append(buffer, count, out);
    return out;
  }

  // The same, appended to `out` in place (no copy of large maps).
  template <class T>
  void download_append(const DeviceBuffer& buffer, size_t count, std::vector<T>& out) {
    if (count == 0) return;
    const size_t at = out.size();
    out.resize(at + count);
    cl::Event e;
    queue_.enqueueReadBuffer(buffer, CL_TRUE, 0, sizeof(T) * count, out.data() + at, nullptr, &e);
    launches_.push_back({"download " + buffer.name(), e, 0, 0, std::chrono::steady_clock::now()});
  }

  size_t work_group_size(const cl::Kernel& kernel) const;
  double build_seconds() const { return build_seconds_; }

  struct ProgramBuild {
    // About a second from the source cold, a few hundredths when PoCL's (or
    // the driver's) kernel cache hits or the binary is reused.
    double seconds = 0.0;
    bool from_binary = false;  // built from another device's binary
  };
  const std::map<std::string, ProgramBuild>& program_builds() const { return program_builds_; }

  // The launches since the last call, for the profile.
  std::vector<Launch> take_launches() { return std::exchange(launches_, {}); }

 private:
  DeviceInfo info_;
  std::string kernel_dir_;
  cl::Context context_;
  cl::CommandQueue queue_;
  std::map<std::string, cl::Program> programs_;
  std::vector<Launch> launches_;
  std::map<std::string, ProgramBuild> program_builds_;
  size_t preferred_group_ = 64;  // work-items per group, capped by each kernel's limit
  int fill_ = -1;                // SPM_FILL_BUFFERS: the byte new buffers are filled with, or -1
  double build_seconds_ = 0.0;
  size_t budget_ = 0;
  // Bytes of this device's live buffers; a DeviceBuffer's lease, which may
  // outlive the Device and go on another thread, subtracts its size.
  std::shared_ptr<std::atomic<size_t>> live_ = std::make_shared<std::atomic<size_t>>(0);
};

// Throws RuntimeError unless argument `index` of `kernel` is called `name`
// in its OpenCL source: programs are built with -cl-kernel-arg-info, so
// that an argument bound to the wrong position (two of the same type
// swapped, say) fails the launch instead of running. A driver without the
// names (CL_KERNEL_ARG_INFO_NOT_AVAILABLE) is not checked.
void check_arg_name(const cl::Kernel& kernel, cl_uint index, const char* name);

// A kernel argument with the name its kernel gives it.
template <class T>
struct NamedArg {
  const char* name;
  const T& value;
};

template <class T>
NamedArg<T> arg(const char* name, const T& value) {
  return {name, value};
}

// Binds one named argument, checking its name (check_arg_name).
template <class T>
void bind_arg(cl::Kernel& kernel, cl_uint index, const char* name, const T& value) {
  check_arg_name(kernel, index, name);
  kernel.setArg(index, value);
}

// An argument group (such as GpuScene) binds several consecutive arguments
// itself, each with its name, through `cl_uint bind(cl::Kernel&, cl_uint
// first) const`.
template <class T, class = void>
struct binds_arguments : std::false_type {};
template <class T>
struct binds_arguments<T, std::void_t<decltype(std::declval<const T&>().bind(std::declval<cl::Kernel&>(), cl_uint{}))>>
    : std::true_type {};

template <class T>
cl_uint set_arg(cl::Kernel& kernel, cl_uint index, const NamedArg<T>& a) {
  bind_arg(kernel, index, a.name, a.value);
  return index + 1;
}

template <class T>
cl_uint set_arg(cl::Kernel& kernel, cl_uint index, const T& group) {
  static_assert(binds_arguments<T>::value, "name each kernel argument: arg(\"name\", value)");
  return group.bind(kernel, index);
}

// Sets every argument of `kernel` in order, so that no call site counts
// indices, and checks every name against the kernel's.
template <class... Args>
void set_args(cl::Kernel& kernel, const Args&... args) {
  cl_uint index = 0;
  ((index = set_arg(kernel, index, args)), ...);
  const cl_uint expected = kernel.getInfo<CL_KERNEL_NUM_ARGS>();
  if (index != expected) {
    throw RuntimeError("kernel " + kernel.getInfo<CL_KERNEL_FUNCTION_NAME>() + " takes " + std::to_string(expected) +
                       " arguments, the host bound " + std::to_string(index));
  }
}

// "call: CL_ERROR_NAME" for an exception thrown by the OpenCL C++ bindings.
std::string describe(const cl::Error& e);

}  // namespace spm
