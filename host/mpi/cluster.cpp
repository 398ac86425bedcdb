#include "mpi/cluster.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <iostream>
#include <mutex>
#include <thread>
#include <utility>

#include "util/errors.h"

#ifdef SPM_HAVE_MPI
#include <mpi.h>
#endif

namespace spm {

namespace {

std::string hostname() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "localhost";
  return name;
}

}  // namespace

Cluster& Cluster::get(int* argc, char*** argv) {
  static Cluster cluster(argc, argv);
  return cluster;
}

std::string Cluster::prefix() const { return size_ > 1 ? "spm: rank " + std::to_string(rank_) + ": " : "spm: "; }

#ifndef SPM_HAVE_MPI

// Built without MPI: one rank.
Cluster::Cluster(int*, char***) : host_(hostname()) {}
Cluster::~Cluster() = default;
int Cluster::fail(int code) { return code; }
int Cluster::finish(int code) { return code; }

Image render_cluster(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
                     RenderStats* stats, const Progress& progress, Profiler* profiler, nlohmann::json*) {
  return render(scene, settings, devices, stats, progress, profiler);
}

#else  // SPM_HAVE_MPI

// A rank's stats as rank 0 receives them (kTagDone), field by field.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(DeviceStats, name, passes, busy_seconds)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(RenderStats, passes, interrupted, seconds, bvh_seconds, build_seconds,
                                   pilot_seconds, propagate_seconds, grid_seconds, gather_seconds, camera_samples, sphere_tests,
                                   devices)

namespace {

using nlohmann::json;

// Messages to rank 0: kTagPass, one per pass ([int pass][pixels x 3 floats],
// as floats); then kTagDone, the rank's stats and profile as JSON text. From
// rank 0 at the end: kTagFinish, the exit code. MPI keeps the order of one
// sender's messages, so a rank's kTagDone comes after all its passes.
constexpr int kTagPass = 1;
constexpr int kTagDone = 2;
constexpr int kTagFinish = 3;

// Open MPI, MPICH (hydra), PMI-1/2 and PMIx launchers (Slurm) set one of these.
bool launched_by_mpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE", "MPI_LOCALNRANKS"}) {
    if (std::getenv(name)) return true;
  }
  return false;
}

// Waits for `request` without spinning on a core (MPI implementations poll):
// for waits that may last a long time, while other ranks still render.
void wait_gently(MPI_Request& request) {
  auto pause = std::chrono::microseconds(50);
  for (;;) {
    int done = 0;
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(pause);
    pause = std::min<std::chrono::microseconds>(pause * 2, std::chrono::milliseconds(10));
  }
}

// What every rank must agree on for its passes to belong to one image.
json settings_json(const RenderSettings& s) {
  return {{"width", s.width}, {"height", s.height}, {"spp", s.spp},
          {"passes", s.passes}, {"seed", s.seed}};
}

// A rank's entry of rank_profiles: a whole profile (the keys main.cpp adds
// for --profile-json included) plus the rank and its host.
json rank_profile(const Cluster& c, const Scene& scene, const RenderSettings& s, const RenderStats& st,
                  const std::vector<Device*>& devices, Profiler* profiler) {
  if (profiler) add_build_values(*profiler, st, devices);
  json j = profiler ? profiler->json() : json::object();
  j["rank"] = c.rank();
  j["hostname"] = c.host();
  j["scene"] = scene.path;
  j["resolution"] = {s.width, s.height};
  j["passes"] = st.passes;
  j["seconds"] = st.seconds;
  for (size_t d = 0; d < st.devices.size(); ++d) {
    j["devices"][d]["index"] = d;
    j["devices"][d]["name"] = st.devices[d].name;
    j["devices"][d]["passes"] = st.devices[d].passes;
    j["devices"][d]["busy_seconds"] = st.devices[d].busy_seconds;
  }
  return j;
}

// This rank's passes, rendered on a thread of their own while the calling
// thread communicates; finished pass images wait in a queue.
class LocalRender {
 public:
  LocalRender(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
              PassSlice slice, Profiler* profiler)
      : outer_stop_(settings.stop) {
    RenderSettings s = settings;
    s.stop = &stop_;
    thread_ = std::thread([this, &scene, s, &devices, slice, profiler] {
      try {
        stats_ = render_passes(
            scene, s, devices, slice,
            [this](int pass, PassImage&& image) {
              {
                std::lock_guard<std::mutex> lock(mutex_);
                queue_.emplace_back(pass, std::move(image.rgb));
              }
              ready_.notify_one();
            },
            profiler);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        error_ = std::current_exception();
      }
      {
        std::lock_guard<std::mutex> lock(mutex_);
        done_ = true;
      }
      ready_.notify_one();
    });
  }

  // Unwinding (an error on the communicating thread): the passes in flight
  // finish, no new one starts.
  ~LocalRender() {
    if (thread_.joinable()) {
      stop_ = true;
      thread_.join();
    }
  }

  // The pass images finished so far (waiting up to `timeout` for one); sets
  // `finished` once the last one is taken and the render has ended.
  std::vector<std::pair<int, std::vector<float>>> take(std::chrono::microseconds timeout, bool& finished) {
    if (outer_stop_ && outer_stop_->load()) stop_ = true;  // SIGINT
    std::unique_lock<std::mutex> lock(mutex_);
    if (timeout.count() > 0) ready_.wait_for(lock, timeout, [this] { return !queue_.empty() || done_; });
    std::vector<std::pair<int, std::vector<float>>> out(std::make_move_iterator(queue_.begin()),
                                                        std::make_move_iterator(queue_.end()));
    queue_.clear();
    finished = done_;
    return out;
  }

  // After take() reported `finished`: this rank's stats, or its error rethrown.
  RenderStats join() {
    thread_.join();
    if (error_) std::rethrow_exception(error_);
    stats_.interrupted = outer_stop_ && outer_stop_->load();
    return stats_;
  }

 private:
  const std::atomic<bool>* outer_stop_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::pair<int, std::vector<float>>> queue_;
  bool done_ = false;
  std::exception_ptr error_;
  RenderStats stats_;
  std::thread thread_;  // last: started once everything above exists
};

std::string rank_name(int rank, size_t device, const std::string& name) {
  return "rank " + std::to_string(rank) + " device " + std::to_string(device) + " (" + name + ")";
}

}  // namespace

Cluster::Cluster(int* argc, char*** argv) : host_(hostname()) {
  if (!launched_by_mpi()) return;  // no singleton MPI start-up (half a second) for a plain run
  int provided = 0;
  MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
  mpi_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  if (provided < MPI_THREAD_FUNNELED) {
    std::fprintf(stderr, "spm: rank %d: the MPI library does not support MPI_THREAD_FUNNELED\n", rank_);
    MPI_Abort(MPI_COMM_WORLD, kExitRuntime);
  }
  char name[MPI_MAX_PROCESSOR_NAME] = {};
  int length = 0;
  if (MPI_Get_processor_name(name, &length) == MPI_SUCCESS && length > 0) host_.assign(name, size_t(length));
}

Cluster::~Cluster() {
  if (!mpi_) return;
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (!finalized) MPI_Finalize();
}

int Cluster::fail(int code) {
  if (mpi_ && size_ > 1) {
    std::cout.flush();
    std::cerr.flush();
    std::fflush(nullptr);
    MPI_Abort(MPI_COMM_WORLD, code);
  }
  return code;
}

int Cluster::finish(int code) {
  if (!mpi_ || size_ == 1) return code;
  if (root()) {
    std::vector<MPI_Request> requests(size_t(size_) - 1);
    for (int r = 1; r < size_; ++r) MPI_Isend(&code, 1, MPI_INT, r, kTagFinish, MPI_COMM_WORLD, &requests[r - 1]);
    for (auto& request : requests) wait_gently(request);
    return code;
  }
  int received = 0;
  MPI_Request request;
  MPI_Irecv(&received, 1, MPI_INT, 0, kTagFinish, MPI_COMM_WORLD, &request);
  wait_gently(request);
  return received;
}

Image render_cluster(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
                     RenderStats* stats, const Progress& progress, Profiler* profiler, nlohmann::json* rank_profiles) {
  Cluster& c = Cluster::get();
  if (c.size() == 1) return render(scene, settings, devices, stats, progress, profiler);

  // The error estimate reads every pass's probe, which the ranks do not
  // send: with several ranks the render has none (a gap: METHOD.md 15).
  if (scene.integrator.target_error > 0.0f) {
    throw InputError("--target-error", "a target error needs one process; use several devices instead of ranks");
  }
  RenderSettings unprobed = settings;
  unprobed.error_probe = false;
  const RenderSettings s = resolve_settings(scene, unprobed);
  const bool timed = s.passes == 0;  // a time budget (resolve_settings)
  const size_t values = size_t(s.width) * s.height * 3;
  const int ranks = c.size();
  LocalRender local(scene, unprobed, devices, PassSlice{c.rank(), ranks}, profiler);

  if (!c.root()) {
    // Each pass image to rank 0 as soon as it is done; then stats and profile.
    std::vector<float> message(values + 1);
    for (bool finished = false; !finished;) {
      for (auto& [pass, rgb] : local.take(std::chrono::milliseconds(10), finished)) {
        if (rgb.size() != values) throw RuntimeError("a pass image of the wrong size");
        std::memcpy(message.data(), &pass, sizeof pass);
        std::copy(rgb.begin(), rgb.end(), message.begin() + 1);
        MPI_Send(message.data(), int(message.size()), MPI_FLOAT, 0, kTagPass, MPI_COMM_WORLD);
      }
    }
    RenderStats st = local.join();
    const std::string done = json{{"settings", settings_json(s)},
                                  {"stats", st},
                                  {"profile", rank_profile(c, scene, s, st, devices, profiler)}}
                                 .dump();
    MPI_Send(done.data(), int(done.size()), MPI_CHAR, 0, kTagDone, MPI_COMM_WORLD);
    for (size_t d = 0; d < st.devices.size(); ++d) st.devices[d].name = rank_name(c.rank(), d, st.devices[d].name);
    if (stats) *stats = st;
    return Image{};
  }

  // Rank 0: its own passes and every other rank's into one OrderedSum.
  OrderedSum sum(values, false);
  std::vector<RenderStats> remote(static_cast<size_t>(ranks));
  std::vector<json> profiles(static_cast<size_t>(ranks));
  int remote_done = 0;
  const auto add = [&](int pass, std::vector<float>&& rgb) {
    const int before = sum.summed();
    sum.add(pass, PassImage{std::move(rgb), {}, 0.0f});
    if (progress && sum.summed() > before) progress(sum.summed(), timed ? 0 : s.passes, sum.estimate());
  };
  std::vector<float> message;
  for (bool local_done = false; !local_done || remote_done < ranks - 1;) {
    bool busy = false;
    int waiting = 0;
    MPI_Status status;
    while (MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &waiting, &status) == MPI_SUCCESS && waiting) {
      busy = true;
      const int from = status.MPI_SOURCE;
      if (status.MPI_TAG == kTagPass) {
        int count = 0;
        MPI_Get_count(&status, MPI_FLOAT, &count);
        if (count < 0 || size_t(count) != values + 1) {
          throw InputError("rank " + std::to_string(from), "sent a pass image of " + std::to_string(count - 1) +
                                                               " values, rank 0 renders " + std::to_string(values) +
                                                               " (" + std::to_string(s.width) + "x" +
                                                               std::to_string(s.height) + " RGB)");
        }
        message.resize(values + 1);
        MPI_Recv(message.data(), count, MPI_FLOAT, from, kTagPass, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        int pass = 0;
        std::memcpy(&pass, message.data(), sizeof pass);
        if (pass < 0 || pass % ranks != from || (!timed && pass >= s.passes)) {
          throw RuntimeError("rank " + std::to_string(from) + " sent pass " + std::to_string(pass) +
                             ", which is not one of its passes");
        }
        add(pass, std::vector<float>(message.begin() + 1, message.end()));
      } else if (status.MPI_TAG == kTagDone) {
        int count = 0;
        MPI_Get_count(&status, MPI_CHAR, &count);
        std::string text(size_t(std::max(count, 0)), '\0');
        MPI_Recv(text.data(), count, MPI_CHAR, from, kTagDone, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        const json done = json::parse(text);
        if (done.at("settings") != settings_json(s)) {
          throw InputError("rank " + std::to_string(from),
                           "renders with other settings than rank 0: " + done.at("settings").dump() + " instead of " +
                               settings_json(s).dump() + " (every rank needs the same scene and options)");
        }
        remote[size_t(from)] = done.at("stats").get<RenderStats>();
        profiles[size_t(from)] = done.at("profile");
        ++remote_done;
      } else {
        throw RuntimeError("rank " + std::to_string(from) + " sent an unexpected message (tag " +
                           std::to_string(status.MPI_TAG) + ")");
      }
    }
    if (!local_done) {
      // Without anything from the other ranks, wait a little for a local pass.
      auto passes = local.take(busy ? std::chrono::microseconds(0) : std::chrono::microseconds(1000), local_done);
      for (auto& [pass, rgb] : passes) add(pass, std::move(rgb));
    } else if (!busy) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  RenderStats total = local.join();
  profiles[0] = rank_profile(c, scene, s, total, devices, profiler);
  for (size_t d = 0; d < total.devices.size(); ++d) total.devices[d].name = rank_name(0, d, total.devices[d].name);
  for (int r = 1; r < ranks; ++r) {
    const RenderStats& st = remote[size_t(r)];
    total.interrupted = total.interrupted || st.interrupted;
    total.seconds = std::max(total.seconds, st.seconds);
    total.bvh_seconds = std::max(total.bvh_seconds, st.bvh_seconds);
    total.build_seconds += st.build_seconds;
    total.pilot_seconds = std::max(total.pilot_seconds, st.pilot_seconds);
    total.propagate_seconds += st.propagate_seconds;
    total.grid_seconds += st.grid_seconds;
    total.gather_seconds += st.gather_seconds;
    total.camera_samples += st.camera_samples;
    total.sphere_tests += st.sphere_tests;
    for (size_t d = 0; d < st.devices.size(); ++d) {
      total.devices.push_back({rank_name(r, d, st.devices[d].name), st.devices[d].passes, st.devices[d].busy_seconds});
    }
  }
  // With a time budget, only the passes before the first missing one count.
  total.passes = sum.summed();
  if (stats) *stats = total;
  if (rank_profiles) *rank_profiles = json(profiles);
  return sum.average(s.width, s.height);
}

#endif  // SPM_HAVE_MPI

}  // namespace spm
