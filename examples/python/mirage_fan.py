"""A fan of rays over a hot road (the hot_ground field of
scenes/mirage_road.toml): rays aimed slightly down bend back up before they
reach the ground, which is the inferior mirage. Each ray is sampled along its
arc by tracing the whole fan to increasing lengths (one vectorised call per
length); prints where each ray turns and plots the fan (matplotlib, when
installed).

    python examples/python/mirage_fan.py [--quick] [--out DIR]
"""

import argparse
import pathlib

import numpy as np

import snell

ROAD = {"kind": "hot_ground", "n_inf": 1.000293, "dn": 0.00012, "h0": 0.4}
EYE_HEIGHT = 1.5  # metres


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer rays and samples")
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/mirage_fan"))
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    n, k = (7, 20) if a.quick else (25, 200)

    # Elevations from 0.2 degrees down to level.
    elev = np.radians(np.linspace(-0.2, 0.0, n))
    origins = np.tile([0.0, EYE_HEIGHT, 0.0], (n, 1))
    directions = np.column_stack([np.cos(elev), np.sin(elev), np.zeros(n)])
    lengths = np.linspace(0.0, 1500.0, k + 1)[1:]
    path = np.stack(
        [snell.grin.trace(ROAD, origins, directions, length=float(s), tolerance=1e-8).end for s in lengths],
        axis=1,
    )  # (rays, samples, 3)
    for i in range(n):
        low = path[i, :, 1].argmin()
        turned = 0 < low < k - 1
        print(
            f"elevation {np.degrees(elev[i]):+.3f} deg: lowest {path[i, low, 1]:.3f} m at x = {path[i, low, 0]:.0f} m"
            + (" (turns up: mirage)" if turned else "")
        )
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (pip install matplotlib)")
        return
    fig, ax = plt.subplots(figsize=(7, 3))
    for i in range(n):
        ax.plot(np.r_[0.0, path[i, :, 0]], np.r_[EYE_HEIGHT, path[i, :, 1]], lw=0.8)
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("distance, m")
    ax.set_ylabel("height, m")
    fig.tight_layout()
    fig.savefig(a.out / "mirage_fan.png", dpi=120)
    print(f"plot in {a.out / 'mirage_fan.png'}")


if __name__ == "__main__":
    main()
