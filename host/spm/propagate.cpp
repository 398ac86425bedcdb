#include "spm/propagate.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

#include "spm/record_order.h"
#include "util/errors.h"

namespace spm {

namespace {

// Device memory of one stream slot: its state, three queue entries (live,
// next live, respawn), an entry in the deposit and the absorb list for each
// associated photon, and room for one iteration's worth of surface records
// and eight volume records (and eight beams when the gather reads them), so
// that flushes stay rare.
size_t bytes_per_stream(uint32_t associated, bool beams) {
  return StreamState::bytes_per_slot() + 3 * sizeof(cl_uint) +
         associated * (sizeof(SpmSurfaceRecord) + 2 * sizeof(cl_uint)) + 8 * sizeof(SpmVolumeRecord) +
         (beams ? 8 * sizeof(SpmBeam) : 0);
}

// A batch takes `memory_budget` bytes when set, else half the device memory
// still free, at most 1 GiB.
uint32_t batch_size(const Device& device, const StreamSettings& s) {
  const DeviceInfo& info = device.info();
  const size_t budget =
      s.memory_budget ? s.memory_budget : std::min<size_t>(device.memory_free() / 2, size_t(1) << 30);
  size_t n = budget / bytes_per_stream(s.associated, s.beams);
  // The largest single buffer, the surface records, must fit one allocation.
  n = std::min<size_t>(n, info.max_alloc / (s.associated * sizeof(SpmSurfaceRecord)));
  // Per-photon kernels index (stream, photon) with 32-bit global ids.
  n = std::min<size_t>(n, (size_t(1) << 31) / s.associated);
  n = std::min<size_t>(n, s.streams);
  if (n == 0) {
    throw RuntimeError("one stream of " + std::to_string(s.associated) + " associated photons (" +
                       std::to_string(bytes_per_stream(s.associated, s.beams)) + " bytes) does not fit the " +
                       std::to_string(budget) + " bytes left for stream batches of the device memory budget of " +
                       std::to_string(device.memory_budget()) + " bytes (--device-memory)");
  }
  return static_cast<uint32_t>(n);
}

}  // namespace

StreamPropagator::StreamPropagator(Device& device, const GpuScene& scene, const StreamSettings& settings)
    : device_(device), scene_(scene), settings_(settings) {
  if (settings_.streams == 0 || settings_.associated == 0) throw InputError("", "streams and associated must be >= 1");
  if (settings_.associated > 65535) throw InputError("", "associated photons per stream must be at most 65535");
  capacity_ = batch_size(device, settings_);
  volume_capacity_ = 8 * capacity_;
  surface_capacity_ = capacity_ * settings_.associated;
  beam_capacity_ = settings_.beams ? 8 * capacity_ : 0;
  state_ = StreamState(device, capacity_);
  live_ = device.buffer(sizeof(cl_uint) * capacity_, "the live queue");
  live_next_ = device.buffer(sizeof(cl_uint) * capacity_, "the next live queue");
  respawn_queue_ = device.buffer(sizeof(cl_uint) * capacity_, "the respawn queue");
  deposit_list_ = device.buffer(sizeof(cl_uint) * surface_capacity_, "the deposit list");
  absorb_list_ = device.buffer(sizeof(cl_uint) * surface_capacity_, "the absorb list");
  counts_ = device.buffer(sizeof(cl_uint) * SPM_COUNTERS, "the stream counters");
  volume_ = device.buffer(sizeof(SpmVolumeRecord) * volume_capacity_, "the volume map buffer");
  surface_ = device.buffer(sizeof(SpmSurfaceRecord) * surface_capacity_, "the surface map buffer");
  // Without beams march still takes a buffer argument: one unused entry.
  beams_ = device.buffer(sizeof(SpmBeam) * std::max<cl_uint>(1, beam_capacity_), "the beam buffer");
  emit_ = device.kernel("spm_emit", "spm_emit");
  march_ = device.kernel("spm_march", "spm_march");
  interact_ = device.kernel("spm_interact", "spm_interact");
  deposit_ = device.kernel("spm_deposit", "spm_deposit");
  absorb_ = device.kernel("spm_absorb", "spm_absorb");
  respawn_ = device.kernel("spm_respawn", "spm_respawn");
  counters_.fill(0);
  device_.queue().enqueueWriteBuffer(counts_, CL_TRUE, 0, sizeof(cl_uint) * SPM_COUNTERS, counters_.data());
}

size_t StreamPropagator::bytes() const {
  return size_t(capacity_) * bytes_per_stream(settings_.associated, settings_.beams) + sizeof(cl_uint) * SPM_COUNTERS;
}

SpmStreamParams StreamPropagator::params() const {
  const StreamSettings& s = settings_;
  SpmStreamParams p{};
  p.seed = s.seed;
  p.pass = s.pass;
  p.pass_streams = s.streams;
  p.associated = s.associated;
  p.stream_width = s.stream_width;
  p.march_step = s.march_step;
  p.max_bounces = s.max_bounces;
  p.max_depth = s.max_depth;
  p.rr_depth = s.rr_depth;
  p.volume_capacity = volume_capacity_;
  p.surface_capacity = surface_capacity_;
  p.beam_capacity = s.beams ? beam_capacity_ : 0u;
  p.beam_streams = std::min(s.beam_streams, s.streams);
  return p;
}

void StreamPropagator::emit(uint32_t first, uint32_t count) {
  if (count == 0 || count > capacity_) throw RuntimeError("emit: batch of " + std::to_string(count) + " streams");
  // Every emitted stream starts in the respawn queue (spm_emit.cl).
  std::array<cl_uint, SPM_COUNT_QUEUES> queues{};
  queues[SPM_COUNT_RESPAWN] = count;
  device_.queue().enqueueWriteBuffer(counts_, CL_TRUE, 0, sizeof(queues), queues.data());
  const SpmStreamParams p = params();
  set_args(emit_, scene_, arg("params", p), arg("respawn_queue", respawn_queue_), arg("count", cl_uint(count)),
           arg("first_stream", cl_uint(first)), state_);
  device_.launch(emit_, count);
  set_args(respawn_, arg("params", p), arg("respawn_queue", respawn_queue_), arg("live_next", live_next_),
           arg("counts", counts_), state_);
  device_.launch(respawn_, count);
  live_bound_ = count;
}

uint32_t StreamPropagator::step() {
  if (live_bound_ == 0) return 0;
  const SpmStreamParams p = params();
  // The loop of METHOD.md 3. Last iteration's next live queue is this one's
  // live queue; the other queues start empty. Interact appends at most one
  // volume record and n <= N_a surface records per stream; make_room made
  // room for them.
  std::swap(live_, live_next_);
  cl::CommandQueue& queue = device_.queue();
  queue.enqueueCopyBuffer(counts_, counts_, sizeof(cl_uint) * SPM_COUNT_LIVE_NEXT, sizeof(cl_uint) * SPM_COUNT_LIVE,
                          sizeof(cl_uint));
  queue.enqueueFillBuffer(counts_, cl_uint(0), sizeof(cl_uint) * SPM_COUNT_LIVE_NEXT,
                          sizeof(cl_uint) * (SPM_COUNT_QUEUES - SPM_COUNT_LIVE_NEXT));
  const cl_uint surface_first = counters_[SPM_COUNT_SURFACE];
  set_args(march_, scene_, arg("params", p), arg("live", live_), arg("counts", counts_), arg("beams", beams_), state_);
  const size_t march = device_.launch(march_, live_bound_);
  set_args(interact_, scene_, arg("params", p), arg("live", live_), arg("counts", counts_),
           arg("surface_first", surface_first), arg("volume", volume_), arg("deposit_list", deposit_list_),
           arg("absorb_list", absorb_list_), arg("live_next", live_next_), state_);
  const size_t interact = device_.launch(interact_, live_bound_);
  // The iteration's one read-back: the queue sizes size the launches below.
  read_counters();
  const cl_uint errors = counters_[SPM_COUNT_ERRORS];
  if (errors & SPM_ERROR_NONFINITE) {
    throw RuntimeError("stream propagation, pass " + std::to_string(settings_.pass) +
                       ": a stream's flux became NaN or infinite");
  }
  if (errors != 0) {
    throw RuntimeError("stream map overflow (error bits " + std::to_string(errors) +
                       "): the host's capacity check failed");
  }
  const cl_uint live = counters_[SPM_COUNT_LIVE];
  live_log_.push_back(live);
  device_.set_items(march, live);
  device_.set_items(interact, live);
  set_args(deposit_, arg("params", p), arg("deposit_list", deposit_list_), arg("counts", counts_),
           arg("surface_first", surface_first), arg("surface", surface_), arg("absorb_list", absorb_list_), arg("patches", scene_.patches()), state_);
  device_.launch(deposit_, counters_[SPM_COUNT_SURFACE] - surface_first);
  set_args(absorb_, arg("params", p), arg("absorb_list", absorb_list_), arg("respawn_queue", respawn_queue_),
           arg("counts", counts_), state_);
  device_.launch(absorb_, counters_[SPM_COUNT_ABSORB]);
  set_args(respawn_, arg("params", p), arg("respawn_queue", respawn_queue_), arg("live_next", live_next_),
           arg("counts", counts_), state_);
  device_.launch(respawn_, counters_[SPM_COUNT_ABSORBING]);
  // Specular and null events went to the next live queue already; respawn
  // adds at most the streams absorb had.
  live_bound_ = counters_[SPM_COUNT_LIVE_NEXT] + counters_[SPM_COUNT_ABSORBING];
  return live_bound_;
}

void StreamPropagator::make_room(PhotonMaps& maps) {
  const size_t volume = size_t(counters_[SPM_COUNT_VOLUME]) + live_bound_;
  const size_t surface = size_t(counters_[SPM_COUNT_SURFACE]) + size_t(live_bound_) * settings_.associated;
  const size_t beams = size_t(counters_[SPM_COUNT_BEAMS]) + live_bound_;
  if (volume > volume_capacity_ || surface > surface_capacity_ || (settings_.beams && beams > beam_capacity_)) {
    flush(maps);
    ++maps.stats.flushes;
  }
}

void StreamPropagator::read_counters() {
  device_.queue().enqueueReadBuffer(counts_, CL_TRUE, 0, sizeof(cl_uint) * SPM_COUNTERS, counters_.data());
}


void StreamPropagator::flush(PhotonMaps& maps) {
  read_counters();
  device_.download_append(volume_, counters_[SPM_COUNT_VOLUME], maps.volume);
  device_.download_append(surface_, counters_[SPM_COUNT_SURFACE], maps.surface);
  if (settings_.beams) device_.download_append(beams_, counters_[SPM_COUNT_BEAMS], maps.beams);
  for (int k = SPM_COUNT_QUEUES; k < SPM_COUNTERS; ++k) {
    maps.stats.counters[k] += counters_[k];
    counters_[k] = 0;
  }
  maps.stats.live.insert(maps.stats.live.end(), live_log_.begin(), live_log_.end());
  live_log_.clear();
  // The queues' sizes stay: a flush may come between two iterations.
  device_.queue().enqueueWriteBuffer(counts_, CL_TRUE, sizeof(cl_uint) * SPM_COUNT_QUEUES,
                                     sizeof(cl_uint) * (SPM_COUNTERS - SPM_COUNT_QUEUES),
                                     counters_.data() + SPM_COUNT_QUEUES);
}

void StreamPropagator::run_batch(uint32_t first, uint32_t count, PhotonMaps& maps) {
  emit(first, count);
  maps.stats.counters[SPM_COUNT_STREAMS] += count;
  ++maps.stats.batches;
  while (live_bound_ > 0) {
    make_room(maps);
    step();
  }
  flush(maps);
}

PhotonMaps StreamPropagator::propagate(uint32_t pass, float width) { return propagate(pass, width, 0, settings_.streams); }

PhotonMaps StreamPropagator::propagate(uint32_t pass, float width, uint32_t begin, uint32_t streams) {
  settings_.pass = pass;
  settings_.stream_width = width;
  PhotonMaps maps;
  maps.stats.batch_size = capacity_;
  const uint32_t end = std::min(settings_.streams, begin + streams);
  for (uint32_t first = begin; first < end; first += capacity_) run_batch(first, std::min(capacity_, end - first), maps);
  // Appends raced on the device; (stream, event[, photon]) is a total order
  // independent of it, so the maps and every sum over them are deterministic.
  order_by_stream(maps.volume, begin, end - begin);
  order_by_stream(maps.surface, begin, end - begin);
  order_by_stream(maps.beams, begin, end - begin);
  return maps;
}

void StreamPropagator::set_settings(const StreamSettings& s) {
  if (s.associated != settings_.associated || s.beams != settings_.beams || s.streams > settings_.streams) {
    throw std::logic_error("StreamPropagator::set_settings: the buffers were sized for other streams");
  }
  const size_t budget = settings_.memory_budget;
  settings_ = s;
  settings_.memory_budget = budget;
}

PhotonMaps StreamPropagator::propagate_leaders(uint32_t first, uint32_t count) {
  const StreamSettings passes = settings_;
  settings_.associated = 1;
  settings_.beams = false;
  PhotonMaps maps;
  try {
    maps = propagate(0, 0.0f, first, count);
  } catch (...) {
    settings_ = passes;
    throw;
  }
  settings_ = passes;
  return maps;
}

PhotonMaps propagate_streams(Device& device, const GpuScene& scene, const StreamSettings& settings) {
  return StreamPropagator(device, scene, settings).propagate(settings.pass, settings.stream_width);
}

}  // namespace spm
