#include "render/tuning.h"

#include <cstdio>

#include "scene/settings.h"
#include "spm_streams.h"
#include "spm_types.h"

namespace spm {

const std::vector<TuningConstant>& tuning_constants() {
  static const std::vector<TuningConstant> rows = {
      {"kDefaultStreams", kDefaultStreams, "photon streams per pass when none is given",
       "equal time at 10 s, 64x64 (docs/experiments/defaults.md \"Defaults that follow the scene\")"},
      {"kDefaultAssociated", kDefaultAssociated, "associated photons per stream when none is given",
       "equal time at 10 s: 4 within noise of 1 and 2, far better than 16 or 100 (same section)"},
      {"kDefaultBeamStreams", kDefaultBeamStreams, "streams of a pass that write beams, with --estimator beams",
       "a few hundred beams make a smooth estimate (docs/experiments/equal-time.md \"Stream beams\")"},
      {"kScaleNeighbours", kScaleNeighbours, "the derived radius: distance to this nearest pilot event",
       "docs/experiments/defaults.md \"Defaults that follow the scene\""},
      {"kFallbackRadius", kFallbackRadius, "the derived radius where the pilot finds no event, in scene diagonals",
       "a stand-in; scenes with light and geometry never need it"},
      {"kPilotWarmStreams", kPilotWarmStreams, "streams the pilot traces untimed first",
       "enough to launch every stage once (a driver's lazy compilation)"},
      {"kVolumeRadiusFactor", kVolumeRadiusFactor, "the derived volume radius, in radii, in homogeneous media",
       "docs/experiments/volume-kernels.md \"A wider volume kernel by default\""},
      {"kCausticVolumeRadiusFactor", kCausticVolumeRadiusFactor, "the caustic volume records' radius, in radii",
       "docs/experiments/volume-kernels.md \"A kernel for focused light\""},
      {"kAimedLightSize", kAimedLightSize, "lights in a medium up to this share of the scene get aimed gather rays",
       "docs/experiments/caustics.md \"Gather rays aimed at the glow\""},
      {"kGatherAim", kGatherAim, "share of final-gather rays aimed at those lights", "the same section"},
      {"kPhotonsPerSample", kPhotonsPerSample, "derived camera samples per pass: one per this many photons",
       "a camera sample cost about four photons here"},
      {"kMaxPassSpp", kMaxPassSpp, "most camera samples per pixel a derived or balanced pass takes",
       "a cap on a pass's length"},
      {"kPassShareOfBudget", kPassShareOfBudget, "a timed render's pass takes at most this share of the budget",
       "docs/experiments/defaults.md \"Samples and time as a user means them\""},
      {"kPassPerPilot", kPassPerPilot, "a pass's length in pilot times (first_pass_estimate)",
       "the gather took about twice the propagation"},
      {"kPilotAssociated", kPilotAssociated, "associated photons that add one pilot time to a pass's propagation",
       "measured propagation against N_a"},
      {"kGatherShare", kGatherShare, "the gather's share of a balanced timed pass",
       "docs/experiments/pass-balance.md \"Passes balanced for error per second\""},
      {"kFirstBalancedSpp", kFirstBalancedSpp, "camera samples of a balanced render's first pass",
       "caustic_area at 10 s lost a third of its budget to a derived first pass"},
      {"kProbeRows", kProbeRows, "the error probe's stride in rows of pixel blocks, first pass",
       "the probe's cost: every row took 1.35x the fog box's gather, 0.06x cornell_fog's (64x64)"},
      {"kMaxProbeRows", kMaxProbeRows, "the error probe's largest stride", "a few rows still probed at 512x512"},
      {"kMinProbeRows", kMinProbeRows, "rows of blocks the error probe keeps at least",
       "one or two rows of a 64x64 fog box: its bias estimate varied 2x between runs"},
      {"kProbeShare", kProbeShare, "the error probe's share of a pass's time, which sets its stride",
       "a tenth cost cornell_fog about a fifth more error at 10 s; 3% about 7% (docs/experiments/error-estimate.md)"},
      {"kTuningPasses", kTuningPasses, "passes at the derived radius before the error model's plan",
       "one per replicate, two probes per value"},
      {"kCostScale", kCostScale, "radius scale of a timed render's cost pass, which times the stages' growth",
       "cornell_fog: a sample's gather 0.12-0.18 s at the derived radius, 0.05-0.06 s at half"},
      {"kPlanOctavesDown", kPlanOctavesDown, "the plan's smallest radius scale, in octaves below the derived",
       "caustic_area and cornell_fog chose 0.3-0.5 at 10 s (docs/experiments/self-tuning.md)"},
      {"kPlanOctavesUp", kPlanOctavesUp, "the plan's largest radius scale, in octaves above the derived (timed)",
       "mirror_area at 10 s, radius by hand: relMSE 0.0027 at 4x the derived, 0.021-0.027 at 1x"},
      {"kPlanStepsPerOctave", kPlanStepsPerOctave, "radius scales the plan weighs per octave",
       "the error moves with the sixth root of the model's terms"},
      {"kReplanPasses", kReplanPasses, "a timed one-device render plans again after this many passes, twice that, ...",
       "mirror_area at 10 s: plans from two passes alone chose 1/4 of the radius in 2 runs of 5"},
      {"kTargetHorizon", kTargetHorizon, "a render to a target error alone plans for this many times its passes",
       "a stand-in for a budget it does not have"},
      {"kSurfaceCell", kSurfaceCell, "surface grid cell edge, in radii", "query cost against cells per query"},
      {"kBeamCell", kBeamCell, "beam grid cell edge, in beam radii", "cells walked against cells per beam"},
      {"kStreamBatchShare", kStreamBatchShare, "share of the device memory after the scene for a stream batch",
       "the batch and the maps' grids both need room"},
      {"kStreamBatchBytes", double(kStreamBatchBytes), "largest stream batch, bytes",
       "larger batches gained nothing here"},
      {"kFilmShare", kFilmShare, "share of the memory left after the batch for the film", "as above"},
      {"kMapPartsMargin", kMapPartsMargin, "margin when maps are split into parts to fit the device",
       "one split instead of several halvings"},
      {"kHostMapShare", kHostMapShare, "share of the machine's memory a pass's maps may hold (SPM_HOST_MEMORY)",
       "room for the grids built from them"},
      {"SPM_MAX_SHADOW_CROSSINGS", SPM_MAX_SHADOW_CROSSINGS, "null boundaries a ray crosses at most",
       "scenes nest media a few levels deep at most"},
      {"SPM_MAX_CAMERA_SPECULAR", SPM_MAX_CAMERA_SPECULAR, "specular vertices a camera path follows at most",
       "a safety cap within a sample's 256 random-number events"},
      {"SPM_GATHER_NEAR", SPM_GATHER_NEAR, "gather rays shorter than this many radii go on (Jensen 1996)",
       "docs/experiments/gather.md \"A branch-free volume estimate, and gather rays that go on\""},
      {"SPM_GATHER_HOPS", SPM_GATHER_HOPS, "times a gather ray goes on at most", "the same section"},
      {"SPM_AIM_CONE", SPM_AIM_CONE, "half-angle (radians) of an aimed gather ray's cone",
       "docs/experiments/caustics.md \"Gather rays aimed at the glow\""},
      {"SPM_DISK_THICKNESS", SPM_DISK_THICKNESS, "a surface record counts within this many radii of the plane",
       "what curved surfaces and corners need"},
      {"SPM_REUSE_DISTANCE", SPM_REUSE_DISTANCE, "a block's samples share an estimate within this many radii",
       "docs/experiments/fig3-and-speed.md \"Measured here\""},
      {"SPM_REUSE_COS", SPM_REUSE_COS, "... on surfaces facing the same way to within this cosine", "the same"},
      {"SPM_TABLE_KNOTS", SPM_TABLE_KNOTS, "knots of a heterogeneous segment's optical-depth table",
       "docs/experiments/heterogeneous.md \"Smoke and clouds: heterogeneous media (issue 15)\""},
      {"SPM_MAX_MEDIUM_EVENTS", SPM_MAX_MEDIUM_EVENTS, "medium events that end a stream (a safety cap)",
       "roulette and max_depth end streams long before it (METHOD.md 10)"},
      {"SPM_MAX_EVENTS", SPM_MAX_EVENTS, "events in all that end a stream (a safety cap)", "the same"},
  };
  return rows;
}

namespace {

std::string range_text(const Setting& s) {
  if (s.names) return s.names->listed();
  if (std::holds_alternative<bool IntegratorSettings::*>(s.member)) return "true, false";
  char lo[32], hi[32];
  std::snprintf(lo, sizeof lo, "%g", s.lo);
  std::snprintf(hi, sizeof hi, "%g", s.hi);
  std::string out = std::string(s.lo_open ? "(" : "[") + lo + ", " + (s.hi >= double(1 << 30) ? "inf" : hi) +
                    (s.hi_open || s.hi >= double(1 << 30) ? ")" : "]");
  if (s.special) {
    char sp[32];
    std::snprintf(sp, sizeof sp, "%g", *s.special);
    out += " or " + std::string(sp);
  }
  return out;
}

}  // namespace

std::string tuning_markdown() {
  std::string md =
      "# Settings and tuning constants\n\n"
      "Generated from the code by `build/spm settings` (host/scene/settings.cpp and\n"
      "host/render/tuning.cpp); a test checks that this file is what it prints.\n\n"
      "## Settings\n\n"
      "Each is a property of `<integrator type=\"spm\">` (unless marked flag only) and a flag of\n"
      "`spm render`; the flag wins over the file. A setting left out takes its default, or is\n"
      "derived from the scene as the column says. The render prints every value and where it\n"
      "came from (default, scene, command line, derived) before its first pass, and\n"
      "`--profile-json` keeps them under `settings`.\n\n"
      "| setting | flag | values | default | what | measured |\n|---|---|---|---|---|---|\n";
  for (const Setting& s : settings_table()) {
    md += "| `" + std::string(s.name) + "`" + (s.xml ? "" : " (flag only)") + " | `" + s.flag + "` | " +
          range_text(s) + " | " + setting_default(s) + " | " + s.help + " | " + (s.measured ? s.measured : "") +
          " |\n";
  }
  md +=
      "\n## Tuning constants\n\n"
      "The values the renderer chooses by that are not settings: the host's in host/render/tuning.h, the\n"
      "kernels' (`SPM_*`) in kernels/spm_tuning.h, each with its reason in a comment there.\n\n"
      "| constant | value | what | chosen by |\n|---|---|---|---|\n";
  for (const TuningConstant& c : tuning_constants()) {
    char value[32];
    std::snprintf(value, sizeof value, "%.6g", c.value);
    md += "| `" + std::string(c.name) + "` | " + value + " | " + c.what + " | " + c.why + " |\n";
  }
  return md;
}

}  // namespace spm
