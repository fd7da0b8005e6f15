"""Rays in gradient-index media (mirages, heat shimmer): many rays at once
through an unbounded index field, each traced as one ``snell grin-trace``
query (the same numbers), in parallel with the GIL released.

Fields are dicts as in a scene's ``[medium.field]``; see docs/grin.md::

    import numpy as np, snell
    road = {"kind": "hot_ground", "n_inf": 1.000293, "dn": 1.2e-4, "h0": 0.4}
    o = np.tile([0.0, 1.5, 0.0], (5, 1))
    d = np.stack([np.ones(5), -np.linspace(0.001, 0.01, 5), np.zeros(5)], axis=1)
    t = snell.grin.trace(road, o, d, length=200.0)
    t.end      # (5, 3) end points, metres
"""

from ._snell import GrinTrace, trace

__all__ = ["GrinTrace", "trace"]
