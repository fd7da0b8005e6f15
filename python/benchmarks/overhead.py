"""The binding's overhead, measured in one run with interleaved repetitions.

- A render through `snell.render_result` against `snell render` on the same
  scene and settings: per repetition the Python call's wall time over the
  CLI's render time (`wall_s` of --stats-json, the tiles), and the same for
  CPU time as a cross-check.
- The warps on NumPy arrays against the Rust bench (`benches/warp.rs
  --only solvers`) on the same grids: the plate on 1M float32 vertices
  written into a reused array, the tube on 316^2 vertices without parity.
  Rounds alternate the bench process and the Python calls.

    python python/benchmarks/overhead.py [--snell target/release/snell] [--warp-bench PATH] [--reps 7]

Both sides must be release builds (`make bench-python` builds them).
"""

import argparse
import json
import pathlib
import platform
import re
import statistics
import subprocess
import tempfile
import time

import numpy as np

import snell

ROOT = pathlib.Path(__file__).resolve().parents[2]


def spread(xs):
    """Median and range of a list, as text."""
    return f"{statistics.median(xs):.3f} (range {min(xs):.3f}-{max(xs):.3f}, n={len(xs)})"


def render_pair(binary, scene, size, threads, reps):
    w, h, spp = size
    s = snell.load_file(str(ROOT / "scenes" / scene))
    wall_ratio, cpu_ratio, cli_wall, py_wall = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        # One untimed round each: page cache, Embree's first build.
        snell.render_result(s, spp=1, width=w, height=h, threads=threads)
        for _ in range(reps):
            stats = pathlib.Path(tmp) / "st.json"
            subprocess.run(
                [binary, "render", str(ROOT / "scenes" / scene), "-o", f"{tmp}/x.exr", "--quiet",
                 "--width", str(w), "--height", str(h), "--spp", str(spp), "--threads", str(threads),
                 "--stats-json", str(stats)],
                check=True, capture_output=True,
            )
            st = json.loads(stats.read_text())
            t, c = time.perf_counter(), time.process_time()
            r = snell.render_result(s, spp=spp, width=w, height=h, threads=threads)
            pw, pc = time.perf_counter() - t, time.process_time() - c
            assert r.image.shape == (h, w, 3)
            cli_wall.append(st["wall_s"])
            py_wall.append(pw)
            wall_ratio.append(pw / st["wall_s"])
            cpu_ratio.append(pc / st["cpu_s"])
    print(f"render {scene} {w}x{h}x{spp}, {threads} threads, {reps} interleaved pairs:")
    print(f"  CLI render (wall_s)             {spread(cli_wall)} s")
    print(f"  Python snell.render_result call {spread(py_wall)} s")
    print(f"  Python / CLI, wall              {spread(wall_ratio)}")
    print(f"  Python / CLI, CPU               {spread(cpu_ratio)}")
    return statistics.median(wall_ratio)


def warp_bench_path():
    out = subprocess.run(
        ["cargo", "bench", "--bench", "warp", "--no-run", "--message-format=json"],
        cwd=ROOT, check=True, capture_output=True, text=True,
    ).stdout
    for line in out.splitlines():
        m = json.loads(line)
        if m.get("reason") == "compiler-artifact" and m.get("target", {}).get("name") == "warp" and m.get("executable"):
            return m["executable"]
    raise SystemExit("overhead.py: cargo did not name the warp bench's executable")


def rust_solvers(bench, reps):
    """Plate M vertices/s (batch, 2 threads) and tube ms per 100k vertices from one bench run."""
    out = subprocess.run([bench, "--bench", "--only", "solvers", "--reps", str(reps)],
                         cwd=ROOT, check=True, capture_output=True, text=True).stdout
    plate = re.search(r"batch \(4 f64 lanes\) 2 threads ([0-9.]+) M vertices/s", out)
    tube = re.search(r"reached ([0-9.]+) ms per 100k", out)
    if not plate or not tube:
        raise SystemExit(f"overhead.py: could not read the bench's figures from:\n{out}")
    return float(plate.group(1)), float(tube.group(1))


def median_s(f, reps):
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def warps(bench, rounds, reps):
    """The bench's grids (benches/warp.rs, `solvers`)."""
    n = 1000
    i = np.arange(n * n)
    grid = np.column_stack([-6.0 + 12.0 * (i % n) / n, -4.5 + 9.0 * (i // n) / n, np.full(n * n, -3.0)])
    grid32 = grid.astype(np.float32)
    out = np.empty_like(grid32)
    plate = ([0.0, 0.0, 4.0], [0.0, 0.0, 1.0], [0.2, -0.1, -1.0], 0.3, 1.5)
    m = 316
    i = np.arange(m * m)
    tube = np.column_stack([-6.0 + 12.0 * (i % m) / m, -4.5 + 9.0 * (i // m) / m, np.full(m * m, -3.0)])
    plate_ratio, tube_ratio, rs_plate, py_plate, rs_tube, py_tube = [], [], [], [], [], []
    for _ in range(rounds):
        rp, rt = rust_solvers(bench, reps)
        pp = len(grid32) / median_s(lambda: snell.warp.plate_positions(grid32, *plate, out=out), reps) / 1e6
        pt = median_s(
            lambda: snell.warp.hollow_cylinder(tube, [0, 0, 4], [0, 0, 0], [0, 1, 0], 1.0, 0.8, 1.5, parity=False),
            reps,
        ) * 1e5 / len(tube) * 1e3
        rs_plate.append(rp)
        py_plate.append(pp)
        rs_tube.append(rt)
        py_tube.append(pt)
        plate_ratio.append(pp / rp)
        tube_ratio.append(rt / pt)
    print(f"warps, {rounds} rounds alternating the Rust bench and Python, median of {reps} calls each:")
    print(f"  plate, 1M f32 vertices: Rust {spread(rs_plate)} M/s, Python plate_positions {spread(py_plate)} M/s")
    print(f"  plate Python / Rust throughput  {spread(plate_ratio)}")
    print(f"  tube, {len(tube)} vertices: Rust {spread(rs_tube)} ms/100k, Python hollow_cylinder {spread(py_tube)} ms/100k")
    print(f"  tube Python / Rust throughput   {spread(tube_ratio)}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snell", default=str(ROOT / "target" / "release" / "snell"))
    ap.add_argument("--warp-bench", help="the warp bench's executable (default: ask cargo)")
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--scene", default="glass_of_water_nested.toml")
    ap.add_argument("--size", default="320x240x16")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    version = subprocess.run([a.snell, "--version"], capture_output=True, text=True, check=True).stdout.strip()
    print(f"CLI: {version}")
    print(f"Python module: snell {snell.__version__} from {snell.__file__}, Python {platform.python_version()}")
    size = tuple(int(x) for x in a.size.split("x"))
    render_pair(a.snell, a.scene, size, a.threads, a.reps)
    warps(a.warp_bench or warp_bench_path(), a.rounds, a.reps)


if __name__ == "__main__":
    main()
