/* The gather's map buffers (METHOD.md 5), listed ONCE: spm_gather takes them
 * as SPM_MAP_PARAMS, and the host's MapGridData holds, counts, uploads and
 * binds them from the same list (host/spm/map_grids.h), so they cannot
 * disagree. Every grid of a pass is one row of the grid table `grids`; the
 * rows' cells and items share the buffers after it, so a grid more is a
 * row more, not a buffer more (host/spm/map_grids.cpp lists the roles).
 * X(type, name): one read-only buffer of `type`. */
#ifndef SPM_MAPS_H
#define SPM_MAPS_H

#include "spm_types.h"

#ifdef __OPENCL_VERSION__
typedef float4 spm_float4;
#else
#include <CL/cl_platform.h>
typedef cl_float4 spm_float4;
#endif

#define SPM_MAP_BUFFERS(X)                                                                          \
  X(SpmMapGrid, grids)              /* the grid table, one row per role */                        \
  X(spm_uint, grid_cells)           /* every row's cell starts (CSR), from its first item */      \
  X(spm_float4, grid_pos)           /* per item: the record's position; w: its index in         */ \
                                    /* volume_records or beams (as_uint), or, in a disk grid,   */ \
                                    /* its packed normal (estimate.h, unpack_normal)            */ \
  X(spm_float4, surface_flux)       /* per item of the disk grids, whose items come first:      */ \
                                    /* the record's flux; w: its depth                          */ \
  X(SpmVolumeRecord, volume_records) /* the volume records the sphere grids list */              \
  X(SpmBeam, beams)                 /* the stream beams the capsule grids list */

#ifdef __OPENCL_VERSION__
#define SPM_MAP_PARAM(type, name) , const __global type *name
#define SPM_MAP_PARAMS SPM_MAP_BUFFERS(SPM_MAP_PARAM)
#endif

#endif
