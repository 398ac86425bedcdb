#!/usr/bin/env python3
"""Convergence of spm to a Mitsuba 3 reference, and an equal-time comparison
with Mitsuba's volpath.

1. Sweep: `spm render` for increasing pass counts (--passes), for each
   estimator (--estimators, default bre and paper), at the reference's
   resolution; relMSE (eps 1e-2) against the reference, against passes and
   against seconds, as CSV and log-log plots.
2. Equal time (--budgets, seconds): spm with the bre estimator and its own
   time budget (`--time B`: its passes end within B), against Mitsuba's
   volpath rendering chunks of samples for the same wall clock (the scene's
   integrator replaced as tools/reference.py does, another seed than the
   reference's), both judged against the reference, in the same run; table
   (CSV and markdown) and plot. --repeats N runs each budget N times with
   fresh seeds for both, alternating which goes first, and the table gives
   the medians and the range of the per-run ratio: one run's relMSE spreads
   by 20% or more, and the machine's speed drifts. Times are rendering
   times: spm's own "passes in X s" (device set-up, kernel build, scene loading and the scale
   pilot excluded; the whole command's wall clock is in the CSV) and
   Mitsuba's render loop after a one-sample warm-up that compiles its
   kernels.

--reference-noise V gives the reference's own noise (its relMSE against
the truth, which tests/data/reference/README.md measures for each long
reference): a relMSE against a reference is the renderer's error plus
that noise (the two are independent), so the table adds the ratio of
both errors less V, which a judge whose noise is near spm's error would
otherwise hide.

--lights FACTOR adds a table of both renderers' relMSE over the pixels that
see a light directly (the reference over FACTOR times its median: a light a
few pixels wide, each of whose pixels sees its edge) and over the ring of
pixels around them, the silhouette and glow that issue 14 asks to be as
clean as volpath's.

Everything goes to --out (default BUILD/convergence/SCENE); --summary-dir
copies the small plots and the markdown table there too (for docs/experiments/).

Example:
  tools/convergence.py scenes/cornell_fog.xml \\
      --reference tests/data/reference/cornell_fog.exr --passes 1,2,4,8,16,32 \\
      --budgets 2,5,10,20
  # the global fog box (every spm setting derived, volpath unbounded):
  tools/convergence.py scenes/fog_box.xml --reference tests/data/reference/fog_box.exr \\
      --passes 1,4,16 --estimators bre --budgets 10 --max-depth -1
  # a small light the camera sees, its silhouette tabulated too:
  tools/convergence.py scenes/caustic_area.xml --reference tests/data/reference/caustic_area.exr \\
      -D res=64 --passes 1 --estimators bre --budgets 2,5,10,30 --repeats 5 --lights 100
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

sys.dont_write_bytecode = True  # no tools/__pycache__ in the work tree
sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference  # noqa: E402

RE_PASSES = re.compile(r"\((\d+) passes in ([0-9.]+) s")


def run_spm(spm, scene, out, res, passes, estimator, seed, defines, extra, log, budget=None):
    """`passes` passes, or passes for `budget` seconds when it is given."""
    cmd = [str(spm), "render", str(scene), "-o", str(out), "--png", str(Path(out).with_suffix(".png")),
           "--res", f"{res[0]}x{res[1]}", "--estimator", estimator, "--seed", str(seed)]
    cmd += ["--time", f"{budget:g}"] if budget is not None else ["--passes", str(passes)]
    for d in defines:
        cmd += ["-D", d]
    cmd += extra
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"convergence: {' '.join(cmd)} failed ({p.returncode}):\n{p.stderr}")
    m = RE_PASSES.search(p.stderr)
    if not m:
        raise SystemExit(f"convergence: no '(N passes in X s)' in spm's output:\n{p.stderr}")
    done, seconds = int(m.group(1)), float(m.group(2))
    log(f"spm {estimator} {done} passes: {seconds:.2f} s (process {wall:.2f} s)")
    return {"passes": done, "seconds": seconds, "wall": wall, "command": " ".join(cmd)}


def add_spm_arguments(p, defines_help):
    """The arguments every tool comparing spm with a reference takes: the
    scene, the reference, where the build is, and what to pass to spm."""
    p.add_argument("scene", type=Path)
    p.add_argument("--reference", type=Path, required=True, help="reference EXR (tools/reference.py)")
    p.add_argument("--build-dir", type=Path, default=reference.default_build_dir(),
                   help="build directory: venv-mitsuba and the default spm (default: %(default)s)")
    p.add_argument("--spm", type=Path, default=None, help="spm executable (default: BUILD/spm)")
    p.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE", help=defines_help)
    p.add_argument("--spm-arg", action="append", default=[], metavar="ARG",
                   help="extra argument for spm render (repeatable, e.g. --spm-arg=--streams=20000)")


def write_csv(path, rows, fields):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)


def plot_sweep(rows, path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(8, 3.3), dpi=80)
    for est, style in (("bre", "o-"), ("paper", "s--")):
        r = [x for x in rows if x["estimator"] == est]
        if not r:
            continue
        ax[0].loglog([x["passes"] for x in r], [x["relmse"] for x in r], style, label=est)
        ax[1].loglog([x["seconds"] for x in r], [x["relmse"] for x in r], style, label=est)
    ax[0].set_xlabel("passes")
    ax[1].set_xlabel("seconds (spm rendering)")
    for a in ax:
        a.set_ylabel("relMSE vs Mitsuba")
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# equal_time.csv's columns with --lights: relMSE over the pixels that see a
# light and over the ring around them (compare.light_masks).
LIGHT_KEYS = ("spm_light_relmse", "mitsuba_light_relmse", "spm_ring_relmse", "mitsuba_ring_relmse")


def median_rows(rows, budgets):
    """Per budget, the median of each number over its runs, and the range of
    the per-run ratio."""
    import statistics
    out = []
    for b in budgets:
        runs = [r for r in rows if r["budget"] == b]
        m = {k: statistics.median(r[k] for r in runs)
             for k in ("spm_passes", "spm_seconds", "spm_relmse", "mitsuba_spp", "mitsuba_seconds", "mitsuba_relmse",
                       "ratio", "ratio_less_noise", *LIGHT_KEYS) if k in runs[0]}
        m.update(budget=b, runs=len(runs), ratio_min=min(r["ratio"] for r in runs),
                 ratio_max=max(r["ratio"] for r in runs))
        out.append(m)
    return out


def plot_equal_time(rows, path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(4.2, 3.3), dpi=80)
    ax.loglog([r["spm_seconds"] for r in rows], [r["spm_relmse"] for r in rows], "o-", label="spm (bre)")
    ax.loglog([r["mitsuba_seconds"] for r in rows], [r["mitsuba_relmse"] for r in rows], "s--",
              label="Mitsuba volpath")
    # Label the budgets, not the log axis's minor ticks, which overlap.
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xticks([r["budget"] for r in rows], [f'{r["budget"]:g}' for r in rows])
    ax.set_xlabel("seconds")
    ax.set_ylabel("relMSE vs reference")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main() -> int:
    reference.reexec_in_venv(os.path.abspath(__file__))
    p = argparse.ArgumentParser(description="relMSE of spm against a Mitsuba reference for increasing pass "
                                "counts (both estimators), and spm vs Mitsuba volpath at equal time.",
                                epilog="Example:" + __doc__.split("Example:")[1],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    add_spm_arguments(p, "scene default overrides for both renderers (repeatable)")
    p.add_argument("--out", type=Path, default=None, help="output directory (default: BUILD/convergence/SCENE)")
    p.add_argument("--passes", default="1,2,4,8,16,32", help="pass counts of the sweep (default %(default)s)")
    p.add_argument("--estimators", default="bre,paper", help="estimators of the sweep (default %(default)s)")
    p.add_argument("--budgets", default="2,5,10,20",
                   help="equal-time budgets in seconds; empty: no equal-time comparison (default %(default)s)")
    p.add_argument("--seed", type=int, default=1, help="spm seed, and Mitsuba's base seed + 1000 (default 1)")
    p.add_argument("--max-depth", type=int, default=64, help="Mitsuba volpath max_depth (default 64)")
    p.add_argument("--repeats", type=int, default=1,
                   help="equal-time runs per budget, each renderer with seeds of its own, alternating which goes "
                        "first; the table gives medians (default %(default)s)")
    p.add_argument("--reference-noise", type=float, default=0.0,
                   help="the reference's own relMSE noise (tests/data/reference/README.md): the table adds the ratio "
                        "with it taken from both renderers' relMSE (default: none)")
    p.add_argument("--lights", type=float, default=None, metavar="FACTOR",
                   help="also tabulate both renderers' relMSE over the pixels that see a light (the reference over "
                        "FACTOR times its median, e.g. 100: a small light's silhouette) and over the ring around them")
    p.add_argument("--summary-dir", type=Path, default=None,
                   help="also copy the plots and the markdown table here as SCENE_*.png / SCENE_*.md")
    args = p.parse_args()
    if args.repeats < 1:
        p.error("--repeats must be at least 1")
    log = lambda *a: print("convergence:", *a, file=sys.stderr, flush=True)  # noqa: E731

    import numpy as np
    import compare

    name = args.scene.stem
    out = args.out or args.build_dir / "convergence" / name
    out.mkdir(parents=True, exist_ok=True)
    spm = args.spm or args.build_dir / "spm"
    ref = compare.load_exr(args.reference)
    res = (ref.shape[1], ref.shape[0])
    if args.lights is not None:
        light, ring = compare.light_masks(ref, args.lights)
        if not light.any() or not ring.any():
            p.error(f"--lights {args.lights:g}: the reference has no pixel over {args.lights:g} times its median, "
                    "or no pixel around those")
    passes = [int(x) for x in args.passes.split(",") if x]
    estimators = [x for x in args.estimators.split(",") if x]

    # 1. Sweep.
    rows = []
    # An empty --passes skips the sweep (the equal-time comparison alone).
    for est in estimators if passes else []:
        for n in passes:
            exr = out / f"spm_{est}_{n:04d}.exr"
            r = run_spm(spm, args.scene, exr, res, n, est, args.seed, args.defines, args.spm_arg, log)
            m = compare.metrics(compare.load_exr(exr), ref)
            rows.append({"estimator": est, **r, **{k: m[k] for k in ("relmse", "rmse", "mean_ratio_all")},
                         "mean_r": m["mean"][0], "mean_g": m["mean"][1], "mean_b": m["mean"][2]})
            log(f"  relMSE {m['relmse']:.5g}, mean ratio {m['mean_ratio_all']:.4f}")
        compare.error_png(compare.load_exr(out / f"spm_{est}_{passes[-1]:04d}.exr"), ref,
                          out / f"error_{est}_{passes[-1]}.png", titles=(f"spm {est}, {passes[-1]} passes",
                                                                         "Mitsuba volpath"))
        compare.error_png(compare.load_exr(out / f"spm_{est}_{passes[-1]:04d}.exr"), ref,
                          out / f"diff_{est}_{passes[-1]}.png", signed=True,
                          titles=(f"spm {est}, {passes[-1]} passes", "Mitsuba volpath"))
    fields = ["estimator", "passes", "seconds", "wall", "relmse", "rmse", "mean_ratio_all", "mean_r", "mean_g",
              "mean_b", "command"]
    write_csv(out / "sweep.csv", rows, fields)
    if rows:
        plot_sweep(rows, out / "convergence.png", f"{name}: spm vs Mitsuba volpath, {res[0]}x{res[1]}")
    md = [f"# {name}: spm against Mitsuba volpath ({args.reference.name}, {res[0]}x{res[1]})", "",
          "| estimator | passes | seconds | relMSE | mean ratio spm/ref |", "|---|---|---|---|---|"]
    md += [f"| {r['estimator']} | {r['passes']} | {r['seconds']:.2f} | {r['relmse']:.4g} | "
           f"{r['mean_ratio_all']:.4f} |" for r in rows]

    # 2. Equal time.
    budgets = [float(x) for x in args.budgets.split(",") if x]
    et_rows = []
    if budgets:
        import mitsuba as mi
        defines = reference.parse_defines(args.defines)
        text = reference.substitute_integrator(args.scene.read_text(), args.max_depth, 5)
        variant = reference.pick_variant("auto", args.scene, text, defines, log)
        scene = reference.load_scene(args.scene, text, defines)
        film = [int(v) for v in scene.sensors()[0].film().size()]
        if film != list(res):
            raise SystemExit(f"convergence: Mitsuba's film is {film[0]}x{film[1]} but the reference is "
                             f"{res[0]}x{res[1]}: pass -D res=...")
        reference.render(scene, 1, 999, 1, 0.0, lambda *a: None)  # compile the kernels
        # Mitsuba's time per launch and per sample, from two probes: each
        # chunk of samples is a launch of its own (14-20 ms each for the
        # scenes here at 64x64, 2 cores), so a time per sample taken from one
        # small probe would make the chunks too small and cost Mitsuba
        # samples. Chunks take about a tenth of a budget, and its tail is
        # filled with smaller ones (reference.render).
        _, _, t_small = reference.render(scene, 16, 998, 16, 0.0, lambda *a: None)
        _, _, t_large = reference.render(scene, 128, 997, 128, 0.0, lambda *a: None)
        per_spp = max(1e-9, (t_large - t_small) / 112.0)
        overhead = max(0.0, t_small - 16.0 * per_spp)
        log(f"Mitsuba: {1e3 * overhead:.1f} ms per launch, {1e3 * per_spp:.3f} ms per sample")
        for b in budgets:
            chunk = max(1, min(4096, 2 ** int(math.floor(math.log2(max(1.0, 0.1 * b / per_spp))))))
            for rep in range(args.repeats):
                exr = out / (f"equal_spm_{b:g}s.exr" if args.repeats == 1 else f"equal_spm_{b:g}s_{rep}.exr")
                # Alternate which renderer goes first, so that a drift in the
                # machine's speed does not fall on one of them.
                def spm_run():
                    return run_spm(spm, args.scene, exr, res, 0, "bre", args.seed + 100 + rep, args.defines,
                                   args.spm_arg, log, budget=b)

                def mitsuba_run():
                    return reference.render(scene, 0, args.seed + 1000 + rep, chunk, b, lambda *a: None, overhead)

                if rep % 2 == 0:
                    r = spm_run()
                    img, spp_done, secs = mitsuba_run()
                else:
                    img, spp_done, secs = mitsuba_run()
                    r = spm_run()
                spm_img, mitsuba_img = compare.load_exr(exr), img.astype(np.float64)
                ms = compare.metrics(spm_img, ref)
                mm = compare.metrics(mitsuba_img, ref)
                log(f"budget {b:g} s, run {rep + 1}/{args.repeats}: spm {r['passes']} passes {r['seconds']:.2f} s "
                    f"relMSE {ms['relmse']:.4g}; Mitsuba {spp_done} spp {secs:.2f} s relMSE {mm['relmse']:.4g}")
                reference.write_exr(exr.with_name(exr.name.replace("equal_spm_", "equal_mitsuba_")), img)
                et_rows.append({"budget": b, "run": rep, "spm_passes": r["passes"], "spm_seconds": r["seconds"],
                                "spm_wall": r["wall"],
                                "spm_relmse": ms["relmse"], "spm_mean_ratio": ms["mean_ratio_all"],
                                "mitsuba_spp": spp_done, "mitsuba_seconds": secs, "mitsuba_relmse": mm["relmse"],
                                "mitsuba_mean_ratio": mm["mean_ratio_all"], "variant": variant,
                                "ratio": ms["relmse"] / mm["relmse"],
                                "ratio_less_noise": (ms["relmse"] - args.reference_noise) /
                                                    (mm["relmse"] - args.reference_noise)})
                if args.lights is not None:
                    et_rows[-1].update(zip(LIGHT_KEYS, (compare.metrics(x, ref, mask=k)["relmse"]
                                                        for k in (light, ring) for x in (spm_img, mitsuba_img))))
        write_csv(out / "equal_time.csv", et_rows, list(et_rows[0].keys()))
        med = median_rows(et_rows, budgets)
        plot_equal_time(med, out / "equal_time.png", f"{name} {res[0]}x{res[1]}: equal time")
        md += ["", f"Equal time (spm bre vs Mitsuba {mi.__version__} volpath, {variant}, 2 cores; "
               f"{args.repeats} run(s) per budget, medians, the ratio the median of each run's "
               f"spm / Mitsuba relMSE; Mitsuba {1e3 * overhead:.1f} ms per launch, "
               f"{1e3 * per_spp:.3f} ms per sample):", "",
               "| budget s | spm passes | spm s | spm relMSE | Mitsuba spp | Mitsuba s | Mitsuba relMSE | "
               "ratio (min-max) |",
               "|---|---|---|---|---|---|---|---|"]
        noise = args.reference_noise > 0.0
        if noise:
            md[-4] += (f" The last column takes the reference's own noise, {args.reference_noise:.3g}, from both "
                       "relMSEs before the ratio (the median of the runs' ratios).")
            md[-2] += " ratio less the reference's noise |"
            md[-1] += "---|"
        md += [f"| {r['budget']:g} | {r['spm_passes']:g} | {r['spm_seconds']:.2f} | {r['spm_relmse']:.4g} | "
               f"{r['mitsuba_spp']:g} | {r['mitsuba_seconds']:.2f} | {r['mitsuba_relmse']:.4g} | "
               f"{r['ratio']:.2g} ({r['ratio_min']:.2g}-{r['ratio_max']:.2g}) |"
               + (f" {r['ratio_less_noise']:.2g} |" if noise else "") for r in med]
    if et_rows and args.lights is not None:
        md += ["", f"relMSE over the {int(light.sum())} pixels that see a light (the reference over {args.lights:g} "
               f"times its median) and the {int(ring.sum())} around them (medians):", "",
               "| budget s | light: spm | light: Mitsuba | around: spm | around: Mitsuba |", "|---|---|---|---|---|"]
        md += [f"| {r['budget']:g} | " + " | ".join(f"{r[k]:.2g}" for k in LIGHT_KEYS) + " |" for r in med]
    (out / "summary.md").write_text("\n".join(md) + "\n")
    (out / "summary.json").write_text(json.dumps({"sweep": rows, "equal_time": et_rows}, indent=2) + "\n")
    print("\n".join(md))
    if args.summary_dir:
        import shutil
        args.summary_dir.mkdir(parents=True, exist_ok=True)
        shutil.copy(out / "convergence.png", args.summary_dir / f"{name}_convergence.png")
        if et_rows:
            shutil.copy(out / "equal_time.png", args.summary_dir / f"{name}_equal_time.png")
        shutil.copy(out / "summary.md", args.summary_dir / f"{name}_summary.md")
    log(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
