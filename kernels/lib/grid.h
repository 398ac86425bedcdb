/* The uniform record grids built on the host (host/spm/record_grid.h): cell
 * lookup and the 3D-DDA walk of a ray segment (Amanatides & Woo 1987). */
#ifndef SPM_LIB_GRID_H
#define SPM_LIB_GRID_H

#include "../spm_types.h"
#include "math.h"

/* A grid with its items in cell order: item k of cell c (cell_start[c] <= k <
 * cell_start[c + 1]) carries the position of the record it lists, so a query
 * streams through its cells' items and reads more only for records in range. */
typedef struct SpmGrid {
  const __global SpmGridInfo* info;
  const __global uint* cell_start;
  const __global float4* item_pos;
} SpmGrid;

/* Cell of point p, clamped to the grid; the same float arithmetic as the
 * host's grid_cell_of, so both agree on a point's cell. */
inline int3 grid_cell_of(const __global SpmGridInfo* g, float3 p) {
  const float3 u = floor((p - load3(g->lo)) / g->cell);
  return (int3)((int)clamp(u.x, 0.0f, (float)(g->dims[0] - 1)), (int)clamp(u.y, 0.0f, (float)(g->dims[1] - 1)),
                (int)clamp(u.z, 0.0f, (float)(g->dims[2] - 1)));
}

inline uint grid_cell_index(const __global SpmGridInfo* g, int3 c) {
  return (uint)c.x + g->dims[0] * ((uint)c.y + g->dims[1] * (uint)c.z);
}

/* DDA state over the cells a segment crosses. */
typedef struct SpmGridWalk {
  int3 cell;
  int3 step;
  float3 t_next;  /* ray parameter at the next boundary per axis */
  float3 t_delta; /* ray parameter per cell per axis */
  float t_in;     /* ray parameter where the segment enters the cell */
  float t_end;
} SpmGridWalk;

/* Ray parameter where the segment leaves the walk's cell. The cells' spans
 * [t_in, grid_walk_out) partition the segment's part in the grid, so a
 * record or beam whose point closest to the ray has its parameter in the
 * span is counted in this cell and in no other (METHOD.md 5: once per
 * segment); the point then lies in the cell, so the cell lists it. */
inline float grid_walk_out(const SpmGridWalk* w) { return fmin(fmin(w->t_next.x, w->t_next.y), w->t_next.z); }

/* Starts a walk over [t0, t1] of o + t d clipped to the grid; false when the
 * segment misses it. */
inline bool grid_walk_begin(const __global SpmGridInfo* g, float3 o, float3 d, float t0, float t1, SpmGridWalk* w) {
  const float3 lo = load3(g->lo);
  const float3 hi = lo + g->cell * (float3)((float)g->dims[0], (float)g->dims[1], (float)g->dims[2]);
  const float3 inv = 1.0f / d;
  const float3 ta = (lo - o) * inv;
  const float3 tb = (hi - o) * inv;
  const float3 tn = fmin(ta, tb);
  const float3 tf = fmax(ta, tb);
  const float enter = fmax(fmax(tn.x, tn.y), fmax(tn.z, t0));
  const float leave = fmin(fmin(tf.x, tf.y), fmin(tf.z, t1));
  if (!(enter <= leave)) return false;
  w->cell = grid_cell_of(g, o + enter * d);
  w->step = (int3)(d.x < 0.0f ? -1 : 1, d.y < 0.0f ? -1 : 1, d.z < 0.0f ? -1 : 1);
  const float3 cell_lo = lo + g->cell * convert_float3(w->cell);
  const float3 boundary = cell_lo + g->cell * (float3)(d.x < 0.0f ? 0.0f : 1.0f, d.y < 0.0f ? 0.0f : 1.0f,
                                                     d.z < 0.0f ? 0.0f : 1.0f);
  /* An axis the ray does not move along never reaches a boundary. */
  w->t_next = (float3)(d.x != 0.0f ? (boundary.x - o.x) * inv.x : SPM_INF,
                       d.y != 0.0f ? (boundary.y - o.y) * inv.y : SPM_INF,
                       d.z != 0.0f ? (boundary.z - o.z) * inv.z : SPM_INF);
  w->t_delta = fabs(g->cell * inv);
  w->t_in = enter;
  w->t_end = leave;
  return true;
}

/* Moves to the next cell along the segment; false past its end or the grid. */
inline bool grid_walk_next(const __global SpmGridInfo* g, SpmGridWalk* w) {
  int axis = 0;
  if (w->t_next.y < w->t_next.x) axis = 1;
  if (w->t_next.z < (axis == 0 ? w->t_next.x : w->t_next.y)) axis = 2;
  const float t = axis == 0 ? w->t_next.x : (axis == 1 ? w->t_next.y : w->t_next.z);
  if (t > w->t_end) return false;
  w->t_in = t;
  if (axis == 0) {
    w->cell.x += w->step.x;
    w->t_next.x += w->t_delta.x;
    return w->cell.x >= 0 && w->cell.x < (int)g->dims[0];
  }
  if (axis == 1) {
    w->cell.y += w->step.y;
    w->t_next.y += w->t_delta.y;
    return w->cell.y >= 0 && w->cell.y < (int)g->dims[1];
  }
  w->cell.z += w->step.z;
  w->t_next.z += w->t_delta.z;
  return w->cell.z >= 0 && w->cell.z < (int)g->dims[2];
}

#endif
