#!/usr/bin/env python3
"""Equal time with every setting derived: shipped scenes in their Mitsuba
form (tools/mitsuba_form.py), rendered by one or more spm builds for the
same budget, runs alternating between the builds, each judged against the
committed Mitsuba 3 reference (64x64).

    tools/derived_ab.py [--time 10] [--seeds 1,2,3] [--spm build/spm ...] SCENE[:SECONDS]...

Prints one line per run (relMSE, passes, the radius the render used) and
per scene and build the median relMSE, and with two builds the median of
the per-seed ratio second/first. Needs only the built spm."""
import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from mitsuba_form import mitsuba_form  # noqa: E402


def relmse(spm, image, reference):
    out = subprocess.run([spm, "compare", image, reference], check=True, capture_output=True, text=True).stdout
    return float(re.search(r"relMSE\s+(\S+)", out).group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", help="NAME or NAME:SECONDS")
    ap.add_argument("--time", type=float, default=10.0)
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--spm", action="append", default=None, help="spm executables (default build/spm)")
    a = ap.parse_args()
    builds = a.spm or [os.path.join(ROOT, "build", "spm")]
    with tempfile.TemporaryDirectory() as tmp:
        for item in a.scenes:
            name, _, seconds = item.partition(":")
            seconds = seconds or str(a.time)
            scene = os.path.join(tmp, name + ".xml")
            with open(scene, "w") as f:
                f.write(mitsuba_form(os.path.join(ROOT, "scenes", name + ".xml")))
            reference = os.path.join(ROOT, "tests", "data", "reference", name + ".exr")
            errors = {b: [] for b in builds}
            for seed in a.seeds.split(","):
                for b in builds:
                    image = os.path.join(tmp, "x.exr")
                    run = subprocess.run([b, "render", scene, "-o", image, "-D", "res=64", "--time", seconds,
                                          "--seed", seed], check=True, capture_output=True, text=True)
                    e = relmse(builds[0], image, reference)
                    errors[b].append(e)
                    passes = re.search(r"\((\d+) passes in ([0-9.]+) s", run.stderr)
                    radius = re.search(r"radius ([0-9.e+-]+) \((derived|command line|scene)", run.stderr)
                    print(f"{name} {seconds} s seed {seed} {b}: relMSE {e:.3g}, {passes.group(1)} passes in "
                          f"{passes.group(2)} s, radius {radius.group(1)} ({radius.group(2)})", flush=True)
            line = ", ".join(f"{b} {statistics.median(v):.3g}" for b, v in errors.items())
            if len(builds) == 2:
                ratios = [y / x for x, y in zip(errors[builds[0]], errors[builds[1]])]
                line += f"; ratio median {statistics.median(ratios):.2f} ({min(ratios):.2f}-{max(ratios):.2f})"
            print(f"{name} {seconds} s medians: {line}", flush=True)


if __name__ == "__main__":
    main()
