#!/usr/bin/env python3
"""The render's estimated relMSE (docs/METHOD.md 15) against the error its
committed Mitsuba 3 reference measures, scene by scene.

    tools/error_calibration.py [--passes 4,16] [--seeds 1,2] SCENE... [-- SPM_ARGS...]

Renders scenes/SCENE.xml at the reference's 64x64 with `build/spm render
--passes P --seed S --profile-json`, measures the image against
tests/data/reference/SCENE.exr with `build/spm compare`, and prints the
estimate (the profile's last `error_estimate`), its parts, the actual relMSE
and their ratio. Needs only the built spm (no Python packages)."""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPM = os.path.join(ROOT, "build", "spm")


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--passes", default="4,16")
    ap.add_argument("--seeds", default="1")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        image, profile = os.path.join(tmp, "x.exr"), os.path.join(tmp, "p.json")
        for scene in a.scenes:
            for seed in a.seeds.split(","):
                for passes in a.passes.split(","):
                    subprocess.run([SPM, "render", os.path.join(ROOT, "scenes", scene + ".xml"), "-o", image,
                                    "-D", "res=64", "--passes", passes, "--seed", seed, "--profile-json", profile]
                                   + extra, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    compared = subprocess.run([SPM, "compare", image,
                                               os.path.join(ROOT, "tests", "data", "reference", scene + ".exr")],
                                              check=True, capture_output=True, text=True).stdout
                    actual = float(re.search(r"relMSE\s+(\S+)", compared).group(1))
                    p = json.load(open(profile))
                    e = p["error_estimate"][-1]
                    host = p["host"]
                    print(f"{scene} seed {seed} passes {passes}: estimated {e['relmse']:.3e} "
                          f"(variance {e['variance']:.3e}, bias {e['bias']:.3e}), actual {actual:.3e}, "
                          f"ratio {e['relmse'] / actual:.2f}; gather {host.get('gather_s', 0):.2f} s, "
                          f"probe {host.get('probe_s', 0):.2f} s", flush=True)


if __name__ == "__main__":
    main()
