"""snell: a ray tracer on Intel Embree 3 for refraction that other renderers
get wrong or make slow: nested dielectrics with priorities, curved rays in
gradient-index media, and analytic refraction warps.

Load a scene (a file, a TOML string, or a dict with the scene format's keys),
render it to a NumPy array, trace single rays, and run the solvers on arrays::

    import snell
    scene = snell.load_file("scenes/three_spheres.toml")
    image = snell.render(scene, spp=4)          # float32 (480, 640, 3), linear
    snell.write("out.exr", image)

    wetter = scene.set("objects.water.material.ior", 1.34)   # as --set

Units are metres and radiance (linear RGB, no tone mapping); row 0 of an
image is its top. Scene errors raise :class:`SceneError` (a ``ValueError``)
naming the file, the key path and, for text, the line and column.

Submodules: :mod:`snell.grin` (rays in gradient-index fields),
:mod:`snell.warp` (refraction warps of vertex arrays).
"""

from ._snell import (
    RenderResult,
    Scene,
    SceneError,
    __version__,
    load_dict,
    load_file,
    load_string,
    read,
    render,
    render_result,
    trace_path,
    write,
)
from . import grin, warp

__all__ = [
    "RenderResult",
    "Scene",
    "SceneError",
    "__version__",
    "grin",
    "load_dict",
    "load_file",
    "load_string",
    "read",
    "render",
    "render_result",
    "trace_path",
    "warp",
    "write",
]
