// Several processes, on one machine or many: `mpirun -np K spm render ...`
// gives rank R the passes R, R + K, R + 2K, ... (each rank on its own
// devices); rank 0 sums every pass image in pass order (OrderedSum), so the
// image is bit for bit the one process's with the same passes, and writes the
// image and the profile. Without MPI at build time (SPM_HAVE_MPI undefined),
// or when the process was not started by an MPI launcher, there is one rank
// and MPI is never initialised.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "device/device.h"
#include "film/image_io.h"
#include "profile/profile.h"
#include "render/render.h"
#include "scene/scene.h"

namespace spm {

class Cluster {
 public:
  // The first call initialises MPI (MPI_Init_thread, MPI_THREAD_FUNNELED: only
  // the thread that makes this call may communicate) when the process was
  // started by mpirun or another MPI launcher; later calls return the same
  // object and ignore their arguments. MPI is finalised at exit.
  static Cluster& get(int* argc = nullptr, char*** argv = nullptr);

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool root() const { return rank_ == 0; }
  const std::string& host() const { return host_; }
  // "spm: " alone, or "spm: rank R: " with several ranks: the start of a message.
  std::string prefix() const;

  // A failure on this rank: with several ranks the whole job ends with `code`
  // (MPI_Abort), so that no rank waits for this one forever; otherwise returns
  // `code`. Print the error first.
  int fail(int code);
  // The end of a command every rank took part in: rank 0 calls it after its
  // output is written and releases the others, which wait for it here (if
  // rank 0 fails first, its fail() ends them). Returns `code`.
  int finish(int code);

  Cluster(const Cluster&) = delete;
  Cluster& operator=(const Cluster&) = delete;
  ~Cluster();

 private:
  Cluster(int* argc, char*** argv);
  int rank_ = 0;
  int size_ = 1;
  bool mpi_ = false;  // MPI_Init_thread was called
  std::string host_;
};

// render() across the cluster's ranks. One rank: exactly render(). K ranks:
// each renders PassSlice{rank, K} on its `devices`; rank 0 returns the average
// of the passes in pass order (with a time budget, the passes before the first
// one missing on any rank), `stats` merged over ranks (stage times, samples and
// kernel build times summed, `seconds` the slowest rank's, one device entry
// per rank and device named "rank R device D (name)"), and `progress` counts
// every rank's passes. Other ranks return an empty Image and their own stats.
// `rank_profiles` (rank 0, several ranks only): one entry per rank, in rank
// order: a whole --profile-json document of that rank alone (its
// Profiler::json() with "scene", "resolution", "passes" and "seconds" of its
// own passes, its devices' passes and busy seconds) plus "rank" and
// "hostname". Communication happens on the calling thread only. A failure on
// any rank throws there; the caller must then call Cluster::fail so that the
// other ranks end too.
Image render_cluster(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
                     RenderStats* stats = nullptr, const Progress& progress = {}, Profiler* profiler = nullptr,
                     nlohmann::json* rank_profiles = nullptr);

}  // namespace spm
