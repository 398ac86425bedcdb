// The maps' deterministic order (METHOD.md 7): by (stream, event[, photon]),
// whatever order the device appended the records in.
//
// The kernels give every stream's records that order among themselves by
// construction: slots are handed out by a counter that only grows across
// iterations and flushes, a stream has at most one event per iteration, and
// a diffuse event's photon j fills slot record_base + j (spm_interact.cl,
// spm_deposit.cl). So the records are only to be grouped by stream, keeping
// each stream's own order: a counting sort, whose prefix sums over the
// per-stream counts give every record its slot in one pass, instead of a
// sort by the whole key.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "util/errors.h"

namespace spm {

// Stably groups `records` (with a `stream` field) by stream id, for ids in
// [first, first + count).
template <class Record>
void order_by_stream(std::vector<Record>& records, uint32_t first, uint32_t count) {
  std::vector<size_t> slot(size_t(count) + 1, 0);
  for (const Record& r : records) {
    if (r.stream < first || r.stream - first >= count) {
      throw RuntimeError("record of stream " + std::to_string(r.stream) + " outside the batch's streams");
    }
    ++slot[r.stream - first + 1];
  }
  for (size_t s = 1; s < slot.size(); ++s) slot[s] += slot[s - 1];
  std::vector<Record> out(records.size());
  for (const Record& r : records) out[slot[r.stream - first]++] = r;
  records = std::move(out);
}

}  // namespace spm
