"""How bright the glass ball's caustic is as its index of refraction grows:
an IOR sweep, one render per index, the mean radiance of the floor below the
ball plotted against the index (matplotlib, when installed).

    python examples/python/ior_sweep.py [--quick] [--out DIR]
"""

import argparse
import pathlib

import numpy as np

import snell

SCENE = {
    "ambient_ior": 1.0,
    "camera": {"position": [0.0, 2.5, 4.0], "target": [0.0, 0.0, 0.0], "fov": 35.0},
    "film": {"width": 160, "height": 120, "spp": 64},
    "lights": [
        {
            "name": "sun",
            "type": "rect",
            "center": [0.0, 6.0, 0.0],
            "normal": [0.0, -1.0, 0.0],
            "u_axis": [1.0, 0.0, 0.0],
            "size": [0.5, 0.5],
            "radiance": [200.0, 200.0, 200.0],
        }
    ],
    "objects": [
        {
            "name": "floor",
            "shape": {"type": "rect", "center": [0, -1, 0], "normal": [0, 1, 0], "u_axis": [1, 0, 0], "size": [10, 10]},
            "material": {"type": "diffuse", "reflectance": [0.7, 0.7, 0.7]},
        },
        {
            "name": "ball",
            "shape": {"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 0.7},
            "material": {"type": "dielectric", "ior": 1.5},
        },
    ],
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a small, fast sweep")
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/ior_sweep"))
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    iors = np.linspace(1.0, 2.0, 3 if a.quick else 11)
    size = dict(width=48, height=36, spp=8) if a.quick else {}

    base = snell.load_dict(SCENE)
    means = []
    for ior in iors:
        image = snell.render(base.set("objects.ball.material.ior", float(ior)), **size)
        h, w, _ = image.shape
        # The floor just below the ball, where its caustic falls.
        spot = image[int(0.72 * h) : int(0.85 * h), int(0.4 * w) : int(0.6 * w)]
        means.append(float(spot.mean()))
        print(f"ior {ior:.2f}: mean radiance below the ball {means[-1]:.4f}")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (pip install matplotlib)")
        return
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(iors, means, "o-")
    ax.set_xlabel("index of refraction of the ball")
    ax.set_ylabel("mean radiance below the ball")
    fig.tight_layout()
    fig.savefig(a.out / "ior_sweep.png", dpi=120)
    print(f"plot in {a.out / 'ior_sweep.png'}")


if __name__ == "__main__":
    main()
