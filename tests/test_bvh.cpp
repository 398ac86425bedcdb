// The BVH kernel finds the same closest hits as a brute-force loop over all
// primitives on the host.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "scene/bvh.h"
#include "scene/gpu_scene.h"
#include "test_support.h"

namespace {

using glm::vec3;

vec3 v3(const float* p) { return {p[0], p[1], p[2]}; }

struct RefHit {
  float t = INFINITY;
  int prim = -1;
  float edge_margin = 1.0f;  // smallest barycentric of the hit: near 0 = grazing an edge
};

// Plain double-precision reference, independent of the kernel's code.
RefHit brute_force(const std::vector<SpmPrim>& prims, const vec3& o, const vec3& d, float tmax) {
  RefHit best;
  for (size_t i = 0; i < prims.size(); ++i) {
    const SpmPrim& p = prims[i];
    if (p.kind == SPM_PRIM_SPHERE) {
      const glm::dvec3 f = glm::dvec3(o) - glm::dvec3(v3(p.p0));
      const double b = glm::dot(f, glm::dvec3(d)), c = glm::dot(f, f) - double(p.p1[0]) * p.p1[0];
      const double disc = b * b - c;
      if (disc < 0) continue;
      const double s = std::sqrt(disc);
      const double t = -b - s > 0 ? -b - s : -b + s;
      if (t > 0 && t < tmax && t < best.t) best = {float(t), int(i), float(std::abs(disc) / (s + 1e-30))};
      continue;
    }
    const glm::dvec3 a(v3(p.p0)), b(v3(p.p1)), c(v3(p.p2));
    const glm::dvec3 e1 = b - a, e2 = c - a, dd(d);
    const glm::dvec3 pv = glm::cross(dd, e2);
    const double det = glm::dot(e1, pv);
    if (det == 0) continue;
    const glm::dvec3 s = glm::dvec3(o) - a;
    const double u = glm::dot(s, pv) / det;
    const glm::dvec3 q = glm::cross(s, e1);
    const double v = glm::dot(dd, q) / det;
    const double t = glm::dot(e2, q) / det;
    if (u < 0 || v < 0 || u + v > 1 || !(t > 0 && t < tmax) || t >= best.t) continue;
    best = {float(t), int(i), float(std::min({u, v, 1 - u - v}))};
  }
  return best;
}

std::vector<SpmPrim> random_scene(std::mt19937& rng, int triangles, int spheres) {
  std::uniform_real_distribution<float> pos(-50.0f, 50.0f), small(-4.0f, 4.0f), radius(0.5f, 5.0f);
  std::vector<SpmPrim> prims;
  for (int i = 0; i < triangles; ++i) {
    SpmPrim p{};
    for (int k = 0; k < 3; ++k) {
      const float c = pos(rng);
      p.p0[k] = c + small(rng);
      p.p1[k] = c + small(rng);
      p.p2[k] = c + small(rng);
    }
    p.kind = SPM_PRIM_TRIANGLE;
    p.normals = SPM_NONE;
    prims.push_back(p);
  }
  for (int i = 0; i < spheres; ++i) {
    SpmPrim p{};
    for (int k = 0; k < 3; ++k) p.p0[k] = pos(rng);
    p.p1[0] = radius(rng);
    p.kind = SPM_PRIM_SPHERE;
    p.normals = SPM_NONE;
    prims.push_back(p);
  }
  return prims;
}

vec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<float> n;
  vec3 v(n(rng), n(rng), n(rng));
  return glm::normalize(v);
}

TEST(Bvh, EveryLeafRangeIsCoveredOnceAndBoxesContainTheirPrimitives) {
  std::mt19937 rng(7);
  auto prims = random_scene(rng, 3000, 100);
  const auto bvh = spm::build_bvh(prims);
  std::vector<int> covered(prims.size(), 0);
  for (const auto& n : bvh.nodes) {
    const uint32_t count = SPM_BVH_COUNT(n);
    if (count == 0) continue;
    for (uint32_t i = n.offset; i < n.offset + count; ++i) {
      ++covered[i];
      const SpmPrim& p = prims[i];
      const float r = p.kind == SPM_PRIM_SPHERE ? p.p1[0] : 0.0f;
      for (const float* v : {p.p0, p.p1, p.p2}) {
        if (p.kind == SPM_PRIM_SPHERE && v != p.p0) continue;
        for (int k = 0; k < 3; ++k) {
          EXPECT_GE(v[k] - r, n.lo[k] - 1e-3f);
          EXPECT_LE(v[k] + r, n.hi[k] + 1e-3f);
        }
      }
    }
  }
  for (size_t i = 0; i < covered.size(); ++i) ASSERT_EQ(covered[i], 1) << "primitive " << i;
}

TEST(Bvh, KernelClosestHitsEqualBruteForce) {
  std::mt19937 rng(12345);
  spm::SceneTables t;
  t.prims = random_scene(rng, 4000, 150);
  t.nodes = spm::build_bvh(t.prims).nodes;
  t.shapes.push_back(SpmShape{});
  t.materials.push_back(SpmMaterial{});
  t.light_cdf.push_back(1.0f);
  auto& dev = spm::test::device();
  spm::GpuScene gpu(dev, t);

  const int n = 5000;
  std::vector<cl_float4> origins(n), dirs(n);
  std::uniform_real_distribution<float> pos(-70.0f, 70.0f), reach(20.0f, 300.0f);
  for (int i = 0; i < n; ++i) {
    const vec3 o(pos(rng), pos(rng), pos(rng));
    // Half the rays aim at a primitive so that most of them hit something.
    vec3 d = random_unit(rng);
    if (i % 2 == 0) {
      const SpmPrim& p = t.prims[rng() % t.prims.size()];
      const float tri = p.kind == SPM_PRIM_TRIANGLE ? 0.3f : 0.0f;
      const vec3 target = v3(p.p0) + tri * (v3(p.p1) - v3(p.p0)) + tri * (v3(p.p2) - v3(p.p0));
      if (glm::length(target - o) > 1e-3f) d = glm::normalize(target - o);
    }
    origins[i] = {{o.x, o.y, o.z, reach(rng)}};
    dirs[i] = {{d.x, d.y, d.z, 0.0f}};
  }
  const cl::Buffer ob = dev.upload("origins", origins), db = dev.upload("directions", dirs);
  const spm::DeviceBuffer hb = dev.buffer(sizeof(cl_float4) * n, "hits", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_intersect", "spm_intersect");
  spm::set_args(k, gpu, spm::arg("origins", ob), spm::arg("directions", db), spm::arg("hits", hb),
                spm::arg("count", cl_uint(n)));
  dev.launch(k, n);
  const auto hits = dev.download<cl_float4>(hb, n);

  int hit_count = 0, grazing = 0;
  for (int i = 0; i < n; ++i) {
    const vec3 o(origins[i].s[0], origins[i].s[1], origins[i].s[2]);
    const vec3 d(dirs[i].s[0], dirs[i].s[1], dirs[i].s[2]);
    const RefHit ref = brute_force(t.prims, o, d, origins[i].s[3]);
    const float t_dev = hits[i].s[0];
    uint32_t prim_dev;
    std::memcpy(&prim_dev, &hits[i].s[1], sizeof prim_dev);
    if (ref.prim >= 0) ++hit_count;
    // A ray through an edge or tangent to a sphere may go either way in
    // float; only those may disagree, and their hit distances must still agree
    // when both report one.
    const bool device_grazing =
        t_dev >= 0.0f && t.prims[prim_dev].kind == SPM_PRIM_TRIANGLE &&
        std::min({hits[i].s[2], hits[i].s[3], 1.0f - hits[i].s[2] - hits[i].s[3]}) < 1e-4f;
    if (ref.edge_margin < 1e-4f || device_grazing) {
      ++grazing;
      continue;
    }
    if (ref.prim < 0) {
      EXPECT_LT(t_dev, 0.0f) << "ray " << i << " hit on the device only";
      continue;
    }
    ASSERT_GE(t_dev, 0.0f) << "ray " << i << " missed on the device";
    EXPECT_NEAR(t_dev, ref.t, 1e-4f * std::max(1.0f, ref.t)) << "ray " << i;
    if (std::abs(t_dev - ref.t) > 1e-4f * std::max(1.0f, ref.t)) continue;
    EXPECT_EQ(t.prims[prim_dev].p0[0], t.prims[ref.prim].p0[0]) << "ray " << i;
  }
  EXPECT_GT(hit_count, n / 3);  // the comparison exercised many hits
  EXPECT_LT(grazing, n / 100);
}

}  // namespace
