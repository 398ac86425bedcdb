#!/usr/bin/env python3
"""Check spm's grid_lookup (host/scene/volume_grid.h) against Mitsuba 3's
gridvolume.

Mitsuba (scalar_rgb, from the venv tools/reference.py makes under the build
directory) writes two small grids with VolumeGrid.write, one of 1 channel
and one of 3, and evaluates gridvolume on them, trilinear and nearest, at
points of every kind the lookup treats apart: random ones in
[-0.25, 1.25]^3, texel centres, cell borders and points just either side,
points within half a texel of a face, and points outside the cube, near and
far. The grids and the lookups go to OUT_DIR; the test
VolumeGrid.MatchesMitsubaGridvolume of the test binary then reads both with
read_vol and grid_lookup and prints the largest absolute differences, which
this script passes on.

OUT_DIR is a temporary directory unless --update makes it tests/data/volume,
the reference the test suite checks against without Mitsuba.

Examples:
  tools/check_gridvolume.py
  tools/check_gridvolume.py --build-dir /path/to/build-with-venv --spm-tests build/tests/spm_tests
  tools/check_gridvolume.py --update
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.dont_write_bytecode = True  # no tools/__pycache__ in the work tree
sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference  # noqa: E402  (the venv bootstrap)

REPO = reference.REPO
REFERENCE_DIR = REPO / "tests" / "data" / "volume"
# Sizes (x, y, z) with every axis different, so that a swapped axis shows.
GRIDS = {"grid1.vol": ((5, 4, 3), 1), "grid3.vol": ((3, 2, 4), 3)}


def points(rng, n):
    """float32 lookup points for a grid of n = (nx, ny, nz) texels."""
    import numpy as np
    n = np.array(n, dtype=np.float64)
    out = [rng.uniform(-0.25, 1.25, size=(120, 3))]
    # Texel centres, and points on and just either side of the cell borders
    # (texel edges, where nearest changes, and centres, where trilinear's
    # pair of texels does) along one axis at a time.
    cells = rng.integers(0, n.astype(int), size=(24, 3))
    out.append((cells + 0.5) / n)
    for axis in range(3):
        for offset in (0.0, 0.5):
            for eps in (-1e-4, 0.0, 1e-4):
                p = rng.uniform(0.0, 1.0, size=(8, 3))
                k = rng.integers(0, int(n[axis]) + 1, size=8)
                p[:, axis] = (k + offset) / n[axis] + eps
                out.append(p)
    # Within half a texel of a face, and outside the cube (just and far).
    for axis in range(3):
        p = rng.uniform(0.0, 1.0, size=(16, 3))
        h = 0.5 / n[axis]
        p[:8, axis] = rng.uniform(0.0, h, size=8)
        p[8:, axis] = rng.uniform(1.0 - h, 1.0, size=8)
        out.append(p)
        q = rng.uniform(0.0, 1.0, size=(12, 3))
        q[:, axis] = [-1e-3, -0.1, -0.7, -10.0, -1e6, 1.0 + 1e-3, 1.1, 1.7, 10.0, 1e6, 0.0, 1.0]
        out.append(q)
    out.append(rng.uniform(-2.0, 3.0, size=(20, 3)))  # outside along several axes at once
    return np.concatenate(out).astype(np.float32)


def write_reference(out_dir: Path) -> int:
    import mitsuba as mi
    import numpy as np
    mi.set_variant("scalar_rgb")
    rng = np.random.default_rng(15)
    out_dir.mkdir(parents=True, exist_ok=True)
    lines = [f"# grid filter x y z value(s): Mitsuba {mi.__version__} gridvolume (scalar_rgb, wrap_mode clamp), "
             "written by tools/check_gridvolume.py"]
    for name, ((nx, ny, nz), channels) in GRIDS.items():
        values = rng.uniform(0.0, 10.0, size=(nz, ny, nx, channels)).astype(np.float32)
        values.flat[::7] = 0.0
        mi.VolumeGrid(values).write(str(out_dir / name))
        pts = points(rng, (nx, ny, nz))
        for filter_type in ("trilinear", "nearest"):
            vol = mi.load_dict({"type": "gridvolume", "filename": str(out_dir / name), "filter_type": filter_type})
            it = mi.Interaction3f()
            for p in pts:
                it.p = mi.Point3f(*(float(c) for c in p))
                v = [vol.eval_1(it)] if channels == 1 else list(vol.eval_3(it))
                lines.append(" ".join([name, filter_type] + [f"{float(c):.9g}" for c in p] +
                                      [f"{float(c):.9g}" for c in v]))
    (out_dir / "lookups.txt").write_text("\n".join(lines) + "\n")
    return len(lines) - 1


def main() -> int:
    reference.reexec_in_venv(os.path.abspath(__file__))
    p = argparse.ArgumentParser(description="Compare spm's grid_lookup with Mitsuba 3's gridvolume and print the "
                                "largest absolute differences.",
                                epilog="Examples:" + __doc__.split("Examples:")[1],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--update", action="store_true",
                   help=f"write the grids and lookups to {REFERENCE_DIR.relative_to(REPO)} (the test's reference)")
    p.add_argument("--build-dir", type=Path, default=reference.default_build_dir(),
                   help="build directory holding venv-mitsuba (default: %(default)s)")
    p.add_argument("--spm-tests", type=Path, default=REPO / "build" / "tests" / "spm_tests",
                   help="the test binary (default: %(default)s)")
    args = p.parse_args()
    with tempfile.TemporaryDirectory(prefix="spm_gridvolume_") as tmp:
        out_dir = REFERENCE_DIR if args.update else Path(tmp)
        count = write_reference(out_dir)
        print(f"check_gridvolume.py: {count} Mitsuba lookups in {out_dir}")
        if not args.spm_tests.exists():
            print(f"check_gridvolume.py: no test binary {args.spm_tests} (build first: bash tools/setup.sh)",
                  file=sys.stderr)
            return 1
        env = dict(os.environ, SPM_GRIDVOLUME_REFERENCE=str(out_dir))
        run = subprocess.run([str(args.spm_tests), "--gtest_filter=VolumeGrid.MatchesMitsubaGridvolume"],
                             env=env, capture_output=True, text=True)
        for line in run.stdout.splitlines():
            if line.startswith("grid_lookup") or "FAILED" in line or "Failure" in line:
                print(line)
        if run.returncode != 0:
            print(run.stdout[-4000:], file=sys.stderr)
        return run.returncode


if __name__ == "__main__":
    sys.exit(main())
