/* The gather's heuristics and caps, in one place: the kernels use them,
 * and the host lists them with its own constants in the tuning table
 * (host/render/tuning.h, docs/TUNING.md). Values only; each one's reason
 * is here, and where it was measured in docs/experiments/. */
#ifndef SPM_TUNING_H
#define SPM_TUNING_H

/* Null boundaries a shadow ray may cross before it counts as blocked; scenes
 * nest media a few levels deep at most. */
#define SPM_MAX_SHADOW_CROSSINGS 16

/* Specular vertices a camera path follows at most: a safety cap, so that
 * the vertices of a sample (null crossings included, at most 4 per specular
 * one) fit the block of 256 RNG events each sample has. */
#define SPM_MAX_CAMERA_SPECULAR 60u

/* Gather rays shorter than SPM_GATHER_NEAR radii do not read the surface
 * map where they end; the path goes on from there instead, at most
 * SPM_GATHER_HOPS times (Jensen 1996's remedy for nearby surfaces). Seen
 * from near, the disk's boundary bias at edges and corners (a disk that
 * reaches past the surface finds no photons there) covers much of the
 * gather ray's hemisphere; seen from further than a few radii it is
 * averaged away. The reach scales with r, so as the passes shrink it the
 * hops become rare. Each hop's vertex has its own events, past the camera
 * vertices' (SPM_MAX_CAMERA_SPECULAR) in the sample's block of 256. */
#define SPM_GATHER_NEAR 4.0f
#define SPM_GATHER_HOPS 2u
#define SPM_GATHER_EVENT 248u

/* Random-number events of a camera sample (spm_gather): its path's
 * segments from the first (at most 4 per specular vertex, null crossings
 * included; lib/walk.h), then its gather hops' from SPM_GATHER_EVENT. */
#define SPM_SAMPLE_EVENTS 256u
#if 4u * SPM_MAX_CAMERA_SPECULAR + 4u > SPM_GATHER_EVENT || SPM_GATHER_EVENT + SPM_GATHER_HOPS + 1u > SPM_SAMPLE_EVENTS
#error "a sample's random-number events overlap"
#endif

/* Half-angle of the cone about a light in which a final-gather ray may be
 * aimed (gather_direction). */
#define SPM_AIM_CONE 1.57079632679489661923f /* pi / 2 */

/* A surface record counts if it lies within this fraction of r of the query's
 * tangent plane: the disk of METHOD.md 5, given the thickness a curved surface
 * or a corner needs and no more. */
#define SPM_DISK_THICKNESS 0.1f

/* A block's samples share a surface or volume estimate within this many
 * radii of where it was made, on surfaces facing the same way to within
 * this cosine (kernels/lib/maps.h, pixel_surface_estimate; METHOD.md 21). */
#define SPM_REUSE_DISTANCE 0.25f
#define SPM_REUSE_COS 0.999f

/* Knots of the optical-depth table a camera segment's estimates share. */
#define SPM_TABLE_KNOTS 32

#endif
