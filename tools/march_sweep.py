#!/usr/bin/env python3
"""The paper's ray-marching step against delta tracking in a heterogeneous
medium (METHOD.md 12): for each step (0 is delta and ratio tracking), spm
renders the scene with the same passes and seeds; the table gives the
render time, the image mean against the reference's (the step's bias: the
mean is what noise hardly moves) and the relMSE.

A finite step takes sigma_t at each step's midpoint and places an event by
the exponential of that constant within the step, so its bias shrinks with
the step (tests: Heterogeneous.RayMarchingBiasShrinksWithTheStep).

Example (docs/experiments/heterogeneous.md "Smoke and clouds"):
  tools/march_sweep.py scenes/smoke_cornell.xml \\
      --reference tests/data/reference/smoke_cornell.exr --steps 0,8,4,2,1,0.5 --passes 4 --seeds 1,2
"""
from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

RE_PASSES = re.compile(r"\((\d+) passes in ([0-9.]+) s")
RE_RELMSE = re.compile(r"relMSE\s+([0-9.eE+-]+)")
RE_MEAN = re.compile(r"mean\s+image\s+([0-9.eE+-]+) ([0-9.eE+-]+) ([0-9.eE+-]+)\s+ref\s+([0-9.eE+-]+) "
                     r"([0-9.eE+-]+) ([0-9.eE+-]+)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--reference", required=True)
    ap.add_argument("--steps", default="0,8,4,2,1,0.5", help="march_step values; 0: delta tracking")
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--seeds", default="1,2")
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--spm", default=str(Path(__file__).resolve().parent.parent / "build" / "spm"))
    a = ap.parse_args()
    steps = [float(s) for s in a.steps.split(",")]
    seeds = [int(s) for s in a.seeds.split(",")]
    print(f"| march_step | seconds per pass | image mean / reference mean | relMSE after {a.passes} passes |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for step in steps:
            seconds, ratios, errors = [], [], []
            for seed in seeds:
                out = Path(tmp) / f"s{step}_{seed}.exr"
                r = subprocess.run([a.spm, "render", a.scene, "-o", str(out), "-D", f"res={a.res}", "--passes",
                                    str(a.passes), "--seed", str(seed), "--march-step", f"{step:g}"],
                                   capture_output=True, text=True)
                m = RE_PASSES.search(r.stderr)
                if r.returncode != 0 or not m:
                    sys.stderr.write(r.stderr)
                    return 1
                seconds.append(float(m.group(2)) / int(m.group(1)))
                c = subprocess.run([a.spm, "compare", str(out), a.reference], capture_output=True, text=True)
                mm = RE_MEAN.search(c.stdout.replace("\n", " "))
                me = RE_RELMSE.search(c.stdout)
                if c.returncode != 0 or not mm or not me:
                    sys.stderr.write(c.stdout + c.stderr)
                    return 1
                v = [float(x) for x in mm.groups()]
                ratios.append(sum(v[:3]) / sum(v[3:]))
                errors.append(float(me.group(1)))
            label = "0 (delta, ratio tracking)" if step == 0 else f"{step:g}"
            print(f"| {label} | {statistics.median(seconds):.2f} | {statistics.mean(ratios):.4f} | "
                  f"{statistics.mean(errors):.5f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
