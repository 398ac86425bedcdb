// The constants the renderer chooses by, which are not settings a scene or
// the command line can give: each written here once, with why it has its
// value and where that was measured; the kernels' own are in
// kernels/spm_tuning.h. tuning_constants() lists both for `spm settings`
// and docs/TUNING.md, which the tests check against it. The settings
// themselves are the table of host/scene/settings.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace spm {

// Photon streams per pass and associated photons per stream when the scene
// and the command line name none. Counts carry no unit. Measured here at
// equal time (10 s, 64x64): fewer associated photons make cheaper passes,
// and more passes (fresh maps, a shrinking radius) beat more photons per
// stream; 4 was within noise of 1 and 2 on the fog box and far better than
// 16 or 100 on it and on cornell_fog. With the final gather, 5,000 streams
// did as well at 10 s, but their larger derived radius left the fog box 5%
// dark after 4 passes, so 10,000 stay.
inline constexpr int kDefaultStreams = 10000;
inline constexpr int kDefaultAssociated = 4;

// Streams of a pass that write stream beams (METHOD.md 11) when the gather
// reads them and the scene names no number: a beam gathers along its whole
// length, so a few hundred make a smooth estimate, while the gather's cost
// grows with their number.
inline constexpr int kDefaultBeamStreams = 1000;

// Distinct streams' records a density estimate aims to gather: the derived
// radius is the distance to the kScaleNeighbours-th nearest event of the
// scale pilot (METHOD.md 22).
inline constexpr int kScaleNeighbours = 32;

// The derived radius where the pilot finds too few events: this share of
// the scene's bounding-box diagonal.
inline constexpr float kFallbackRadius = 0.01f;

// Streams the scale pilot traces untimed before its timed run, so that the
// kernels' first launches (a driver's lazy compilation) stay out of the
// time that sizes a timed render's passes.
inline constexpr uint32_t kPilotWarmStreams = 64;

// The volume records' kernel radius against the radius when the scene names
// none, in scenes whose media are all homogeneous, with the beam radiance
// estimate (bre) and single scattering by next-event estimation (direct
// nee): the camera's volume estimate then holds multiple scattering only,
// which varies over the medium's mean free path, far more slowly than a
// caustic on a surface or the single scattering around a light, and since
// the volume records' images stop the estimate at walls, a wider kernel
// costs little bias. Light focused by glass or a mirror does not vary
// slowly: the records of its first scattering (SPM_RECORD_CAUSTIC) keep
// kCausticVolumeRadiusFactor radii (METHOD.md 17). Measured at 10 and 30 s:
// with one kernel for all records, 1.5 radii gave 9-13% less error at 30 s
// than 1 on cornell_fog and the fog box and 21% on caustic_area, 3 less,
// the caustic's cone blurred; with the caustic records apart, 3 radii for
// the rest gave caustic_area 31% less error than 1.5 at 10 s (2 radii
// 25%), and cornell_fog and the fog box the same within their runs'
// spread. In smoke the light follows the density, and on smoke_cornell 1.5
// gave 11% more error, so heterogeneous media keep the radius.
inline constexpr float kVolumeRadiusFactor = 3.0f;
inline constexpr float kCausticVolumeRadiusFactor = 1.5f;

// A light in a medium lights the medium around it, and the light scattered
// once there arrives with a radiance of about 1 / sin alpha at an angle
// alpha from the light, up to the angle the light subtends: the smaller the
// light, the more of that glow a cosine-weighted final-gather ray misses.
// Final-gather rays are aimed at the lights in a medium no larger than this
// share of the scene's diagonal (half their bounding box's diagonal; point
// and spot lights: 0): caustic_area's sphere light is 0.8% of it,
// cornell_fog's ceiling light 10% and the fog box's 8%, where aiming gave
// 10% more error and none less (METHOD.md 20).
inline constexpr double kAimedLightSize = 0.05;

// The share of final-gather rays aimed at those lights where the scene has
// any: caustic_area at 10 s, seeds 1 to 3, had 20% less error with 1/4 and
// the gather rays' volume term 2.5 times less variance; with 1/2 the term
// had 3.7 times less, but its rays, aimed into the light's bright
// surroundings, read more records, and timed renders were no better.
inline constexpr float kGatherAim = 0.25f;

// Camera samples per pixel of a pass when none is given: one per this many
// photons of the pass, so that the gather and the stream propagation take
// comparable time (a camera sample cost about four times a photon here),
// at least 1 and at most kMaxPassSpp.
inline constexpr double kPhotonsPerSample = 4.0;
inline constexpr int kMaxPassSpp = 64;

// A timed render's passes are sized so that one takes at most this share of
// the budget by first_pass_estimate; after the first pass, a pass that would
// not fit (judged by the longest so far) is never started.
inline constexpr double kPassShareOfBudget = 0.1;

// first_pass_estimate: a pass takes about kPassPerPilot times the scale
// pilot's propagation of one photon per stream (the gather about twice the
// propagation), and propagation grows by the pilot's own time for every
// kPilotAssociated associated photons.
inline constexpr double kPassPerPilot = 3.0;
inline constexpr double kPilotAssociated = 8.0;

// The gather's share of a pass at which the error at equal time was lowest
// (tools/pass_balance.py, docs/experiments/pass-balance.md "Passes balanced
// for error per second": 2/3 to 3/4 on fog_box and cornell_fog alike).
inline constexpr double kGatherShare = 2.0 / 3.0;

// Camera samples of a balanced timed render's first pass, before any stage
// has been timed: the derived count (one per four photons) can make the
// first pass several times a balanced one (caustic_area at 10 s: 61
// samples, about 3 s, against 16 samples and 1 s after it), and the budget
// then lost a third to it.
inline constexpr int kFirstBalancedSpp = 4;

// The error probe (render/error_model.h) gathers every kProbeRows-th row of
// blocks of pixels in the first pass; a device's later passes change the
// stride by powers of two so that the probe takes about kProbeShare of a
// pass (a probe of every row took 1.35 times the fog box's gather at 64x64,
// 0.06 times cornell_fog's; at a tenth of the pass, cornell_fog's error at
// 10 s rose by about a fifth, docs/experiments/error-estimate.md), up to
// kMaxProbeRows and keeping at least
// kMinProbeRows rows probed: with one or two rows of a 64x64 image the
// fog box's estimated bias varied 2x from run to run.
inline constexpr int kProbeRows = 8;
inline constexpr int kMaxProbeRows = 64;
inline constexpr int kMinProbeRows = 8;
inline constexpr double kProbeShare = 0.03;

// The error model's plan (render/planner.h, docs/METHOD.md 15). The first
// kTuningPasses passes render at the derived radius and give the model its
// first terms (two: one per replicate, and two probes per value); a timed
// render's next pass, at kCostScale of the radius, times how a pass's
// stages grow with it (cornell_fog at 64x64: a sample's gather 0.12-0.18 s
// at the derived radius, 0.05-0.06 s at half of it). Scales run from
// 2^-kPlanOctavesDown to 2^kPlanOctavesUp of the derived radius in
// kPlanStepsPerOctave steps an octave (the error moves with the sixth root
// of the model's terms, so finer steps would chase their noise; at 10 s
// cornell_fog's plans chose about 0.38, mirror_area's 3-4: its radius set
// by hand to 4 times the derived 0.57 had relMSE 0.0027, at 0.57 0.021-0.027); a timed render on one device plans again after kReplanPasses
// passes, twice that, and so on, from more probes (mirror_area at 10 s: a
// plan from two passes alone chose a quarter of the radius in two runs of
// five, and their error was 5-10 times the others'); a render to a target
// error alone plans for kTargetHorizon times its passes so far.
inline constexpr int kTuningPasses = 2;
inline constexpr float kCostScale = 0.5f;
inline constexpr int kPlanOctavesDown = 4;
inline constexpr int kPlanOctavesUp = 2;
inline constexpr int kPlanStepsPerOctave = 8;
inline constexpr int kReplanPasses = 8;
inline constexpr double kTargetHorizon = 16.0;

// Edge of the surface map's point grid cells, in gather radii. A query
// examines about (2 + kSurfaceCell)^2 r^2 of surface for the pi r^2 it uses
// and reads the bounds of up to (2 / kSurfaceCell + 1)^2 rows of cells.
inline constexpr float kSurfaceCell = 1.0f;

// Edge of the stream beams' capsule grid cells, in beam radii: a ray
// examines the beams of the cells it crosses, which lie within about
// r + (1/2 + sqrt(3)/2) kBeamCell r of it, and a beam of length L is listed
// in about pi (1 + sqrt(3)/2 kBeamCell)^2 L / (kBeamCell^3 r) cells.
inline constexpr float kBeamCell = 1.5f;

// The device memory budget is shared out by sizes alone (never by what the
// driver has freed so far, which varies from run to run), so that the same
// render always makes the same batches, tiles and map parts: the scene's
// tables first, then this share of the rest for a stream batch, at most
// kStreamBatchBytes, this share of what remains for the film, and the rest
// for the maps' grids.
inline constexpr double kStreamBatchShare = 0.5;
inline constexpr size_t kStreamBatchBytes = size_t(1) << 30;
inline constexpr double kFilmShare = 0.25;

// Maps whose grids do not fit the device are gathered in parts: as many as
// their size over the budget says, with this margin, before halving them.
inline constexpr double kMapPartsMargin = 1.25;

// Host memory a pass's maps may hold before they are gathered, unless
// SPM_HOST_MEMORY says otherwise: this share of the machine's memory.
inline constexpr double kHostMapShare = 0.25;

// One row of the tuning table.
struct TuningConstant {
  const char* name;
  double value;
  const char* what;  // what it sets, in a line
  const char* why;   // how its value was chosen, or where it was measured
};

// The constants above and the kernels' (kernels/spm_tuning.h), in one table.
const std::vector<TuningConstant>& tuning_constants();

// docs/TUNING.md: the settings table (scene/settings.h) and this one, in
// words; `spm settings` prints it and a test checks the file.
std::string tuning_markdown();

}  // namespace spm
