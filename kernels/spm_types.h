/* Structs shared by the host (C++17) and the kernels (OpenCL C 1.2).
 *
 * Rules (STYLE.md): plain C, no float3 (its size differs between host and
 * device), explicit padding so every struct is a multiple of 16 bytes. The host
 * static_asserts the sizes (host/device/layout.cpp) and the layout test runs a
 * kernel that reports the device's sizeof/offsetof for every field. */
#ifndef SPM_TYPES_H
#define SPM_TYPES_H

#ifdef __OPENCL_VERSION__
typedef uint spm_uint;
typedef int spm_int;
typedef float spm_float;
#else
#include <stdint.h>
typedef uint32_t spm_uint;
typedef int32_t spm_int;
typedef float spm_float;
#endif

#define SPM_NONE 0xffffffffu

#include "spm_tuning.h"

/* Error bits kernels raise in an error word the host checks after each stage. */
#define SPM_ERROR_VOLUME_OVERFLOW 1u  /* more volume records than the buffer holds */
#define SPM_ERROR_SURFACE_OVERFLOW 2u /* more surface records than the buffer holds */
#define SPM_ERROR_NONFINITE 4u        /* a NaN or infinite flux or radiance */
#define SPM_ERROR_BEAM_OVERFLOW 8u    /* more stream beams than the buffer holds */

/* Integrator options as the kernels take them; their names are in
 * host/scene/integrator_options.h, the one table the loader, the command
 * line and the host binding read. */
#define SPM_KERNEL_UNIFORM 0u      /* density kernel 1 / (pi r^2) */
#define SPM_KERNEL_EPANECHNIKOV 1u /* density kernel 2 / (pi r^2) (1 - d^2 / r^2) */
#define SPM_ESTIMATOR_BRE 0u       /* beam radiance estimate (METHOD.md 5) */
#define SPM_ESTIMATOR_PAPER 1u     /* the paper's eq. (4), literally */
#define SPM_ESTIMATOR_BEAMS 2u     /* stream beams, beam x beam 1D (METHOD.md 11) */
#define SPM_DIRECT_NEE 0u          /* direct light on surfaces by shadow rays */
#define SPM_DIRECT_PHOTONS 1u      /* direct light from the photon map only */

/* The gather's terms (SpmGatherParams.terms, `spm render --terms`): each is
 * computed only when its bit is set, so that a render of one term alone
 * shows both its part of the image and its cost. The terms partition the
 * radiance: their images add up to the whole one. */
#define SPM_TERM_EMISSION 1u         /* emission the camera sees, directly or through specular chains */
#define SPM_TERM_DIRECT 2u           /* direct light at the camera's diffuse vertex (shadow ray) */
#define SPM_TERM_INSCATTER 4u        /* single scattering along the camera's segments (shadow rays) */
#define SPM_TERM_VOLUME 8u           /* the camera segments' volume estimate */
#define SPM_TERM_SURFACE 16u         /* the surface estimate at the camera's diffuse vertex (caustic records with a final gather) */
#define SPM_TERM_GATHER_VOLUME 32u   /* the gather rays' volume estimate */
#define SPM_TERM_GATHER_DIRECT 64u   /* direct light at the gather rays' ends (shadow ray) */
#define SPM_TERM_GATHER_SURFACE 128u /* the surface estimate at the gather rays' ends */
#define SPM_TERMS_ALL 255u
#define SPM_TERMS_GATHER (SPM_TERM_GATHER_VOLUME | SPM_TERM_GATHER_DIRECT | SPM_TERM_GATHER_SURFACE)
/* The terms that read the photon maps; without them a pass propagates no streams. */
#define SPM_TERMS_PHOTONS (SPM_TERM_VOLUME | SPM_TERM_SURFACE | SPM_TERM_GATHER_VOLUME | SPM_TERM_GATHER_SURFACE)

/* spm_gather's work-item gathers a block of SPM_GATHER_BLOCK x
 * SPM_GATHER_BLOCK pixels (spm_gather.cl); the host launches one per block. */
#define SPM_GATHER_BLOCK 2u

/* Primitive kinds (SpmPrim.kind). */
#define SPM_PRIM_TRIANGLE 0u
#define SPM_PRIM_SPHERE 1u

/* One ray-traceable primitive: a triangle or an analytic sphere, so that a glass
 * sphere refracts exactly as in Mitsuba 3 (SCENES.md: shape sphere). */
typedef struct SpmPrim {
  spm_float p0[3]; /* triangle vertex 0; sphere centre */
  spm_uint shape;  /* index into the SpmShape table */
  spm_float p1[3]; /* triangle vertex 1; sphere: p1[0] = radius */
  spm_uint kind;   /* SPM_PRIM_TRIANGLE or SPM_PRIM_SPHERE */
  spm_float p2[3]; /* triangle vertex 2 */
  /* Index into the SpmPrimNormals table; with SPM_PRIM_PATCH set, a flat
   * triangle's index into the SpmPatch table; SPM_NONE: flat, no patch. */
  spm_uint normals;
} SpmPrim;

#define SPM_PRIM_PATCH 0x80000000u

/* A planar rectangle (a rectangle shape, a cube's face) that flat triangles
 * belong to: centre, unit edge directions u and v and the half extents along
 * them. Surface estimates and deposits near its edges reflect across them
 * (docs/experiments/gather.md "Surface estimates that stop at edges"), except across the edges
 * `open` names, where another patch continues the plane. */
typedef struct SpmPatch {
  spm_float center[3];
  spm_float half_u;
  spm_float u[3];
  spm_float half_v;
  spm_float v[3];
  spm_uint open; /* SPM_PATCH_OPEN_* bits */
} SpmPatch;

#define SPM_PATCH_OPEN_U_LO 1u
#define SPM_PATCH_OPEN_U_HI 2u
#define SPM_PATCH_OPEN_V_LO 4u
#define SPM_PATCH_OPEN_V_HI 8u

/* Per-vertex shading normals of one triangle (OBJ vertex normals). */
typedef struct SpmPrimNormals {
  spm_float n0[3];
  spm_float n1[3];
  spm_float n2[3];
  spm_float pad[3];
} SpmPrimNormals;

/* Flattened BVH node (depth-first order). Interior: the first child is the next
 * node, `offset` is the second child, `count` is 0 and `axis` the split axis.
 * Leaf: primitives [offset, offset + count) of the reordered SpmPrim array. */
typedef struct SpmBvhNode {
  spm_float lo[3];
  spm_uint offset;
  spm_float hi[3];
  spm_uint count_axis; /* leaf: count (> 0) << 2; interior: axis (0..2) */
} SpmBvhNode;

#define SPM_BVH_COUNT(n) ((n).count_axis >> 2)
#define SPM_BVH_AXIS(n) ((n).count_axis & 3u)

/* Shape flags. */
#define SPM_SHAPE_FLIP_NORMALS 1u

typedef struct SpmShape {
  spm_uint material; /* index into SpmMaterial */
  spm_int interior;  /* medium on the side opposite the normal, -1: none */
  spm_int exterior;  /* medium on the side the normal points to, -1: none */
  spm_int light;     /* area light index, -1: not an emitter */
  spm_uint flags;
  spm_uint pad[3];
} SpmShape;

/* Material types (SpmMaterial.type). Their lobes (METHOD.md 13): delta
 * (conductor, dielectric, thin dielectric, the plastic's coat), glossy (the
 * rough ones) and diffuse (diffuse, the plastic's base). */
#define SPM_MAT_DIFFUSE 0u
#define SPM_MAT_CONDUCTOR 1u  /* smooth conductor: a mirror with the Fresnel reflectance of eta + i k */
#define SPM_MAT_DIELECTRIC 2u
#define SPM_MAT_NULL 3u       /* medium boundary: rays pass straight through */
#define SPM_MAT_THIN_DIELECTRIC 4u /* a thin sheet of glass: reflects, or passes straight on */
#define SPM_MAT_ROUGH_CONDUCTOR 5u  /* a microfacet conductor */
#define SPM_MAT_ROUGH_DIELECTRIC 6u /* a microfacet dielectric boundary */
#define SPM_MAT_PLASTIC 7u          /* a smooth dielectric coat over a diffuse base */

/* Microfacet distributions (SpmMaterial.distribution). */
#define SPM_MICROFACET_BECKMANN 0u
#define SPM_MICROFACET_GGX 1u

typedef struct SpmMaterial {
  spm_float reflectance[3]; /* diffuse: reflectance; plastic: diffuse_reflectance */
  spm_uint type;
  spm_float eta;         /* dielectrics, plastic: int_ior / ext_ior */
  spm_uint twosided;     /* opaque materials reflect on both sides */
  spm_float alpha;       /* rough materials: the microfacet roughness */
  spm_uint distribution; /* rough materials: SPM_MICROFACET_* */
  spm_float specular[3]; /* conductors, plastic: specular_reflectance */
  spm_float fdr_int;     /* plastic: diffuse Fresnel reflectance of the coat from inside */
  spm_float k_eta[3];    /* conductors: the real part of the complex index */
  spm_uint nonlinear;    /* plastic: Mitsuba's `nonlinear` */
  spm_float k[3];        /* conductors: the imaginary part */
  spm_uint pad;
} SpmMaterial;

#define SPM_PHASE_ISOTROPIC 0u
#define SPM_PHASE_HG 1u

/* A medium, coefficients in inverse scene units (scale applied). A
 * homogeneous one has sigma_t and albedo; in a heterogeneous one (METHOD.md
 * 12, Mitsuba 3's `heterogeneous`) each is that factor times a grid's value
 * at the point, where the medium names one (-1: the factor alone). */
typedef struct SpmMedium {
  spm_float sigma_t[3];
  spm_float g;
  spm_float albedo[3];
  spm_uint phase;
  spm_int sigma_t_grid; /* index into the SpmGridVolume table, -1: constant */
  spm_int albedo_grid;
  spm_uint pad[2];
} SpmMedium;

#define SPM_GRID_TRILINEAR 0u
#define SPM_GRID_NEAREST 1u

/* Majorant cells per grid axis are this many voxels wide (METHOD.md 12). */
#define SPM_MAJORANT_VOXELS 8u

/* A grid of 1 or 3 channels over the unit cube of its to_world (Mitsuba 3's
 * gridvolume): values in the scene's grid data buffer from `offset`, index
 * ((z ny + y) nx + x) channels + c, texel centres at (i + 0.5) / n, and 0
 * outside the cube. Beside it, from majorant_offset, the coarse grid of
 * maxima (the largest value of any channel a lookup in each cell can give)
 * that delta and ratio tracking step through. */
typedef struct SpmGridVolume {
  spm_float to_local[12]; /* rows of the affine map world -> unit cube: local_i = row_i . (x, 1) */
  spm_uint dims[3];
  spm_uint channels;
  spm_uint majorant_dims[3];
  spm_uint filter;        /* SPM_GRID_TRILINEAR or SPM_GRID_NEAREST */
  spm_uint offset;
  spm_uint majorant_offset;
  spm_float voxel;        /* world length of the shortest voxel edge */
  spm_uint pad;
} SpmGridVolume;

#define SPM_LIGHT_AREA 0u
#define SPM_LIGHT_POINT 1u
#define SPM_LIGHT_SPOT 2u
#define SPM_LIGHT_DIRECTIONAL 3u
#define SPM_LIGHT_ENVMAP 4u /* envmap and constant: radiance from every direction at infinity */

typedef struct SpmLight {
  spm_float emission[3]; /* area: radiance; point and spot: intensity; directional: irradiance;
                          * envmap: the scale of its map */
  spm_uint type;
  /* point, spot; area: the centroid of its surface, where final-gather rays
   * aim; directional: the centre of the disk its streams start from */
  spm_float position[3];
  spm_float power;       /* mean over RGB of the emitted power (METHOD.md 2) */
  spm_float axis_x[3];   /* spot and directional frame: light shines along +axis_z */
  spm_float cos_cutoff;
  spm_float axis_y[3];
  spm_float cos_beam;
  spm_float axis_z[3];
  spm_float cutoff;      /* radians */
  spm_uint prim_begin;   /* area: range in the light-primitive table */
  spm_uint prim_count;
  spm_float area;        /* area: total surface area; directional: its disk's, pi disk_radius^2 */
  spm_float beam_width;  /* spot: radians */
  spm_int medium;        /* medium the light sits in (area: shape exterior) */
  /* The probability that a final-gather ray aimed at the lights aims at
   * this one (spm_gather.cl, gather_direction): its share of the power of
   * the small lights in a medium (host/scene/gpu_scene.h), 0 for others. */
  spm_float aim;
  spm_float disk_radius; /* directional, envmap: the scene's bounding sphere's (METHOD.md 14) */
  spm_uint map_height;   /* envmap: rows of its lat-long map (prim_begin: its offset in the
                          * scene's light data, prim_count: its columns; lib/lights.h) */
} SpmLight;

/* Area-light primitive table entry: cumulative area fraction, for sampling a
 * point uniformly on the light's surface. */
typedef struct SpmLightPrim {
  spm_uint prim;
  spm_float cdf; /* inclusive cumulative probability */
} SpmLightPrim;

#define SPM_FILTER_BOX 0u
#define SPM_FILTER_GAUSSIAN 1u

/* Pinhole camera. Local ray direction for film coordinates (u, v) in [0, 1]^2
 * (u to the right, v down) is ((1 - 2u) tan_half_x, (1 - 2v) tan_half_y, 1),
 * as in Mitsuba 3 where camera-space +x points left. */
typedef struct SpmCamera {
  spm_float origin[3];
  spm_float tan_half_x;
  spm_float axis_x[3];
  spm_float tan_half_y;
  spm_float axis_y[3];
  spm_float near_clip;
  spm_float axis_z[3];
  spm_float far_clip;
  spm_uint width;
  spm_uint height;
  spm_int medium; /* medium the camera sits in, -1: none */
  spm_uint filter;
  spm_float filter_stddev;
  spm_float filter_radius;
  spm_uint pad[2];
} SpmCamera;

/* Volumetric stream map record (METHOD.md 3, interact): one per medium event
 * of a stream, stored before absorption. Every medium event adds a path
 * vertex, so (stream, depth) orders the records deterministically whatever
 * order the device appended them in. */
typedef struct SpmVolumeRecord {
  spm_float position[3];
  spm_uint stream; /* stream id within the pass */
  spm_float direction[3]; /* the leader's direction of travel at the event */
  spm_uint depth;  /* path vertices from the light up to this event (METHOD.md 10) */
  spm_float flux[3]; /* n * phi: the whole stream's flux (RGB) */
  spm_int medium;    /* the medium the event happened in */
  /* SPM_RECORD_CAUSTIC: the stream's last event before this one was
   * specular, so the record is light focused by glass or a mirror, which
   * the camera reads with the narrower caustic volume radius (map_grids.h) */
  spm_uint flags;
  spm_uint pad[3];
} SpmVolumeRecord;

/* Stream beam (METHOD.md 11): one in-medium flight segment of a stream's
 * leader, from where the stream set off to its next event, carrying the
 * flux the stream set off with. Every segment ends in a path vertex, so
 * (stream, depth) orders the beams as it orders the records. */
typedef struct SpmBeam {
  spm_float origin[3];
  spm_uint stream;        /* stream id within the pass */
  spm_float direction[3]; /* unit direction of travel */
  spm_uint depth;         /* the path vertex a scattering on the beam makes (METHOD.md 10) */
  spm_float flux[3];      /* n * phi as the stream set off (RGB) */
  spm_int medium;         /* the medium the segment crosses */
  spm_float length;       /* to the next event */
  spm_uint pad[3];
} SpmBeam;

/* Record flags. */
#define SPM_RECORD_HAD_EVENT 1u /* the stream scattered or bounced before (METHOD.md 5) */
#define SPM_RECORD_CAUSTIC 2u   /* the stream's last event before this one was specular: on a surface, light
                                 * a final gather ray cannot bring, read at the camera's own vertex
                                 * (spm_gather.cl); in a medium, focused light, read with a narrower kernel */

/* A volume record's `stream` in the gather, once its stream id is no longer
 * read (host/spm/wall_images.h): with SPM_RECORD_WALL set, the record lies
 * within the volume radius of the wall of patch (stream & SPM_RECORD_PATCH)
 * and counts only on its own side of the wall's plane; with SPM_RECORD_IMAGE
 * too, it is the mirror image of such a record, made by the host, and counts
 * only on the other side of the plane, its record's. */
#define SPM_RECORD_WALL 0x80000000u
#define SPM_RECORD_IMAGE 0x40000000u
#define SPM_RECORD_PATCH 0x3fffffffu

/* Surface photon map record: one per alive associated photon of a stream at a
 * diffuse event. */
typedef struct SpmSurfaceRecord {
  spm_float position[3];
  spm_uint stream;
  spm_float direction[3]; /* direction of travel of the arriving photon */
  spm_uint depth_photon;  /* depth << 16 | photon index (depth: path vertices, METHOD.md 10) */
  spm_float flux[3];      /* phi (RGB) */
  spm_uint flags;
  spm_float normal[3];    /* geometric normal on the side the photon arrived from */
  spm_uint pad;
} SpmSurfaceRecord;

/* What every stream kernel of a pass reads (METHOD.md 2-4, 10), in one
 * struct bound by value, so that no kernel takes them one by one in an order
 * the host must repeat. */
typedef struct SpmStreamParams {
  spm_uint seed;
  spm_uint pass;
  spm_uint pass_streams;     /* N_s of the pass */
  spm_uint associated;       /* N_a per stream */
  spm_float stream_width;    /* w: radius of the disk and ball of offsets */
  spm_float march_step;      /* Delta; 0: exact free-flight sampling */
  spm_uint max_bounces;      /* diffuse bounces before a stream ends; SPM_NONE: unlimited */
  spm_uint max_depth;        /* longest path in segments; SPM_NONE: unlimited */
  spm_uint rr_depth;         /* Russian roulette from this path vertex on */
  spm_uint volume_capacity;  /* records the volume map buffer holds */
  spm_uint surface_capacity; /* records the surface map buffer holds */
  spm_uint beam_capacity;    /* beams the beam buffer holds; 0: march writes no beams */
  spm_uint beam_streams;     /* streams [0, beam_streams) of the pass write beams (METHOD.md 11) */
  spm_uint pad[3];
} SpmStreamParams;

/* What the gather kernel of a pass reads besides the maps (METHOD.md 5, 6,
 * 10), in one struct bound by value. */
typedef struct SpmGatherParams {
  spm_uint seed;
  spm_uint pass;
  spm_uint spp;            /* camera samples per pixel in the pass */
  spm_uint max_depth;      /* longest path in segments; SPM_NONE: unlimited */
  spm_float radius;        /* r of the pass */
  spm_uint density_kernel; /* SPM_KERNEL_* */
  spm_uint estimator;      /* SPM_ESTIMATOR_* */
  spm_uint direct;         /* SPM_DIRECT_* */
  spm_uint direct_terms;   /* 0: the photon estimates alone (a later part of the maps) */
  spm_uint final_gather;   /* 1: one gather ray at the camera's diffuse vertex (with SPM_DIRECT_NEE) */
  spm_float march_step;    /* Delta of heterogeneous media's transmittance; 0: ratio tracking (METHOD.md 12) */
  spm_uint first_sample;   /* the render's index of the pass's first sample per pixel (stratify2) */
  spm_uint strata_seed;    /* which scrambled sequence those indices read (stratify2) */
  spm_uint terms;          /* SPM_TERM_* bits of the terms to add; SPM_TERMS_ALL */
  /* Camera rays per sample that bring the emission seen through pixels
   * that see a mirror or glass (spm_gather.cl, emission_chains);
   * 0: each sample's own path brings it everywhere. */
  spm_uint emission_chains;
  /* The first volume_samples of a pixel's samples in the pass add the
   * camera segments' volume estimate, weighted spp / volume_samples; the
   * others leave it out (spm_gather). */
  spm_uint volume_samples;
  /* The volume records' kernel radius for the camera in the pass: the
   * reach of a block's shared volume estimate (volume_reuse_hit). The
   * radius each grid is read with is the grid table's (SpmMapGrid). */
  spm_float volume_radius;
  /* The share of final-gather rays aimed at the lights whose `aim` is
   * above 0 (spm_gather.cl, gather_direction); 0: all cosine-weighted. */
  spm_float gather_aim;
  spm_uint grids;       /* rows of the grid table (SpmMapGrid) */
  spm_uint first_pixel; /* the launch's tile: `count` pixels from first_pixel */
  spm_uint count;
  /* Every grid's radius is read times this: 1 for the pass's image; below
   * 1 for the probe that measures the estimates' bias (METHOD.md 15,
   * host/render/error_model.h). The grids built for the pass's radii hold
   * every record a smaller radius reaches. */
  spm_float radius_scale;
  spm_uint pad[2];
} SpmGatherParams;

/* Uniform grid over spheres of radius r around map records (METHOD.md 5),
 * built on the host as flat CSR arrays: the records of cell c are
 * items[cell_start[c] .. cell_start[c + 1]). Cell (x, y, z) has index
 * x + dims[0] * (y + dims[1] * z). */
typedef struct SpmGridInfo {
  spm_float lo[3];   /* corner of cell (0, 0, 0) */
  spm_float cell;    /* edge length of the cubic cells */
  spm_uint dims[3];  /* cells per axis (each >= 1) */
  spm_uint records;  /* records in the map */
} SpmGridInfo;

/* The places of a camera path that read the photon maps, each reading
 * every grid of the table its SpmMapGrid.radius names (spm_gather.cl). */
#define SPM_READ_CAMERA 0u     /* the camera's medium segments: volume */
#define SPM_READ_GATHER 1u     /* the final-gather rays' medium segments: volume */
#define SPM_READ_VERTEX 2u     /* the camera's diffuse vertex: surface */
#define SPM_READ_GATHER_END 3u /* a gather ray's end: surface */
#define SPM_READ_GATHER_HOP 4u /* a gather ray's end near its start, where the path goes on: surface */
#define SPM_READERS 5u

/* What a map grid lists, and so which estimate reads it (kernels/lib/estimate.h). */
#define SPM_GRID_DISKS 0u    /* surface records, each in its cell: the surface estimate */
#define SPM_GRID_SPHERES 1u  /* volume records' spheres: the beam radiance estimate */
#define SPM_GRID_CAPSULES 2u /* stream beams' capsules: the beam x beam estimate */

/* One row of the gather's grid table (kernels/spm_maps.h; the host's
 * roles are in host/spm/map_grids.cpp). The grid's cell starts are
 * grid_cells[first_cell .. first_cell + cells], indices of its items from
 * first_item in the item buffers all grids share. */
typedef struct SpmMapGrid {
  SpmGridInfo info;
  spm_uint first_cell;
  spm_uint first_item;
  spm_uint kind; /* SPM_GRID_* */
  /* The kernel radius each reader (SPM_READ_*) reads the grid with in the
   * pass; 0: that reader does not read it. */
  spm_float radius[SPM_READERS];
} SpmMapGrid;

#endif
