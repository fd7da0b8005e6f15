#!/usr/bin/env python3
"""Vector against scalar shading on every scene in scenes/: CPU time of
interleaved single-thread renders (median and range of the per-pair ratios)
and the vector render's lane shares from --stats-json. Prints a Markdown table.

    scripts/shading_table.py [--snell BIN] [--reps 5] [--width 160 --height 120 --spp 16]
"""
import argparse
import glob
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile


def render(snell, scene, shading, args, out_dir):
    stats = os.path.join(out_dir, "stats.json")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(
        [snell, "render", scene, "-o", os.path.join(out_dir, "out.exr"),
         "--width", str(args.width), "--height", str(args.height), "--spp", str(args.spp),
         "--threads", "1", "--shading", shading, "--quiet", "--stats-json", stats],
        check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(stats) as f:
        st = json.load(f)
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, st


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--snell", default="target/release/snell")
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--width", type=int, default=160)
    p.add_argument("--height", type=int, default=120)
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--scenes", nargs="*", help="scene files (default: every scenes/*.toml)")
    args = p.parse_args()
    scenes = args.scenes or sorted(glob.glob("scenes/*.toml"))
    print(f"{args.width}x{args.height}x{args.spp}, 1 thread, {args.reps} interleaved pairs, CPU time")
    print()
    print("| scene | shade_lane_share | packet_lane_share | vector s | scalar s | scalar/vector (min-max) |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            name = os.path.basename(scene)[:-5]
            times = {"vector": [], "scalar": []}
            share = None
            for _ in range(args.reps):
                for shading in ("vector", "scalar"):
                    t, st = render(args.snell, scene, shading, args, tmp)
                    times[shading].append(t)
                    if shading == "vector":
                        share = st
            ratios = [s / v for v, s in zip(times["vector"], times["scalar"]) if v > 0]
            print(f"| {name} | {share.get('shade_lane_share', 0):.2f} | {share.get('packet_lane_share', 0):.2f} | "
                  f"{statistics.median(times['vector']):.3f} | {statistics.median(times['scalar']):.3f} | "
                  f"{statistics.median(ratios):.2f} ({min(ratios):.2f}-{max(ratios):.2f}) |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
