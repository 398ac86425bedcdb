#include "device/device.h"

#include <cstring>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <mutex>

#include "device/cl_errors.h"
#include "device/kernel_source.h"
#include "util/errors.h"

namespace spm {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string type_name(cl_device_type t) {
  if (t & CL_DEVICE_TYPE_GPU) return "GPU";
  if (t & CL_DEVICE_TYPE_CPU) return "CPU";
  if (t & CL_DEVICE_TYPE_ACCELERATOR) return "accelerator";
  return "other";
}

// Program binaries built in this process, by device model and source. A
// second device of the same model (two GPUs of one kind, or PoCL's
// POCL_DEVICES="pthread pthread") loads the first one's binary rather than
// compiling the source again: for the eight programs on PoCL that is 0.34 s
// instead of 0.65 s with warm caches, and a second device no longer takes CPU
// time from the first device's kernels for a duplicate compile. A device that
// wants a program another device of its model is building waits for it.
class BinaryCache {
 public:
  struct Entry {
    std::mutex building;
    std::vector<unsigned char> binary;  // empty until a device built the source
  };

  Entry& entry(const std::string& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto& e = entries_[key];
    if (!e) e = std::make_unique<Entry>();
    return *e;
  }

 private:
  std::mutex mutex_;
  std::map<std::string, std::unique_ptr<Entry>> entries_;
};

BinaryCache& binary_cache() {
  static BinaryCache cache;
  return cache;
}

// Binaries are only portable between devices of the same platform, model and
// driver.
std::string model_key(const DeviceInfo& info) {
  return info.platform_name + '\n' + info.name + '\n' + info.version + '\n' +
         info.device.getInfo<CL_DRIVER_VERSION>() + '\n';
}

// -cl-kernel-arg-info keeps every argument's name for check_arg_name.
const char* const kBuildOptions = "-cl-std=CL1.2 -cl-kernel-arg-info";

}  // namespace

std::string describe(const cl::Error& e) { return std::string(e.what()) + ": " + cl_error_name(e.err()); }

std::vector<DeviceInfo> list_devices() {
  std::vector<cl::Platform> platforms;
  // ocl-icd returns CL_PLATFORM_NOT_FOUND_KHR when no ICD is installed: no devices.
  if (cl::Platform::get(&platforms) != CL_SUCCESS) return {};
  std::vector<DeviceInfo> out;
  for (size_t p = 0; p < platforms.size(); ++p) {
    std::vector<cl::Device> devices;
    try {
      platforms[p].getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
      continue;  // CL_DEVICE_NOT_FOUND: a platform without devices
    }
    for (size_t d = 0; d < devices.size(); ++d) {
      DeviceInfo info;
      info.platform = static_cast<int>(p);
      info.index = static_cast<int>(d);
      info.platform_name = platforms[p].getInfo<CL_PLATFORM_NAME>();
      info.device = devices[d];
      info.name = devices[d].getInfo<CL_DEVICE_NAME>();
      info.type = type_name(devices[d].getInfo<CL_DEVICE_TYPE>());
      info.version = devices[d].getInfo<CL_DEVICE_VERSION>();
      info.compute_units = devices[d].getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
      info.global_memory = devices[d].getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
      info.max_alloc = devices[d].getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
      info.max_work_group = devices[d].getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>();
      out.push_back(info);
    }
  }
  return out;
}

DeviceInfo select_device(const std::string& selector) {
  const auto devices = list_devices();
  if (devices.empty()) throw RuntimeError("no OpenCL device found (is an ICD such as pocl-opencl-icd installed?)");
  if (selector.empty()) {
    for (const char* want : {"GPU", "CPU"}) {
      for (const auto& d : devices) {
        if (d.type == want) return d;
      }
    }
    return devices.front();
  }
  int p = -1, d = -1;
  char tail = 0;
  if (std::sscanf(selector.c_str(), "%d:%d%c", &p, &d, &tail) == 2) {
    for (const auto& info : devices) {
      if (info.platform == p && info.index == d) return info;
    }
    throw InputError("--device", "no device " + selector + " (see 'spm devices')");
  }
  for (const auto& info : devices) {
    if (lower(info.name).find(lower(selector)) != std::string::npos) return info;
  }
  throw InputError("--device", "no device name contains '" + selector + "' (see 'spm devices')");
}

std::vector<DeviceInfo> select_devices(const std::string& selector) {
  if (lower(selector) == "all") {
    auto all = list_devices();
    if (all.empty()) throw RuntimeError("no OpenCL device found (is an ICD such as pocl-opencl-icd installed?)");
    return all;
  }
  std::vector<DeviceInfo> out;
  size_t begin = 0;
  for (;;) {
    const size_t comma = selector.find(',', begin);
    const DeviceInfo d = select_device(selector.substr(begin, comma - begin));
    for (const auto& o : out) {
      if (o.platform == d.platform && o.index == d.index) {
        throw InputError("--device", "device " + std::to_string(d.platform) + ":" + std::to_string(d.index) +
                                         " is selected twice");
      }
    }
    out.push_back(d);
    if (comma == std::string::npos) return out;
    begin = comma + 1;
  }
}

Device::Device(const DeviceInfo& info, std::string kernel_dir) : info_(info), kernel_dir_(std::move(kernel_dir)) {
  // SPM_WORK_GROUP_SIZE tunes (and the tests vary) the work-group size; the
  // images must not depend on it (METHOD.md 7).
  if (const char* env = std::getenv("SPM_WORK_GROUP_SIZE")) {
    char* end = nullptr;
    const unsigned long v = std::strtoul(env, &end, 10);
    if (*end != 0 || v == 0) {
      throw InputError("SPM_WORK_GROUP_SIZE", std::string("expected a positive number, got '") + env + "'");
    }
    preferred_group_ = v;
  }
  // SPM_FILL_BUFFERS fills every new buffer with one byte value before use:
  // OpenCL leaves new buffers undefined, so no kernel may read a byte it did
  // not write first. Renders with two fills must agree bit for bit (the
  // tests), which catches reads of unwritten device memory on any device.
  if (const char* env = std::getenv("SPM_FILL_BUFFERS")) {
    char* end = nullptr;
    const unsigned long v = std::strtoul(env, &end, 0);
    if (*env == 0 || *end != 0 || v > 255) {
      throw InputError("SPM_FILL_BUFFERS", std::string("expected a byte value 0-255, got '") + env + "'");
    }
    fill_ = static_cast<int>(v);
  }
  set_memory_budget(0);
  context_ = cl::Context(info_.device);
  queue_ = cl::CommandQueue(context_, info_.device, CL_QUEUE_PROFILING_ENABLE);
}

cl::Kernel Device::kernel(const std::string& program, const std::string& name) {
  auto it = programs_.find(program);
  if (it == programs_.end()) {
    const std::string source = kernel_program_source(program, kernel_dir_);
    BinaryCache::Entry& cached = binary_cache().entry(model_key(info_) + source);
    std::lock_guard<std::mutex> lock(cached.building);
    const auto start = std::chrono::steady_clock::now();
    ProgramBuild build;
    cl::Program prog;
    if (!cached.binary.empty()) {
      // A driver may still refuse a binary (CL_INVALID_BINARY); the source
      // build below is then the answer, not an error.
      try {
        prog = cl::Program(context_, {info_.device}, cl::Program::Binaries{cached.binary});
        prog.build({info_.device}, kBuildOptions);
        build.from_binary = true;
      } catch (const cl::Error&) {
      }
    }
    if (!build.from_binary) {
      prog = cl::Program(context_, source);
      // No scene values in the options (STYLE.md): PoCL's kernel cache then
      // hits for every scene and run.
      try {
        prog.build({info_.device}, kBuildOptions);
      } catch (const cl::Error& e) {
        std::string log;
        try {
          log = prog.getBuildInfo<CL_PROGRAM_BUILD_LOG>(info_.device);
        } catch (const cl::Error&) {
          log = "(no build log)";
        }
        throw RuntimeError("building " + program + ".cl on " + info_.name + ": " + describe(e) + "\n" + log);
      }
      if (cached.binary.empty()) {
        // A driver without program binaries only costs the next device of
        // its model a compile of its own.
        try {
          auto binaries = prog.getInfo<CL_PROGRAM_BINARIES>();
          if (!binaries.empty()) cached.binary = std::move(binaries.front());
        } catch (const cl::Error&) {
        }
      }
    }
    build.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    build_seconds_ += build.seconds;
    program_builds_[program] = build;
    it = programs_.emplace(program, prog).first;
  }
  return cl::Kernel(it->second, name.c_str());
}

namespace {

// A DeviceBuffer's share of its device's count.
class Lease {
 public:
  Lease(std::shared_ptr<std::atomic<size_t>> live, size_t bytes) : live_(std::move(live)), bytes_(bytes) {
    live_->fetch_add(bytes_);
  }
  Lease(const Lease&) = delete;
  Lease& operator=(const Lease&) = delete;
  ~Lease() { live_->fetch_sub(bytes_); }

 private:
  std::shared_ptr<std::atomic<size_t>> live_;
  size_t bytes_;
};

}  // namespace

void check_arg_name(const cl::Kernel& kernel, cl_uint index, const char* name) {
  size_t size = 0;
  cl_int err = clGetKernelArgInfo(kernel(), index, CL_KERNEL_ARG_NAME, 0, nullptr, &size);
  if (err == CL_KERNEL_ARG_INFO_NOT_AVAILABLE) return;
  if (err != CL_SUCCESS) throw cl::Error(err, "clGetKernelArgInfo");
  std::string actual(size, '\0');
  err = clGetKernelArgInfo(kernel(), index, CL_KERNEL_ARG_NAME, size, actual.data(), nullptr);
  if (err != CL_SUCCESS) throw cl::Error(err, "clGetKernelArgInfo");
  actual.resize(std::strlen(actual.c_str()));
  if (actual != name) {
    std::string function = kernel.getInfo<CL_KERNEL_FUNCTION_NAME>();
    function.resize(std::strlen(function.c_str()));
    throw RuntimeError("kernel " + function + ": argument " + std::to_string(index) + " is '" + actual +
                       "' in the kernel but the host binds '" + name + "' there");
  }
}

void Device::set_memory_budget(size_t bytes) { budget_ = bytes ? bytes : size_t(info_.global_memory); }

DeviceBuffer Device::buffer(size_t bytes, const std::string& what, cl_mem_flags flags) {
  if (bytes > info_.max_alloc) {
    throw RuntimeError(what + " needs " + std::to_string(bytes) + " bytes, more than " + info_.name +
                       " allocates at once (CL_DEVICE_MAX_MEM_ALLOC_SIZE = " + std::to_string(info_.max_alloc) + ")");
  }
  if (bytes > memory_free()) {
    throw RuntimeError(what + " (" + std::to_string(bytes) + " bytes) does not fit the device memory budget of " +
                       std::to_string(budget_) + " bytes (--device-memory) on " + info_.name + ", " +
                       std::to_string(memory_in_use()) + " bytes of it in use");
  }
  cl::Buffer b(context_, flags, bytes);
  std::shared_ptr<void> lease = std::make_shared<Lease>(live_, bytes);
  if (fill_ >= 0) queue_.enqueueFillBuffer(b, static_cast<cl_uchar>(fill_), 0, bytes);
  return DeviceBuffer(std::move(b), std::move(lease), what);
}

size_t Device::work_group_size(const cl::Kernel& kernel) const {
  const size_t max = kernel.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(info_.device);
  const size_t multiple = kernel.getWorkGroupInfo<CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE>(info_.device);
  size_t size = std::min<size_t>(preferred_group_, max);
  if (multiple > 0 && size >= multiple) size -= size % multiple;
  return std::max<size_t>(size, 1);
}

size_t Device::launch(cl::Kernel& kernel, size_t items, const char* name) {
  const size_t local = work_group_size(kernel);
  const size_t global = std::max<size_t>(local, (items + local - 1) / local * local);
  std::string label = name ? name : kernel.getInfo<CL_KERNEL_FUNCTION_NAME>();
  if (label.rfind("spm_", 0) == 0) label.erase(0, 4);
  cl::Event event;
  const auto enqueued = std::chrono::steady_clock::now();
  queue_.enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(global), cl::NDRange(local), nullptr, &event);
  launches_.push_back({label, event, global, items, enqueued});
  return launches_.size() - 1;
}

}  // namespace spm
