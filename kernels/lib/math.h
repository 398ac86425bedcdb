/* Small vector helpers shared by every kernel. */
#ifndef SPM_LIB_MATH_H
#define SPM_LIB_MATH_H

#define SPM_PI 3.14159265358979323846f
#define SPM_INV_PI 0.31830988618379067154f
#define SPM_INF INFINITY

/* Vector literals. OpenCL C's (float3)(x, y, z) is a comma expression in
 * C++, where tests/cl_compat.h compiles these headers for the stream
 * reference and defines the macros as C++ constructions instead. */
#ifdef __OPENCL_VERSION__
#define SPM_F2(x, y) ((float2)(x, y))
#define SPM_F3(x, y, z) ((float3)(x, y, z))
#define SPM_F4(x, y, z, w) ((float4)(x, y, z, w))
#endif

inline float3 load3(const __global float* p) { return SPM_F3(p[0], p[1], p[2]); }

inline float max_comp(float3 v) { return fmax(v.x, fmax(v.y, v.z)); }
inline float mean_comp(float3 v) { return (v.x + v.y + v.z) * (1.0f / 3.0f); }

/* Orthonormal basis around a unit vector (Duff et al. 2017, branchless). */
inline void make_basis(float3 n, float3* t, float3* b) {
  const float sign = copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float c = n.x * n.y * a;
  *t = SPM_F3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
  *b = SPM_F3(c, sign + n.y * n.y * a, -n.y);
}

inline float3 to_world(float3 v, float3 n) {
  float3 t, b;
  make_basis(n, &t, &b);
  return v.x * t + v.y * b + v.z * n;
}

/* Offset for a ray leaving a surface at p towards the side `side_normal`
 * points to: relative to the coordinates' magnitude, and to a hundredth of
 * the scene's extent (its largest coordinate) near the origin, so that a
 * scene scaled by any factor avoids self-intersection alike and traces the
 * same paths. */
inline float3 offset_origin(float3 p, float3 side_normal, float extent) {
  const float scale = 0.01f * extent + max_comp(fabs(p));
  return p + side_normal * (2e-5f * scale);
}

#endif
