"""Analytic refraction warps (Mukai et al.): where a vertex behind a glass
must move so that straight eye rays see it where refraction would. Applied to
(N, 3) vertex arrays in parallel with the GIL released; the images, families
and statuses are those of ``snell warp-points``.

Each result is a :class:`WarpImages`: flat arrays of images (``positions``,
``directions``, ``family``, ``refractions``, ``parity``) with, per vertex,
``counts``, ``offsets`` and ``status``::

    import numpy as np, snell
    v = np.array([[0.5, 0.0, -2.5], [0.0, 0.5, -4.0]])
    w = snell.warp.hollow_cylinder(v, eye=[0, 0, 4], axis_point=[0, 0, 0],
                                   axis_direction=[0, 1, 0], outer_radius=1.0,
                                   inner_radius=0.8, ior=1.5)
    first = w.positions[w.offsets[0]:w.offsets[1]]   # the images of vertex 0

For a mesh behind a plate, :func:`plate_positions` writes only the moved
float32 positions (into a reused array if given): the warp renderer's call.
"""

from ._snell import WarpImages, hollow_cylinder, plate, plate_positions

#: The names of ``WarpImages.family`` codes.
FAMILIES = tuple(WarpImages.FAMILIES)

__all__ = ["FAMILIES", "WarpImages", "hollow_cylinder", "plate", "plate_positions"]
