// radix_sort orders (key, index) pairs exactly as a stable sort by key does,
// and sort_by_key moves records into that order.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "util/radix_sort.h"

namespace {

std::vector<spm::KeyIndex> pairs(const std::vector<uint64_t>& keys) {
  std::vector<spm::KeyIndex> v;
  for (size_t i = 0; i < keys.size(); ++i) v.push_back({keys[i], static_cast<uint32_t>(i)});
  return v;
}

void expect_stable_order(const std::vector<uint64_t>& keys) {
  std::vector<spm::KeyIndex> got = pairs(keys), want = pairs(keys);
  spm::radix_sort(got);
  std::stable_sort(want.begin(), want.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].key, want[i].key) << "position " << i;
    ASSERT_EQ(got[i].index, want[i].index) << "position " << i;
  }
}

TEST(RadixSort, MatchesAStableSort) {
  std::mt19937_64 rng(7);
  // Every digit varying, with duplicates.
  std::vector<uint64_t> keys(20000);
  for (auto& k : keys) k = rng() % 5000 * 0x0001000100010001ull + (rng() & 0xffff000000000000ull);
  expect_stable_order(keys);
  // The photon maps' shape: stream << 32 | event << 16 | photon, shuffled.
  keys.clear();
  for (uint64_t s = 0; s < 300; ++s) {
    for (uint64_t e = 0; e < 5; ++e) {
      for (uint64_t p = 0; p < 20; ++p) keys.push_back(s << 32 | e << 16 | p);
    }
  }
  std::shuffle(keys.begin(), keys.end(), rng);
  expect_stable_order(keys);
  // Only the top digit varies; only the bottom one.
  keys.assign(5000, 0);
  for (auto& k : keys) k = (rng() % 7) << 48;
  expect_stable_order(keys);
  for (auto& k : keys) k = rng() % 3;
  expect_stable_order(keys);
}

TEST(RadixSort, EdgeCases) {
  expect_stable_order({});
  expect_stable_order({42});
  expect_stable_order(std::vector<uint64_t>(100, 9));  // all equal: input order kept
  expect_stable_order({~0ull, 0, ~0ull - 1, 1ull << 63, 1});
}

TEST(RadixSort, SortByKeyMovesRecords) {
  struct Rec {
    uint32_t stream, event;
  };
  std::vector<Rec> recs{{3, 1}, {0, 2}, {3, 0}, {1, 5}, {0, 1}};
  spm::sort_by_key(recs, [](const Rec& r) { return uint64_t(r.stream) << 32 | r.event; });
  const std::vector<std::pair<uint32_t, uint32_t>> want{{0, 1}, {0, 2}, {1, 5}, {3, 0}, {3, 1}};
  ASSERT_EQ(recs.size(), want.size());
  for (size_t i = 0; i < recs.size(); ++i) EXPECT_EQ(std::make_pair(recs[i].stream, recs[i].event), want[i]);
}

}  // namespace
