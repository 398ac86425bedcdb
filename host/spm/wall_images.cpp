#include "spm/wall_images.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "util/errors.h"

namespace spm {

namespace {

glm::vec3 v3(const float* f) { return glm::vec3(f[0], f[1], f[2]); }

}  // namespace

// The reach grows by a little against the rounding of a pass's volume
// radius (the first pass's, scaled by r_k / r_0 in float).
WallImages::WallImages(const SceneTables& t, float reach) : reach_(reach * 1.001f) {
  for (size_t i = 0; i < t.patches.size(); ++i) {
    const SpmPatch& p = t.patches[i];
    const SpmShape& shape = t.shapes[t.patch_shapes[i]];
    const spm_uint type = t.materials[shape.material].type;
    const bool opaque = type == SPM_MAT_DIFFUSE || type == SPM_MAT_CONDUCTOR || type == SPM_MAT_ROUGH_CONDUCTOR ||
                        type == SPM_MAT_PLASTIC;
    const bool boundary = type == SPM_MAT_NULL && (shape.interior < 0) != (shape.exterior < 0);
    if (!opaque && !boundary) continue;
    Wall w;
    w.boundary = boundary;
    w.centre = v3(p.center);
    w.u = v3(p.u);
    w.v = v3(p.v);
    w.normal = glm::normalize(glm::cross(w.u, w.v));
    w.half_u = p.half_u;
    w.half_v = p.half_v;
    w.patch = static_cast<uint32_t>(i);
    walls_.push_back(w);
  }
  if (walls_.empty()) return;
  // Each wall's box, grown by the reach: where its records can be.
  std::vector<glm::vec3> los, his;
  glm::vec3 lo(INFINITY), hi(-INFINITY);
  for (const Wall& w : walls_) {
    const glm::vec3 half = glm::abs(w.u) * w.half_u + glm::abs(w.v) * w.half_v + glm::vec3(reach_);
    los.push_back(w.centre - half);
    his.push_back(w.centre + half);
    lo = glm::min(lo, los.back());
    hi = glm::max(hi, his.back());
  }
  // About four cells per wall and axis' cube root: a record meets a handful
  // of candidate walls, however many the scene has.
  const int n = std::clamp(int(std::ceil(2.0 * std::cbrt(double(walls_.size())))), 1, 64);
  lo_ = lo;
  dims_ = glm::ivec3(n);
  cell_ = glm::max((hi - lo) / float(n), glm::vec3(1e-6f));
  const size_t cells = size_t(n) * n * n;
  std::vector<std::vector<uint32_t>> lists(cells);
  for (uint32_t k = 0; k < walls_.size(); ++k) {
    const glm::ivec3 a = glm::clamp(glm::ivec3(glm::floor((los[k] - lo_) / cell_)), glm::ivec3(0), dims_ - 1);
    const glm::ivec3 b = glm::clamp(glm::ivec3(glm::floor((his[k] - lo_) / cell_)), glm::ivec3(0), dims_ - 1);
    for (int z = a.z; z <= b.z; ++z)
      for (int y = a.y; y <= b.y; ++y)
        for (int x = a.x; x <= b.x; ++x) lists[(size_t(z) * n + y) * n + x].push_back(k);
  }
  cell_start_.assign(cells + 1, 0);
  for (size_t c = 0; c < cells; ++c) {
    cell_walls_.insert(cell_walls_.end(), lists[c].begin(), lists[c].end());
    cell_start_[c + 1] = static_cast<uint32_t>(cell_walls_.size());
  }
}

bool WallImages::crosses_opaque_wall(size_t cell, glm::vec3 a, glm::vec3 b) const {
  for (uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
    const Wall& o = walls_[cell_walls_[k]];
    if (o.boundary) continue;
    const float sa = glm::dot(a - o.centre, o.normal), sb = glm::dot(b - o.centre, o.normal);
    if ((sa > 0.0f) == (sb > 0.0f) || sa == sb) continue;
    if (o.covers(a + (sa / (sa - sb)) * (b - a) - o.centre)) return true;
  }
  return false;
}

void WallImages::add(std::vector<SpmVolumeRecord>& records, float radius) const {
  if (walls_.empty() || !(radius > 0.0f)) return;
  if (radius > reach_) {
    throw RuntimeError("wall images: radius " + std::to_string(radius) + " beyond the walls' index (" +
                       std::to_string(reach_) + ")");
  }
  const size_t count = records.size();
  for (size_t i = 0; i < count; ++i) {
    const glm::vec3 x = v3(records[i].position);
    const glm::vec3 q = glm::floor((x - lo_) / cell_);
    if (glm::any(glm::lessThan(q, glm::vec3(0.0f))) || glm::any(glm::greaterThanEqual(q, glm::vec3(dims_)))) continue;
    const size_t c = (size_t(q.z) * dims_.y + size_t(q.y)) * dims_.x + size_t(q.x);
    float nearest = INFINITY;
    for (uint32_t k = cell_start_[c]; k < cell_start_[c + 1]; ++k) {
      const Wall& w = walls_[cell_walls_[k]];
      const float s = glm::dot(x - w.centre, w.normal);
      if (!(std::abs(s) < radius) || s == 0.0f) continue;
      if (!w.covers(x - s * w.normal - w.centre)) continue;
      if (w.boundary) {
        // Behind an opaque wall the boundary's other side is the wall's,
        // whose own image fills it.
        if (crosses_opaque_wall(c, x, x - s * w.normal)) continue;
      } else if (std::abs(s) < nearest) {
        nearest = std::abs(s);
        records[i].stream = SPM_RECORD_WALL | w.patch;
      }
      SpmVolumeRecord image = records[i];
      const glm::vec3 p = x - 2.0f * s * w.normal;
      const glm::vec3 d = v3(image.direction);
      const glm::vec3 e = d - 2.0f * glm::dot(d, w.normal) * w.normal;
      for (int a = 0; a < 3; ++a) {
        image.position[a] = p[a];
        image.direction[a] = e[a];
      }
      image.stream = SPM_RECORD_WALL | SPM_RECORD_IMAGE | w.patch;
      records.push_back(image);
    }
  }
}

}  // namespace spm
