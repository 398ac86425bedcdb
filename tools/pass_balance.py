#!/usr/bin/env python3
"""How a pass should split its time between photons and camera samples
(issue 14 item 3): relMSE at equal time against a Mitsuba reference, swept
over the camera samples per pass (--spp) and the photon streams per pass.

Every configuration renders with spm's own time budget (`--time B`: its
passes end within B), so a configuration with cheaper passes gets more of
them. Beside each run's relMSE the tool records, from `--profile-json`,
the share of the pass's time its gather took: the rule timed renders
follow (host/render/render.cpp, balanced_spp) is stated in that share,
which carries over to other resolutions and devices where a fixed sample
count would not.

Writes BALANCE.csv, a markdown table and a plot (relMSE against the
gather's share of the pass, one curve per stream count) to --out.

Example:
  tools/pass_balance.py scenes/fog_box.xml --reference tests/data/reference/fog_box.exr \\
      -D res=64 --budget 10 --spp 1,2,4,8,16 --streams 5000,10000,20000 --seeds 1,2
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import statistics
import sys
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import convergence  # noqa: E402
import reference  # noqa: E402


def run(spm, out, args, res, spp, streams, seed):
    """One render for the budget (convergence.run_spm), and its share of
    the gather from the profile."""
    prof = out.with_suffix(".json")
    extra = ["--spp", str(spp), "--streams", str(streams), "--profile-json", str(prof)] + args.spm_arg
    convergence.run_spm(spm, args.scene, out, res, 0, "bre", seed, args.defines, extra, lambda *a: None,
                        budget=args.budget)
    j = json.loads(prof.read_text())
    h = j["host"]
    busy = h["propagate_s"] + h["grid_s"] + h["gather_s"]
    return {"passes": j["passes"], "seconds": j["seconds"], "gather_share": h["gather_s"] / busy,
            "pass_s": j["seconds"] / max(1, j["passes"]), "radius": j["settings"]["radius"]}


def plot(rows, path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(8.4, 3.4), dpi=80)
    for streams in sorted({r["streams"] for r in rows}):
        rs = sorted((r for r in rows if r["streams"] == streams), key=lambda r: r["spp"])
        ax[0].semilogy([r["gather_share"] for r in rs], [r["relmse"] for r in rs], "o-", label=f"{streams} streams")
        ax[1].loglog([r["spp"] for r in rs], [r["relmse"] for r in rs], "o-", label=f"{streams} streams")
        for r in rs:
            ax[0].annotate(str(r["spp"]), (r["gather_share"], r["relmse"]), fontsize=6, xytext=(2, 2),
                           textcoords="offset points")
    ax[0].set_xlabel("gather's share of the pass (labels: spp per pass)")
    ax[1].set_xlabel("camera samples per pass")
    ax[1].xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    spps = sorted({r["spp"] for r in rows})
    ax[1].set_xticks(spps, [str(s) for s in spps])
    for a in ax:
        a.set_ylabel("relMSE (median of seeds)")
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    convergence.add_spm_arguments(p, "scene default override, passed to spm (repeatable)")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    p.add_argument("--budget", type=float, default=10.0, help="seconds per render (default %(default)s)")
    p.add_argument("--spp", default="1,2,4,8,16", help="camera samples per pass (default %(default)s)")
    p.add_argument("--streams", default="10000", help="photon streams per pass (default %(default)s)")
    p.add_argument("--seeds", default="1,2", help="seeds; the table gives the median (default %(default)s)")
    args = p.parse_args()
    import compare
    spm = args.spm or args.build_dir / "spm"
    args.out.mkdir(parents=True, exist_ok=True)
    ref = compare.load_exr(args.reference)
    res = (ref.shape[1], ref.shape[0])
    rows = []
    for streams in [int(x) for x in args.streams.split(",")]:
        for spp in [int(x) for x in args.spp.split(",")]:
            runs = []
            for seed in [int(x) for x in args.seeds.split(",")]:
                out = args.out / f"s{streams}_spp{spp}_seed{seed}.exr"
                r = run(spm, out, args, res, spp, streams, seed)
                r["relmse"] = compare.metrics(compare.load_exr(out), ref)["relmse"]
                runs.append(r)
                out.unlink()
                out.with_suffix(".png").unlink()
                out.with_suffix(".json").unlink()
            row = {"streams": streams, "spp": spp,
                   "relmse": statistics.median(r["relmse"] for r in runs),
                   "relmse_seeds": " ".join(f"{r['relmse']:.5g}" for r in runs),
                   "passes": statistics.median(r["passes"] for r in runs),
                   "pass_s": statistics.median(r["pass_s"] for r in runs),
                   "gather_share": statistics.median(r["gather_share"] for r in runs),
                   "radius": runs[0]["radius"]}
            print(f"pass_balance: {streams} streams, spp {spp}: relMSE {row['relmse']:.5g} "
                  f"({row['relmse_seeds']}), {row['passes']:g} passes, gather {100 * row['gather_share']:.0f}%",
                  flush=True)
            rows.append(row)
    fields = ["streams", "spp", "relmse", "relmse_seeds", "passes", "pass_s", "gather_share", "radius"]
    with open(args.out / "balance.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    name = args.scene.stem
    lines = [f"Pass balance, {name}, {args.budget:g} s each, seeds {args.seeds}, "
             f"{' '.join('-D ' + d for d in args.defines)} {' '.join(args.spm_arg)}".rstrip(), "",
             "| streams | spp per pass | relMSE (median) | seeds | passes | s per pass | gather share |",
             "|---|---|---|---|---|---|---|"]
    best = min(rows, key=lambda r: r["relmse"])
    for r in rows:
        mark = " **(best)**" if r is best else ""
        lines.append(f"| {r['streams']} | {r['spp']} | {r['relmse']:.5g}{mark} | {r['relmse_seeds']} | "
                     f"{r['passes']:g} | {r['pass_s']:.3f} | {100 * r['gather_share']:.0f}% |")
    (args.out / f"{name}_balance.md").write_text("\n".join(lines) + "\n")
    plot(rows, args.out / f"{name}_balance.png", f"{name}: relMSE at {args.budget:g} s")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    reference.reexec_in_venv(os.path.abspath(__file__))
    sys.exit(main())
