/* The gather's map buffers (METHOD.md 5), listed ONCE: spm_gather takes them
 * as SPM_MAP_PARAMS and the host uploads and binds them from the same list
 * (host/spm/map_grids.h), so they cannot disagree.
 * X(type, name): one read-only buffer of `type`. */
#ifndef SPM_MAPS_H
#define SPM_MAPS_H

#define SPM_MAP_BUFFERS(X)                                                                   \
  X(SpmGridInfo, volume_info)  /* the volume map's sphere grid */                            \
  X(uint, volume_start)        /* its cells' first items (CSR) */                            \
  X(float4, volume_pos)        /* per item: the record's position; w: its depth */           \
  X(uint, volume_items)        /* per item: the record's index */                            \
  X(SpmVolumeRecord, volume)   /* the records */                                             \
  X(SpmGridInfo, gather_info)  /* the gather rays' grid of those records (empty unless */     \
  X(uint, gather_start)        /* their radius is below the volume radius): cell starts, */    \
  X(float4, gather_pos)        /* item positions and depths, */                                \
  X(uint, gather_items)        /* record indices */                                            \
  X(SpmGridInfo, volume_caustic_info) /* the caustic volume records' sphere grid, */       \
  X(uint, volume_caustic_start)       /* of the caustic volume radius: cell starts, */     \
  X(float4, volume_caustic_pos)       /* item positions and depths, indices into */        \
  X(uint, volume_caustic_items)       /* `volume` (map_grids.h) */                         \
  X(SpmGridInfo, outer_info)   /* the volume records outside volume_core: their own grid */  \
  X(uint, outer_start)         /* its cells' first items (CSR) */                            \
  X(float4, outer_pos)         /* per item: the record's position; w: its depth */           \
  X(uint, outer_items)         /* per item: the record's index */                            \
  X(SpmVolumeRecord, outer)    /* those records */                                           \
  X(SpmGridInfo, surface_info) /* the surface map's point grid */                            \
  X(uint, surface_start)       /* its cells' first items (CSR) */                            \
  X(float4, surface_pos)       /* per item: position; w: the packed normal */                \
  X(float4, surface_flux)      /* per item: flux; w: depth */                             \
  X(SpmGridInfo, beam_info)    /* the stream beams' capsule grid */                       \
  X(uint, beam_start)          /* its cells' first items (CSR) */                         \
  X(uint, beam_items)          /* per item: the beam's index */                           \
  X(SpmBeam, beams)            /* the beams */                                              \
  X(SpmGridInfo, caustic_info) /* final gather: the caustic surface records' point grid */ \
  X(uint, caustic_start)       /* its cells' first items (CSR) */                         \
  X(float4, caustic_pos)       /* per item: position; w: the packed normal */             \
  X(float4, caustic_flux)      /* per item: flux; w: depth */

#ifdef __OPENCL_VERSION__
#define SPM_MAP_PARAM(type, name) , const __global type *name
#define SPM_MAP_PARAMS SPM_MAP_BUFFERS(SPM_MAP_PARAM)
#endif

#endif
