#!/usr/bin/env python3
"""Draws PNG plots from `spm bench --json FILE`.

  per-kernel device time per case (stacked bars), wavefront occupancy (live
  streams per iteration), and scaling curves (stage times against streams at
  10 associated photons, and against associated photons at 10,000 streams).

Needs matplotlib (Debian: apt-get install -y python3-matplotlib).
Usage: tools/plot_bench.py BENCH.json OUT_DIR
"""
import argparse
import json
import os
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bench_json")
    parser.add_argument("out_dir")
    args = parser.parse_args()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        sys.exit("plot_bench.py: matplotlib is missing (Debian: apt-get install -y python3-matplotlib)")
    with open(args.bench_json) as f:
        bench = json.load(f)
    cases = bench["cases"]
    os.makedirs(args.out_dir, exist_ok=True)

    # Per-kernel device time, stacked per case; transfers ("upload film",
    # "download volume", ...) in one bar segment each way.
    def group(label):
        return label.split(" ", 1)[0]

    grouped = []
    for c in cases:
        ms = {}
        for label, value in c["kernel_ms"].items():
            ms[group(label)] = ms.get(group(label), 0.0) + value
        grouped.append(ms)
    labels = sorted({k for ms in grouped for k in ms})
    fig, ax = plt.subplots(figsize=(8, 4.5))
    bottom = [0.0] * len(cases)
    for label in labels:
        values = [ms.get(label, 0.0) for ms in grouped]
        ax.bar([c["name"] for c in cases], values, bottom=bottom, label=label)
        bottom = [b + v for b, v in zip(bottom, values)]
    ax.set_ylabel("device time per pass, ms (median)")
    ax.set_title("Per-kernel device time, %dx%d, %d spp" % (bench["resolution"], bench["resolution"], bench["spp"]))
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out_dir, "kernels.png"), dpi=100)

    # Wavefront occupancy: live streams at the start of each iteration.
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for c in cases:
        live = c["live_per_iteration"]
        ax.plot(range(len(live)), [v / live[0] for v in live], marker="o", label=c["name"])
    ax.set_xlabel("wavefront iteration")
    ax.set_ylabel("live streams / streams emitted")
    ax.set_title("Wavefront occupancy")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(args.out_dir, "occupancy.png"), dpi=100)

    # Scaling curves.
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.5))
    for axis, key, fixed_key, fixed, title in (
        (left, "streams", "associated", 10, "streams (10 associated photons)"),
        (right, "associated", "streams", 10000, "associated photons (10,000 streams)"),
    ):
        sel = sorted((c for c in cases if c[fixed_key] == fixed), key=lambda c: c[key])
        xs = [c[key] for c in sel]
        for stage in ("propagate_s", "grid_s", "gather_s", "total_s"):
            axis.plot(xs, [c[stage] for c in sel], marker="o", label=stage[:-2])
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel(title)
        axis.set_ylabel("seconds per pass (median)")
        axis.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(args.out_dir, "scaling.png"), dpi=100)
    print("wrote kernels.png, occupancy.png, scaling.png in " + args.out_dir)


if __name__ == "__main__":
    main()
