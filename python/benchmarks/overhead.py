"""The binding's overhead, measured in one run with interleaved repetitions:
a render through `snell.render_result` against `snell render` on the same
scene and settings, and the warps on NumPy arrays (vertices per second, to
set beside `cargo bench --bench warp`'s solver figures on the same grids).

    python python/benchmarks/overhead.py [--snell target/release/snell] [--reps 5]
"""

import argparse
import json
import pathlib
import statistics
import subprocess
import tempfile
import time

import numpy as np

import snell

ROOT = pathlib.Path(__file__).resolve().parents[2]


def render_pair(binary, scene, size, threads, reps):
    w, h, spp = size
    s = snell.load_file(str(ROOT / "scenes" / scene))
    cli_render, cli_process, py_call, py_render = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(reps):
            stats = pathlib.Path(tmp) / "st.json"
            t = time.perf_counter()
            subprocess.run(
                [binary, "render", str(ROOT / "scenes" / scene), "-o", f"{tmp}/x.exr", "--quiet",
                 "--width", str(w), "--height", str(h), "--spp", str(spp), "--threads", str(threads),
                 "--stats-json", str(stats)],
                check=True, capture_output=True,
            )
            cli_process.append(time.perf_counter() - t)
            cli_render.append(json.loads(stats.read_text())["wall_s"])
            t = time.perf_counter()
            r = snell.render_result(s, spp=spp, width=w, height=h, threads=threads)
            py_call.append(time.perf_counter() - t)
            py_render.append(r.stats["wall_s"])
    m = statistics.median
    print(
        f"render {scene} {w}x{h}x{spp}, {threads} threads, median of {reps} interleaved:\n"
        f"  CLI: render {m(cli_render):.3f} s (whole process {m(cli_process):.3f} s)\n"
        f"  Python: snell.render_result call {m(py_call):.3f} s (the library's render inside it {m(py_render):.3f} s)\n"
        f"  Python call / CLI render = {m(py_call) / m(cli_render):.3f}"
    )


def _median_s(f, reps):
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def warps(reps):
    """The bench's grids (benches/warp.rs, `solvers`): a plate behind 1M
    float32 vertices, the tube behind 316² vertices."""
    n = 1000
    i = np.arange(n * n)
    grid32 = np.column_stack([-6.0 + 12.0 * (i % n) / n, -4.5 + 9.0 * (i // n) / n, np.full(n * n, -3.0)])
    grid32 = grid32.astype(np.float32)
    grid = grid32.astype(np.float64)
    plate = ([0.0, 0.0, 4.0], [0.0, 0.0, 1.0], [0.2, -0.1, -1.0], 0.3, 1.5)
    out = np.empty_like(grid32)
    for label, f in (
        ("plate_positions into a reused array (the bench's batch call)", lambda: snell.warp.plate_positions(grid32, *plate, out=out)),
        ("plate, every image (batch solver)", lambda: snell.warp.plate(grid, *plate)),
        ("plate, every image (scalar solver)", lambda: snell.warp.plate(grid, *plate, solver="scalar")),
    ):
        print(f"{label}, {len(grid)} vertices from NumPy: {len(grid) / _median_s(f, reps) / 1e6:.2f} M vertices/s")
    m = 316
    i = np.arange(m * m)
    tube = np.column_stack([-6.0 + 12.0 * (i % m) / m, -4.5 + 9.0 * (i // m) / m, np.full(m * m, -3.0)])
    for parity in (False, True):
        med = _median_s(
            lambda: snell.warp.hollow_cylinder(tube, [0, 0, 4], [0, 0, 0], [0, 1, 0], 1.0, 0.8, 1.5, parity=parity),
            reps,
        )
        print(f"tube (tables, parity={parity}), {len(tube)} vertices from NumPy: {med * 1e5 / len(tube) * 1e3:.1f} ms per 100k vertices")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snell", default=str(ROOT / "target" / "release" / "snell"))
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--scene", default="glass_of_water_nested.toml")
    ap.add_argument("--size", default="320x240x16")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    size = tuple(int(x) for x in a.size.split("x"))
    render_pair(a.snell, a.scene, size, a.threads, a.reps)
    warps(a.reps)


if __name__ == "__main__":
    main()
