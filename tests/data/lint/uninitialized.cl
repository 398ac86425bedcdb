// Seeded bugs for tests/test_kernel_lint.cpp: the checks must report each.
kernel void sometimes_set(global float* out, int c) {
  float v;
  if (c > 2) v = 1.0f;
  out[0] = v;  // uninitialised whenever c <= 2
}

typedef struct {
  float t;
  float u;
} Hit;

Hit miss(float t) {
  Hit h;
  h.t = t;
  return h;  // h.u is never written
}

kernel void partly_set(global float* out, float t) {
  const Hit h = miss(t);
  out[0] = h.u;  // line 21
}
