// The kernels' physics helpers (kernels/lib/math.h, sampling.h, intersect.h,
// scene.h, bsdf.h, phase.h, rng.h) compiled as C++17, in namespace spm::clc,
// so that the stream reference (stream_reference.cpp) calls the very
// functions the kernels call instead of a hand-typed copy of them.
//
// This is test code, so it lives in tests/: kernels/lib/ stays OpenCL C that
// the kernels embed and clang lints, and the rounding model below belongs to
// the reference. It provides the part of OpenCL C 1.2 those headers use:
// float2/3/4 with OpenCL's component-wise arithmetic, their built-ins, and
// the SPM_F2/3/4 vector literals (kernels/lib/math.h), which must be spelled
// so because OpenCL's (float3)(x, y, z) is a comma expression in C++. A
// header that still wrote such a literal would compile here to the broadcast
// of its last component; the reference comparison (test_stream_reference.cpp)
// would then fail on every stream that uses it.
#pragma once

#include <Random123/philox.h>  // outside the namespace; rng.h's own #include is then a no-op

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "spm_types.h"

#define __global
#define SPM_F2(x, y) (::spm::clc::float2{x, y})
#define SPM_F3(x, y, z) (::spm::clc::float3{x, y, z})
#define SPM_F4(x, y, z, w) (::spm::clc::float4{x, y, z, w})

namespace spm::clc {

using uint = std::uint32_t;
using ulong = std::uint64_t;

// ---- the device's math library, modelled ------------------------------------
//
// Device and host libraries may round sqrt, exp, log, sin, cos, acos, ...
// differently by a few ulps (OpenCL allows up to 4 for most of them). With
// `ulps` > 0 every such result moves that many ulps up or down
// (pseudo-randomly per call), so that a second run of the reference shows how
// sensitive each record is to that rounding (test_stream_reference.cpp sets
// its tolerances from it). Arithmetic and the exact built-ins (fabs, fmin,
// fmax, copysign) are left alone.

struct Rounding {
  int ulps = 0;
  uint32_t calls = 0;
};
inline thread_local Rounding t_rounding;

inline float rounded(float x) {
  if (t_rounding.ulps == 0 || x == 0.0f || !std::isfinite(x)) return x;
  uint32_t h = ++t_rounding.calls * 0x9e3779b9u;  // Fibonacci hashing of the call count
  h ^= h >> 16;
  const float to = (h & 1u) ? INFINITY : -INFINITY;
  for (int k = 0; k < t_rounding.ulps; ++k) x = std::nextafter(x, to);
  return x;
}

inline float sqrt(float x) { return rounded(std::sqrt(x)); }
inline float exp(float x) { return rounded(std::exp(x)); }
inline float log(float x) { return rounded(std::log(x)); }
inline float expm1(float x) { return rounded(std::expm1(x)); }
inline float log1p(float x) { return rounded(std::log1p(x)); }
inline float sin(float x) { return rounded(std::sin(x)); }
inline float cos(float x) { return rounded(std::cos(x)); }
inline float acos(float x) { return rounded(std::acos(x)); }
inline float cbrt(float x) { return rounded(std::cbrt(x)); }
inline float erf(float x) { return rounded(std::erf(x)); }
inline float rsqrt(float x) { return rounded(1.0f / std::sqrt(x)); }

inline float fabs(float x) { return std::fabs(x); }
inline float fmin(float a, float b) { return std::fmin(a, b); }
inline float fmax(float a, float b) { return std::fmax(a, b); }
inline float copysign(float a, float b) { return std::copysign(a, b); }
inline float clamp(float x, float lo, float hi) { return fmin(fmax(x, lo), hi); }  // as OpenCL defines it

// ---- vectors ------------------------------------------------------------------

struct float2 {
  float x, y;
};

struct float4 {
  float x, y, z, w;
};

struct float3 {
  float x = 0, y = 0, z = 0;
  float3() = default;
  constexpr float3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  constexpr explicit float3(float s) : x(s), y(s), z(s) {}  // OpenCL's (float3)(s)
};

// Component-wise, a scalar operand standing for a vector of it (OpenCL C 6.3).
inline float3 operator+(float3 a, float3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline float3 operator-(float3 a, float3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline float3 operator-(float3 a, float s) { return {a.x - s, a.y - s, a.z - s}; }
inline float3 operator-(float s, float3 a) { return {s - a.x, s - a.y, s - a.z}; }
inline float3 operator+(float3 a, float s) { return {a.x + s, a.y + s, a.z + s}; }
inline float3 operator-(float3 a) { return {-a.x, -a.y, -a.z}; }
inline float3 operator*(float3 a, float3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline float3 operator*(float s, float3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline float3 operator*(float3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline float3 operator/(float3 a, float s) { return {a.x / s, a.y / s, a.z / s}; }
inline float3 operator/(float3 a, float3 b) { return {a.x / b.x, a.y / b.y, a.z / b.z}; }
inline float3 operator/(float s, float3 a) { return {s / a.x, s / a.y, s / a.z}; }

inline float3 fabs(float3 a) { return {fabs(a.x), fabs(a.y), fabs(a.z)}; }
inline float3 fmin(float3 a, float3 b) { return {fmin(a.x, b.x), fmin(a.y, b.y), fmin(a.z, b.z)}; }
inline float3 fmax(float3 a, float3 b) { return {fmax(a.x, b.x), fmax(a.y, b.y), fmax(a.z, b.z)}; }
inline float3 fmax(float3 a, float s) { return {fmax(a.x, s), fmax(a.y, s), fmax(a.z, s)}; }
inline float3 exp(float3 a) { return {exp(a.x), exp(a.y), exp(a.z)}; }
inline float3 sqrt(float3 a) { return {sqrt(a.x), sqrt(a.y), sqrt(a.z)}; }

inline float dot(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline float3 cross(float3 a, float3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(float3 a) { return sqrt(dot(a, a)); }
inline float3 normalize(float3 a) { return a / length(a); }

inline float3 vload3(std::size_t offset, const float* p) { return {p[3 * offset], p[3 * offset + 1], p[3 * offset + 2]}; }
inline void vstore3(float3 v, std::size_t offset, float* p) {
  p[3 * offset] = v.x;
  p[3 * offset + 1] = v.y;
  p[3 * offset + 2] = v.z;
}

// ---- the kernels' headers -----------------------------------------------------------

#include "lib/bsdf.h"
#include "lib/phase.h"
#include "lib/rng.h"

}  // namespace spm::clc

#undef __global  // for the kernels' headers above only
