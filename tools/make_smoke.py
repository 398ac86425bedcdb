#!/usr/bin/env python3
"""Procedural density grids for the heterogeneous-medium scenes (issue 15).

Writes three Mitsuba 3 binary `.vol` grids into scenes/volumes/, one channel
of float32 density in [0, 1], deterministic from fixed seeds:

  plume.vol   56 x 96 x 56   a smoke plume (scenes/smoke_cornell.xml): a
              rising column, dense at the floor, widening and thinning
              upward, swaying a little, broken up by fractal value noise
              stretched along the direction it rises;
  cloud.vol   84 x 56 x 84   a cumulus-like cloud (scenes/cloud.xml): the
              union of seven noise-perturbed spheres with a soft edge and a
              flattened base;
  haze.vol    64 x 64 x 64   a thin, patchy smoke layer (scenes/smoke_caustic.xml)
              filling the whole box: fractal noise, densest near the floor
              and thinning upward, never quite empty.

Grid x, y, z are the scene's x, y, z: each scene's gridvolume `to_world` maps
the unit cube [0, 1]^3 onto its box (the bbox stored in the file is the unit
cube, so `use_grid_bbox` would give the same box as no to_world at all).

The format (Mitsuba's VolumeGrid, written here by `write_vol`, little
endian): the bytes 'VOL', the version byte 3, int32 encoding 1 (float32),
int32 xres, yres, zres, int32 channels, 6 float32 bbox xmin ymin zmin xmax
ymax zmax, then the float32 data indexed ((z*yres + y)*xres + x)*channels + c.
After writing, every file is read back with Mitsuba 3 itself (mi.VolumeGrid
in scalar_rgb, and a gridvolume with use_grid_bbox for the bbox) and checked
to hold exactly these numbers, bit for bit, with this size, channel count,
maximum and bbox: Mitsuba 3.9.1 reads all three identically.

Determinism: the random numbers come from numpy's legacy RandomState (whose
stream numpy keeps fixed across versions), and the density is computed with
float64 +, -, *, / and sqrt only (IEEE exact: no library transcendentals,
and no reduction but a max, which is exact in any order), then rounded to
float32, so the files regenerate bit-identically (checked here with numpy
2.4.6: --check compares the files on disk with freshly generated ones, and
with Mitsuba's reading of them, and writes nothing).

Regenerate, from the repository's top directory, with the venv that
tools/reference.py makes (BUILD/venv-mitsuba, which has numpy and Mitsuba;
here /work/main/build/venv-mitsuba):

  build/venv-mitsuba/bin/python tools/make_smoke.py          # write, then check with Mitsuba
  build/venv-mitsuba/bin/python tools/make_smoke.py --check  # check only
  build/venv-mitsuba/bin/python tools/make_smoke.py --stats  # optical depths per unit scale
"""
from __future__ import annotations

import argparse
import hashlib
import struct
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
OUT_DIR = REPO / "scenes" / "volumes"


# --------------------------------------------------------------------------
# The .vol format


def vol_bytes(density: np.ndarray, bbox=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))) -> bytes:
    """`density` indexed [z, y, x] (one channel) or [z, y, x, c]."""
    d = np.asarray(density, dtype="<f4")
    if d.ndim == 3:
        d = d[..., None]
    zres, yres, xres, channels = d.shape
    header = b"VOL" + bytes([3]) + struct.pack("<iiiii", 1, xres, yres, zres, channels)
    header += struct.pack("<6f", *bbox[0], *bbox[1])
    return header + np.ascontiguousarray(d).tobytes(order="C")


def write_vol(path: Path, density: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(vol_bytes(density))


def read_vol(path: Path):
    """(data [z, y, x, c] float32, bbox) from our own reader, for --stats."""
    raw = Path(path).read_bytes()
    if raw[:3] != b"VOL" or raw[3] != 3:
        raise ValueError(f"{path}: not a version 3 .vol file")
    enc, xres, yres, zres, ch = struct.unpack("<iiiii", raw[4:24])
    if enc != 1:
        raise ValueError(f"{path}: encoding {enc}, expected 1 (float32)")
    bbox = struct.unpack("<6f", raw[24:48])
    data = np.frombuffer(raw, dtype="<f4", offset=48).reshape(zres, yres, xres, ch)
    return data, bbox


# --------------------------------------------------------------------------
# Noise (float64 arithmetic only)


def _smooth(f):
    return f * f * f * (f * (f * 6.0 - 15.0) + 10.0)  # quintic fade, C2


def value_noise(x, y, z, rng: np.random.RandomState, cells: float):
    """Smooth value noise in [0, 1] at points (x, y, z) in [0, 1]-ish: a
    lattice of `cells` cells per unit with uniform random values, blended with
    a quintic fade. The lattice covers [-1, 2] in each axis (warped coordinates
    may leave the unit cube)."""
    n = int(3 * cells) + 3
    lattice = rng.random_sample((n, n, n))
    u = (x + 1.0) * cells
    v = (y + 1.0) * cells
    w = (z + 1.0) * cells
    i = np.clip(np.floor(u), 0, n - 2).astype(np.int64)
    j = np.clip(np.floor(v), 0, n - 2).astype(np.int64)
    k = np.clip(np.floor(w), 0, n - 2).astype(np.int64)
    fu, fv, fw = _smooth(u - i), _smooth(v - j), _smooth(w - k)
    out = 0.0
    for di in (0, 1):
        wu = fu if di else 1.0 - fu
        for dj in (0, 1):
            wv = fv if dj else 1.0 - fv
            for dk in (0, 1):
                ww = fw if dk else 1.0 - fw
                out = out + wu * wv * ww * lattice[i + di, j + dj, k + dk]
    return out


def fbm(x, y, z, rng, cells: float, octaves: int, gain: float = 0.5):
    """Fractal sum of `octaves` octaves of value noise, each twice the
    frequency and `gain` times the amplitude of the last, normalised to
    [0, 1] (mean 0.5)."""
    total = 0.0
    amp = 1.0
    norm = 0.0
    for o in range(octaves):
        total = total + amp * value_noise(x, y, z, rng, cells * (2 ** o))
        norm += amp
        amp *= gain
    return total / norm


def smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def grid_points(xres, yres, zres, size):
    """Voxel centres, arrays indexed [z, y, x], in world units relative to the
    box's minimum corner (size = the box's extent in x, y, z), and the same
    points divided by the box's largest extent (isotropic noise coordinates)."""
    sx, sy, sz = size
    x = (np.arange(xres, dtype=np.float64) + 0.5) / xres * sx
    y = (np.arange(yres, dtype=np.float64) + 0.5) / yres * sy
    z = (np.arange(zres, dtype=np.float64) + 0.5) / zres * sz
    Z, Y, X = np.meshgrid(z, y, x, indexing="ij")
    s = float(max(size))
    return X, Y, Z, X / s, Y / s, Z / s


# --------------------------------------------------------------------------
# The grids. Each returns density [z, y, x] in [0, 1]; BOXES gives the world
# box each scene maps it onto (for --stats only: the scenes hold the boxes).

BOXES = {
    # scenes/smoke_cornell.xml: x, z in [-25, 25], y in [0.25, 80.25]
    "plume": ((-25.0, 0.25, -25.0), (25.0, 80.25, 25.0)),
    # scenes/cloud.xml
    "cloud": ((-30.0, 10.0, -30.0), (30.0, 50.0, 30.0)),
    # scenes/smoke_caustic.xml: the fog box of caustic_area.xml
    "haze": ((-55.0, -2.0, -55.0), (55.0, 102.0, 55.0)),
}


def plume():
    rng = np.random.RandomState(15001)
    X, Y, Z, x, y, z = grid_points(56, 96, 56, (50.0, 80.0, 50.0))
    t = Y / 80.0  # height, 0 at the floor, 1 at the top of the box
    # The column's axis sways with height (polynomials, no trig).
    cx = 25.0 + 5.0 * t * t - 2.0 * t
    cz = 25.0 - 3.5 * t * t * t + 1.0 * t
    # Warp the horizontal coordinates with low-frequency noise: curls that
    # grow with height.
    wx = fbm(x, y * 0.5, z, rng, 3.0, 4) - 0.5
    wz = fbm(x, y * 0.5, z, rng, 3.0, 4) - 0.5
    dx = X - cx + wx * (3.0 + 40.0 * t)
    dz = Z - cz + wz * (3.0 + 40.0 * t)
    r = np.sqrt(dx * dx + dz * dz)
    radius = 5.0 + 16.0 * t  # widening upward
    q = np.clip(1.0 - (r / radius) * (r / radius), 0.0, 1.0)
    profile = q * np.sqrt(q)
    # Denser at the bottom, thinning upward (as the column widens, roughly
    # conserving the smoke per height), fading out at the top.
    amp = np.sqrt(1.0 - t) * (1.0 - 0.4 * t)
    # Fractal detail, stretched upward (sampled at half the vertical rate)
    # and more broken-up higher up.
    n = fbm(x, y * 0.55, z, rng, 6.0, 4)
    contrast = 2.5 + 3.0 * t
    detail = np.clip(0.5 + (n - 0.5) * contrast, 0.0, 1.0)
    detail = 0.2 + 0.8 * detail
    d = profile * amp * detail
    return d / d.max()  # max 1 (a max is exact, whatever the order)


def cloud():
    rng = np.random.RandomState(15002)
    X, Y, Z, x, y, z = grid_points(84, 56, 84, (60.0, 40.0, 60.0))
    # Sphere centres (box-relative world units) and radii: a central tower,
    # a shoulder on each side and smaller puffs.
    spheres = [
        (30.0, 15.0, 30.0, 12.0),
        (30.0, 23.0, 28.0, 8.5),
        (18.0, 12.0, 32.0, 9.0),
        (42.0, 12.5, 27.0, 9.5),
        (24.0, 11.0, 20.0, 7.0),
        (37.0, 10.5, 40.0, 7.5),
        (10.0, 9.0, 30.0, 5.5),
    ]
    sd = None  # signed distance to the union of the spheres
    for cx, cy, cz, r in spheres:
        dx, dy, dz = X - cx, Y - cy, Z - cz
        d = np.sqrt(dx * dx + dy * dy + dz * dz) - r
        sd = d if sd is None else np.minimum(sd, d)
    # Billowy surface: push the distance in and out with fractal noise.
    n = fbm(x, y, z, rng, 5.0, 5)
    sd = sd - (n - 0.5) * 20.0
    edge = smoothstep(1.5, -2.5, sd)  # soft edge about 4 units wide
    base = smoothstep(3.0, 7.0, Y)  # flattened base
    inner = 0.65 + 0.35 * fbm(x, y, z, rng, 10.0, 3)
    return np.clip(edge * base * inner, 0.0, 1.0)


def haze():
    rng = np.random.RandomState(15003)
    X, Y, Z, x, y, z = grid_points(64, 64, 64, (110.0, 104.0, 110.0))
    h = Y / 104.0
    n = fbm(x, y * 1.6, z, rng, 4.0, 5)  # flattened: layered wisps
    patches = smoothstep(0.38, 0.62, n)
    layer = 0.15 + 0.85 * (1.0 - smoothstep(0.2, 0.7, h))  # densest low down
    return np.clip((0.05 + 0.95 * patches) * layer, 0.0, 1.0)


GRIDS = {"plume": plume, "cloud": cloud, "haze": haze}


# --------------------------------------------------------------------------


def check_with_mitsuba(path: Path, density: np.ndarray) -> None:
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    grid = mi.VolumeGrid(str(path))
    zres, yres, xres = density.shape
    got = np.array(grid)  # [z, y, x] for one channel
    want = np.asarray(density, dtype=np.float32)
    if tuple(int(v) for v in grid.size()) != (xres, yres, zres) or grid.channel_count() != 1:
        raise SystemExit(f"{path}: Mitsuba reads size {grid.size()} x {grid.channel_count()} channels")
    if got.shape != want.shape or got.tobytes() != want.tobytes():
        raise SystemExit(f"{path}: Mitsuba reads other numbers than were written")
    if grid.max() != float(want.max()):
        raise SystemExit(f"{path}: Mitsuba's max {grid.max()} != {want.max()}")
    vol = mi.load_dict({"type": "gridvolume", "filename": str(path), "use_grid_bbox": True})
    bb = vol.bbox()
    if list(bb.min) != [0, 0, 0] or list(bb.max) != [1, 1, 1]:
        raise SystemExit(f"{path}: Mitsuba's bbox {bb}")


def stats(name: str, d: np.ndarray) -> str:
    """Optical depth per unit `scale` along a few lines through the grid
    (trapezoid sums of voxel-centre densities times the voxel length)."""
    lo, hi = BOXES[name]
    zres, yres, xres = d.shape
    vx = (hi[0] - lo[0]) / xres
    vy = (hi[1] - lo[1]) / yres
    lines = [f"{name}: {xres}x{yres}x{zres}, box {lo}..{hi}, mean {d.mean():.4f}, max {d.max():.4f}"]
    vz = (hi[2] - lo[2]) / zres
    if name == "plume":
        for frac in (0.05, 0.2, 0.4, 0.6, 0.8):
            j = int(frac * yres)
            row = d[:, j, :]  # [z, x]
            # the densest lines at this height (through the core)
            lines.append(f"  height {lo[1] + (j + 0.5) * vy:5.1f}: max tau/scale along z {row.sum(axis=0).max() * vz:5.2f}, "
                         f"along x {row.sum(axis=1).max() * vx:5.2f}, densest voxel {row.max():.3f}")
        lines.append(f"  max tau/scale vertically {d.sum(axis=1).max() * vy:.2f}")
    elif name == "cloud":
        lines.append(f"  max tau/scale along x {d.sum(axis=2).max() * vx:.2f}, "
                     f"along y {d.sum(axis=1).max() * vy:.2f}, along z {d.sum(axis=0).max() * vz:.2f}; "
                     f"through the centre along x {d[zres // 2, yres // 2 - 4, :].sum() * vx:.2f}, "
                     f"along z {d[:, yres // 2 - 4, xres // 2].sum() * vz:.2f}")
    elif name == "haze":
        for frac in (0.05, 0.2, 0.4, 0.7, 0.95):
            j = int(frac * yres)
            lines.append(f"  height {lo[1] + (j + 0.5) * vy:5.1f}: mean density {d[:, j, :].mean():.3f}")
        lines.append(f"  mean tau/scale along x {d.sum(axis=2).mean() * vx:.2f}, "
                     f"along y {d.sum(axis=1).mean() * vy:.2f}")
    return "\n".join(lines)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--check", action="store_true",
                   help="write nothing; check the files on disk against fresh ones and Mitsuba's reading")
    p.add_argument("--stats", action="store_true", help="print optical depths per unit scale")
    p.add_argument("--out", type=Path, default=OUT_DIR, help="output folder (default: %(default)s)")
    args = p.parse_args()
    for name, make in GRIDS.items():
        d = make().astype(np.float32)
        path = args.out / f"{name}.vol"
        data = vol_bytes(d)
        if args.check:
            if not path.exists() or path.read_bytes() != data:
                raise SystemExit(f"{path}: differs from what this script generates")
        elif not args.stats:
            write_vol(path, d)
        if not args.stats:
            check_with_mitsuba(path, d)
            print(f"{path.relative_to(REPO) if path.is_relative_to(REPO) else path}: "
                  f"{d.shape[2]}x{d.shape[1]}x{d.shape[0]}, {len(data)} bytes, "
                  f"sha256 {hashlib.sha256(data).hexdigest()[:16]}..., Mitsuba reads it identically")
        else:
            print(stats(name, d))
    return 0


if __name__ == "__main__":
    sys.exit(main())
