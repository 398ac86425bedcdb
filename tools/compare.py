#!/usr/bin/env python3
"""Compare an image with a reference: RMSE, relMSE, per-channel means, and a
false-colour error picture.

  relMSE = mean over pixels and channels of (a - b)^2 / (b^2 + eps), eps = 1e-2
  RMSE   = sqrt(mean (a - b)^2)

where b is the reference. Both images are 32-bit float RGB OpenEXR (read with
Mitsuba's Bitmap from the venv that tools/reference.py makes under the build
directory). --png writes three panels (image, reference, per-pixel relative
squared error on a log colour scale) and --diff-png a signed difference map.

Examples:
  tools/compare.py build/out/cornell_fog.exr tests/data/reference/cornell_fog.exr
  tools/compare.py a.exr ref.exr --png build/err.png --json build/err.json
  tools/compare.py a.exr tests/data/reference/caustic_area.exr --lights 100
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

sys.dont_write_bytecode = True  # no tools/__pycache__ in the work tree
sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference  # noqa: E402  (the venv bootstrap)

EPSILON = 1e-2


def load_exr(path):
    """An EXR as a float64 numpy array HxWx3 (alpha dropped)."""
    import mitsuba as mi
    import numpy as np
    if not mi.variant():
        mi.set_variant("scalar_rgb")
    bmp = mi.Bitmap(str(path))
    arr = np.array(bmp, dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[..., None]
    if arr.shape[2] == 1:
        arr = np.repeat(arr, 3, axis=2)
    return arr[..., :3]


def metrics(a, b, eps=EPSILON, mask=None):
    """Errors of image a against reference b (HxWx3); `mask` (HxW bool)
    restricts them to some pixels."""
    import numpy as np
    if a.shape != b.shape:
        raise SystemExit(f"compare: the images differ in size: {a.shape[1]}x{a.shape[0]} vs "
                         f"{b.shape[1]}x{b.shape[0]}")
    if mask is not None:
        a, b = a[mask], b[mask]
    d = a - b
    mean_a = [float(a[..., c].mean()) for c in range(3)]
    mean_b = [float(b[..., c].mean()) for c in range(3)]
    return {
        "rmse": float(np.sqrt(np.mean(d * d))),
        "relmse": float(np.mean(d * d / (b * b + eps))),
        "mean": mean_a,
        "mean_ref": mean_b,
        "mean_ratio": [ma / mb if mb != 0 else float("nan") for ma, mb in zip(mean_a, mean_b)],
        "mean_ratio_all": float(a.mean() / b.mean()) if b.mean() != 0 else float("nan"),
        "nonfinite": int(np.count_nonzero(~np.isfinite(a))),
    }


def light_masks(ref, factor):
    """The pixels that see a light directly, and the ring of pixels around
    them (HxW bool each): where the reference's mean over channels is over
    `factor` times its median, and those pixels' 8-neighbours that are not.
    A light a few pixels wide is its silhouette: each of its pixels sees its
    edge (issue 14 asks for silhouettes as clean as volpath's)."""
    import numpy as np
    lum = ref.mean(axis=2)
    light = lum > factor * np.median(lum)
    padded = np.pad(light, 1)
    h, w = light.shape
    ring = np.zeros_like(light)
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            ring |= padded[dy:dy + h, dx:dx + w]
    return light, ring & ~light


def _tonemap(img, scale):
    import numpy as np
    x = np.clip(img / scale, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def error_png(a, b, path, eps=EPSILON, titles=("image", "reference"), signed=False):
    """Three panels: a, b (same exposure: the reference's 99th percentile maps
    to white) and the per-pixel relMSE (mean over channels) on a log scale,
    or, with signed=True, the relative difference (a - b) / (|b| + sqrt(eps))
    of the luminance on a diverging scale."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    import numpy as np
    scale = max(float(np.percentile(b, 99)), 1e-6)
    fig, ax = plt.subplots(1, 3, figsize=(10.5, 3.6), dpi=80)
    ax[0].imshow(_tonemap(a, scale), interpolation="nearest")
    ax[1].imshow(_tonemap(b, scale), interpolation="nearest")
    ax[0].set_title(titles[0], fontsize=9)
    ax[1].set_title(titles[1], fontsize=9)
    if signed:
        la, lb = a.mean(axis=2), b.mean(axis=2)
        rel = (la - lb) / (np.abs(lb) + np.sqrt(eps))
        lim = max(float(np.percentile(np.abs(rel), 99)), 1e-3)
        im = ax[2].imshow(rel, cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest")
        ax[2].set_title("(a - b) / (|b| + 0.1), luminance", fontsize=9)
    else:
        e = ((a - b) ** 2 / (b * b + eps)).mean(axis=2)
        m = float(e.mean())
        lo = max(float(np.percentile(e, 1)), 1e-8)
        hi = max(float(e.max()), lo * 10)
        im = ax[2].imshow(np.clip(e, lo, None), cmap="inferno", norm=LogNorm(vmin=lo, vmax=hi),
                          interpolation="nearest")
        ax[2].set_title(f"per-pixel relMSE (mean {m:.3g})", fontsize=9)
    fig.colorbar(im, ax=ax[2], fraction=0.046, pad=0.04)
    for x in ax:
        x.set_xticks([])
        x.set_yticks([])
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def main() -> int:
    reference.reexec_in_venv(os.path.abspath(__file__))
    p = argparse.ArgumentParser(description="Errors of an EXR image against a reference EXR: RMSE, relMSE "
                                "(eps 1e-2), per-channel means, and a false-colour error PNG.",
                                epilog="Examples:" + __doc__.split("Examples:")[1],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("image", type=Path, help="the image to judge (EXR)")
    p.add_argument("reference", type=Path, help="the reference (EXR)")
    p.add_argument("--png", type=Path, help="false-colour picture: image, reference, per-pixel relMSE")
    p.add_argument("--diff-png", type=Path, help="the same with the signed relative difference")
    p.add_argument("--json", type=Path, help="write the numbers as JSON")
    p.add_argument("--eps", type=float, default=EPSILON, help="relMSE epsilon (default %(default)s)")
    p.add_argument("--lights", type=float, default=None, metavar="FACTOR",
                   help="also the errors over the pixels that see a light (the reference over FACTOR times its "
                        "median, e.g. 100) and over the ring of pixels around them")
    p.add_argument("--build-dir", type=Path, default=reference.default_build_dir(),
                   help="build directory holding venv-mitsuba (default: %(default)s)")
    args = p.parse_args()
    a, b = load_exr(args.image), load_exr(args.reference)
    m = metrics(a, b, args.eps)
    if args.lights is not None:
        light, ring = light_masks(b, args.lights)
        if not light.any():
            raise SystemExit(f"compare: no pixel of {args.reference} is over {args.lights:g} times its median")
        m["light_pixels"], m["ring_pixels"] = int(light.sum()), int(ring.sum())
        m["light_relmse"] = metrics(a, b, args.eps, light)["relmse"]
        m["ring_relmse"] = metrics(a, b, args.eps, ring)["relmse"] if ring.any() else float("nan")
    print(f"RMSE    {m['rmse']:.6g}")
    print(f"relMSE  {m['relmse']:.6g}  (eps {args.eps:g})")
    print("mean    image {:.6g} {:.6g} {:.6g}".format(*m["mean"]))
    print("        ref   {:.6g} {:.6g} {:.6g}".format(*m["mean_ref"]))
    print("        ratio {:.4f} {:.4f} {:.4f}  (all channels {:.4f})".format(*m["mean_ratio"], m["mean_ratio_all"]))
    if args.lights is not None:
        print(f"lights  relMSE {m['light_relmse']:.6g} over the {m['light_pixels']} pixels that see a light, "
              f"{m['ring_relmse']:.6g} over the {m['ring_pixels']} around them")
    if m["nonfinite"]:
        print(f"non-finite values in the image: {m['nonfinite']}")
    if args.png:
        error_png(a, b, args.png, args.eps, (args.image.name, args.reference.name))
    if args.diff_png:
        error_png(a, b, args.diff_png, args.eps, (args.image.name, args.reference.name), signed=True)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"image": str(args.image), "reference": str(args.reference),
                                         "eps": args.eps, **m}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
