#include "scene/bvh.h"

#include <algorithm>
#include <array>
#include <limits>

#include <glm/glm.hpp>

namespace spm {

namespace {

constexpr int kBins = 16;
constexpr unsigned kMaxLeaf = 4;
// SAH costs relative to one primitive test.
constexpr float kTraversalCost = 1.0f;

struct Box {
  glm::vec3 lo{std::numeric_limits<float>::max()};
  glm::vec3 hi{std::numeric_limits<float>::lowest()};
  void grow(const glm::vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void grow(const Box& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  float area() const {
    if (lo.x > hi.x) return 0.0f;
    const glm::vec3 e = hi - lo;
    return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
  }
};

glm::vec3 v3(const float* p) { return {p[0], p[1], p[2]}; }

Box prim_box(const SpmPrim& p) {
  Box b;
  if (p.kind == SPM_PRIM_SPHERE) {
    const glm::vec3 c = v3(p.p0);
    b.grow(c - glm::vec3(p.p1[0]));
    b.grow(c + glm::vec3(p.p1[0]));
  } else {
    b.grow(v3(p.p0));
    b.grow(v3(p.p1));
    b.grow(v3(p.p2));
  }
  return b;
}

struct Builder {
  std::vector<SpmPrim>& prims;
  std::vector<Box> boxes;
  std::vector<glm::vec3> centres;
  std::vector<SpmBvhNode> nodes;

  void set_box(SpmBvhNode& n, const Box& b) {
    for (int k = 0; k < 3; ++k) {
      n.lo[k] = b.lo[k];
      n.hi[k] = b.hi[k];
    }
  }

  void make_leaf(uint32_t index, uint32_t begin, uint32_t end) {
    nodes[index].offset = begin;
    nodes[index].count_axis = (end - begin) << 2;
  }

  void swap_prims(uint32_t a, uint32_t b) {
    std::swap(prims[a], prims[b]);
    std::swap(boxes[a], boxes[b]);
    std::swap(centres[a], centres[b]);
  }

  // Builds the subtree of prims [begin, end) at node `index`.
  void build(uint32_t index, uint32_t begin, uint32_t end) {
    Box bounds, centre_bounds;
    for (uint32_t i = begin; i < end; ++i) {
      bounds.grow(boxes[i]);
      centre_bounds.grow(centres[i]);
    }
    set_box(nodes[index], bounds);
    const uint32_t count = end - begin;
    if (count <= kMaxLeaf) return make_leaf(index, begin, end);

    // Binned SAH (Wald 2007): the best of kBins-1 planes per axis.
    float best_cost = std::numeric_limits<float>::max();
    int best_axis = -1, best_split = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const float lo = centre_bounds.lo[axis], hi = centre_bounds.hi[axis];
      if (hi <= lo) continue;
      std::array<Box, kBins> bin_box;
      std::array<uint32_t, kBins> bin_count{};
      const float scale = kBins / (hi - lo);
      for (uint32_t i = begin; i < end; ++i) {
        const int b = std::min(kBins - 1, static_cast<int>((centres[i][axis] - lo) * scale));
        bin_box[b].grow(boxes[i]);
        ++bin_count[b];
      }
      std::array<float, kBins> right_area{};
      std::array<uint32_t, kBins> right_count{};
      Box acc;
      uint32_t n = 0;
      for (int b = kBins - 1; b > 0; --b) {
        acc.grow(bin_box[b]);
        n += bin_count[b];
        right_area[b] = acc.area();
        right_count[b] = n;
      }
      acc = Box();
      n = 0;
      for (int b = 0; b < kBins - 1; ++b) {
        acc.grow(bin_box[b]);
        n += bin_count[b];
        const float cost = acc.area() * n + right_area[b + 1] * right_count[b + 1];
        if (n > 0 && right_count[b + 1] > 0 && cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_split = b;
        }
      }
    }
    const float leaf_cost = bounds.area() * count;
    const float split_cost = kTraversalCost * bounds.area() + best_cost;
    uint32_t mid = begin;
    if (best_axis >= 0 && (split_cost < leaf_cost || count > 4 * kMaxLeaf)) {
      const float lo = centre_bounds.lo[best_axis];
      const float scale = kBins / (centre_bounds.hi[best_axis] - lo);
      for (uint32_t i = begin; i < end; ++i) {
        const int b = std::min(kBins - 1, static_cast<int>((centres[i][best_axis] - lo) * scale));
        if (b <= best_split) swap_prims(i, mid++);
      }
    } else if (count > kMaxLeaf && best_axis < 0) {
      // All centres coincide: split in the middle so leaves stay small.
      mid = begin + count / 2;
      best_axis = 0;
    } else {
      return make_leaf(index, begin, end);
    }
    const uint32_t left = static_cast<uint32_t>(nodes.size());
    nodes.emplace_back();
    build(left, begin, mid);
    const uint32_t right = static_cast<uint32_t>(nodes.size());
    nodes.emplace_back();
    build(right, mid, end);
    nodes[index].offset = right;
    nodes[index].count_axis = static_cast<uint32_t>(best_axis);
  }
};

}  // namespace

Bvh build_bvh(std::vector<SpmPrim>& prims) {
  Builder b{prims, {}, {}, {}};
  b.boxes.reserve(prims.size());
  for (const auto& p : prims) {
    b.boxes.push_back(prim_box(p));
    b.centres.push_back(0.5f * (b.boxes.back().lo + b.boxes.back().hi));
  }
  b.nodes.reserve(2 * prims.size() + 1);
  b.nodes.emplace_back();
  if (prims.empty()) {
    b.nodes[0] = SpmBvhNode{};
    return {b.nodes};
  }
  b.build(0, 0, static_cast<uint32_t>(prims.size()));
  return {std::move(b.nodes)};
}

}  // namespace spm
