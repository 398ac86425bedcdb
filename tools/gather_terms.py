#!/usr/bin/env python3
"""Where a render's error and the gather's time go, term by term.

The gather computes each of its terms (render/terms.h: emission, direct,
inscatter, volume, surface, gather_volume, gather_direct, gather_surface)
only when `spm render --terms` asks for it, and the terms add up to the
whole image. For every term this tool renders the term alone with two
seeds and the whole image without it, all at the same pass count, and
tabulates:

- variance: the relMSE-weighted mean of (a - b)^2 / 2 between the two
  seeds' images of the term alone (weights 1 / (ref^2 + 1e-2), as
  tools/compare.py's relMSE), the term's part of a render's variance;
- share: the term's part of the image's mean;
- cost: the gather kernel's milliseconds per pass with every term, less
  those without this one.

Example (docs/experiments/gather.md "Single scattering along the gather rays"):
  tools/gather_terms.py scenes/cornell_fog.xml --reference tests/data/reference/cornell_fog.exr \\
      -D res=64 --spm-arg=--bounces=-1 --spm-arg=--associated=4 --spm-arg=--streams=10000 \\
      --spm-arg=--spp=6 --passes 30
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import convergence  # noqa: E402
import reference  # noqa: E402

TERMS = ["emission", "direct", "inscatter", "volume", "surface", "gather_volume", "gather_direct", "gather_surface"]


def render(spm, args, res, terms, seed, out):
    """One render of `terms` (a list), and the gather kernel's ms per pass."""
    prof = out.with_suffix(".json")
    extra = ["--terms", ",".join(terms), "--profile-json", str(prof)] + args.spm_arg
    convergence.run_spm(spm, args.scene, out, res, args.passes, args.estimator, seed, args.defines, extra,
                        lambda *a: None)
    j = json.loads(prof.read_text())
    return j["kernels"]["gather"]["total_ms"] / max(1, j["passes"])


def main() -> int:
    reference.reexec_in_venv(os.path.abspath(__file__))
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    convergence.add_spm_arguments(p, "scene default override, passed to spm (repeatable)")
    p.add_argument("--passes", type=int, default=30, help="passes of every render (default %(default)s)")
    p.add_argument("--seeds", default="1,2", help="the two seeds (default %(default)s)")
    p.add_argument("--estimator", default="bre", help="volume estimate (default %(default)s)")
    p.add_argument("--out", type=Path, help="also write the markdown table here")
    args = p.parse_args()
    import numpy as np
    import compare
    seeds = [int(s) for s in args.seeds.split(",")]
    if len(seeds) != 2:
        raise SystemExit("gather_terms: --seeds takes two seeds")
    spm = args.spm or args.build_dir / "spm"
    ref = compare.load_exr(args.reference)
    res = (ref.shape[1], ref.shape[0])
    weight = 1.0 / (ref * ref + compare.EPSILON)
    with tempfile.TemporaryDirectory() as tmp:
        def pair(terms, name):
            imgs, ms = [], []
            for s in seeds:
                out = Path(tmp) / f"{name}_{s}.exr"
                ms.append(render(spm, args, res, terms, s, out))
                imgs.append(compare.load_exr(out))
            a, b = imgs
            return {"variance": float(np.mean((a - b) ** 2 / 2 * weight)),
                    "share": float((a + b).mean() / 2 / ref.mean()), "ms": min(ms)}

        whole = pair(TERMS, "all")
        rows = []
        for t in TERMS:
            alone = pair([t], t)
            without = render(spm, args, res, [u for u in TERMS if u != t], seeds[0], Path(tmp) / f"no_{t}.exr")
            rows.append((t, alone["variance"], alone["share"], whole["ms"] - without))
    lines = [f"`{args.scene}`, {args.passes} passes, seeds {seeds[0]} and {seeds[1]}, spm arguments "
             f"`{' '.join(args.spm_arg) or '(none)'}`; the whole image: variance {whole['variance']:.3g}, "
             f"share {whole['share']:.3f}, gather {whole['ms']:.1f} ms per pass",
             "", "| term | variance | share of the mean | gather ms per pass it costs |", "|---|---|---|---|"]
    lines += [f"| {t} | {v:.3g} | {100 * s:.1f}% | {c:.1f} |" for t, v, s, c in rows]
    text = "\n".join(lines) + "\n"
    print(text, end="")
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
