"""Scenes from files, strings and dicts: the same scene whatever the form,
errors that name the key (and the line and column of text), overrides with
the CLI's semantics, and no Rust panic for any dict."""

import copy
import random

import numpy as np
import pytest

import snell

BALL_TOML = """
ambient_ior = 1.0
[camera]
position = [0.0, 0.5, 4.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[film]
width = 32
height = 24
spp = 2
[environment]
type = "constant"
radiance = [1.0, 0.9, 0.8]
[[objects]]
name = "floor"
shape = { type = "rect", center = [0.0, -1.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [8.0, 8.0] }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.0, 0.0], radius = 0.8 }
material = { type = "dielectric", ior = 1.5 }
"""


def ball_dict():
    return {
        "ambient_ior": 1.0,
        "camera": {"position": np.array([0.0, 0.5, 4.0]), "target": (0, 0, 0), "fov": np.float32(40.0)},
        "film": {"width": 32, "height": np.int64(24), "spp": 2},
        "environment": {"type": "constant", "radiance": [1.0, 0.9, 0.8]},
        "objects": [
            {
                "name": "floor",
                "shape": {
                    "type": "rect",
                    "center": [0.0, -1.0, 0.0],
                    "normal": [0.0, 1.0, 0.0],
                    "u_axis": [1.0, 0.0, 0.0],
                    "size": [8.0, 8.0],
                },
                "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
            },
            {
                "name": "ball",
                "shape": {"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 0.8},
                "material": {"type": "dielectric", "ior": 1.5},
            },
        ],
    }


def test_a_dict_a_string_and_a_file_are_the_same_scene(tmp_path):
    path = tmp_path / "ball.toml"
    path.write_text(BALL_TOML)
    images = [
        snell.render(s)
        for s in (snell.load_dict(ball_dict()), snell.load_string(BALL_TOML), snell.load_file(str(path)))
    ]
    assert images[0].shape == (24, 32, 3) and images[0].std() > 0.01
    for im in images[1:]:
        assert np.array_equal(im.view(np.uint32), images[0].view(np.uint32))


def test_set_returns_a_new_scene_as_the_cli_set_does():
    s = snell.load_dict(ball_dict())
    wet = s.set("objects.ball.material.ior", 1.33).set("film.spp", 3)
    assert (s.spp, wet.spp) == (2, 3)
    assert wet.overrides == ["objects.ball.material.ior=1.33", "film.spp=3"]
    same = snell.load_string(BALL_TOML.replace("ior = 1.5", "ior = 1.33").replace("spp = 2", "spp = 3"))
    assert np.array_equal(snell.render(wet), snell.render(same))
    assert not np.array_equal(snell.render(wet, spp=2), snell.render(s))
    # A table value and a string value, as --set 'KEY={ ... }' and KEY=text.
    mirror = s.set("objects[1].material", {"type": "mirror"})
    assert mirror.to_toml().count("mirror") == 1
    assert s.set("integrator.type", "whitted").to_toml().count("whitted") == 1


def test_set_errors_are_located_in_the_override():
    s = snell.load_dict(ball_dict())
    with pytest.raises(snell.SceneError) as e:
        s.set("objects.glass.material.ior", 1.3)
    assert e.value.file == "--set 'objects.glass.material.ior=1.3'"
    assert (e.value.line, e.value.column) == (1, 9)
    assert "entries: floor, ball" in e.value.message
    with pytest.raises(snell.SceneError) as e:
        s.set("film.spp", 0)
    assert e.value.key == "film.spp" and "samples per pixel" in str(e.value)


def test_unknown_key_in_a_dict():
    d = ball_dict()
    d["objects"][1]["material"]["colour"] = [1, 0, 0]
    with pytest.raises(snell.SceneError) as e:
        snell.load_dict(d)
    assert isinstance(e.value, ValueError)
    assert e.value.file == "<dict>" and e.value.line is None and e.value.column is None
    assert e.value.key.startswith("objects[1].material")
    assert "colour" in e.value.message
    assert str(e.value).startswith("<dict>: objects[1].material")


def test_wrong_types_in_a_dict():
    d = ball_dict()
    d["objects"][1]["material"]["ior"] = "high"
    with pytest.raises(snell.SceneError) as e:
        snell.load_dict(d)
    assert e.value.key.startswith("objects[1].material"), e.value.key
    d = ball_dict()
    d["camera"]["fov"] = None
    with pytest.raises(snell.SceneError) as e:
        snell.load_dict(d)
    assert e.value.key == "camera.fov" and "None" in e.value.message
    d = ball_dict()
    d["objects"][0]["shape"]["size"] = [8.0, object()]
    with pytest.raises(snell.SceneError) as e:
        snell.load_dict(d)
    assert e.value.key == "objects[0].shape.size[1]"
    with pytest.raises(snell.SceneError) as e:
        snell.load_dict({1: 2})
    assert "string keys" in e.value.message
    with pytest.raises(snell.SceneError):
        snell.load_dict([1, 2])


def test_missing_mesh_names_its_key(tmp_path):
    d = ball_dict()
    d["objects"][1]["shape"] = {"type": "mesh", "file": "no_such_mesh.obj"}
    with pytest.raises(snell.SceneError) as e:
        snell.load_dict(d, base_dir=str(tmp_path))
    assert e.value.key == "objects[1].shape.file", e.value.key
    assert "no_such_mesh.obj" in e.value.message


def test_text_errors_carry_line_and_column_as_the_cli(cli, tmp_path):
    bad = BALL_TOML.replace("radius = 0.8", "radius = -0.8")
    path = tmp_path / "bad.toml"
    path.write_text(bad)
    with pytest.raises(snell.SceneError) as e:
        snell.load_string(bad)
    line = next(i for i, text in enumerate(bad.splitlines(), 1) if "radius = -0.8" in text)
    assert e.value.file == "<string>" and e.value.line == line and e.value.column > 1
    assert e.value.key.startswith("objects[1].shape")
    with pytest.raises(snell.SceneError) as from_file:
        snell.load_file(str(path))
    run = cli("render", path, "-o", tmp_path / "x.png", "--quiet", check=False)
    assert run.returncode == 1
    assert run.stderr.strip() == f"error: {from_file.value}"


MUTATIONS = [
    None,
    True,
    -1,
    0,
    2**40,
    -2.5,
    0.0,
    1e300,
    float("nan"),
    float("inf"),
    "",
    "sphere",
    "mesh",
    [],
    [1.0],
    [0.0, 0.0, 0.0],
    [1, 2, 3, 4],
    [[1.0, 2.0]],
    {},
    {"type": "sphere"},
    {"type": "dielectric", "ior": -1},
    np.zeros(3),
    np.float32(0.5),
]


def _paths(v, path=()):
    yield path
    if isinstance(v, dict):
        for k, x in v.items():
            yield from _paths(x, path + (k,))
    elif isinstance(v, list):
        for i, x in enumerate(v):
            yield from _paths(x, path + (i,))


def _mutate(d, rng):
    d = copy.deepcopy(d)
    for _ in range(rng.randint(1, 3)):
        paths = [p for p in _paths(d) if p]
        path = rng.choice(paths)
        parent = d
        for k in path[:-1]:
            parent = parent[k]
        key = path[-1]
        op = rng.random()
        if op < 0.15 and isinstance(parent, dict):
            del parent[key]
        elif op < 0.25 and isinstance(parent, dict):
            parent[rng.choice(["extra", "type", "name", "file", "priority"])] = rng.choice(MUTATIONS)
        else:
            parent[key] = copy.deepcopy(rng.choice(MUTATIONS))
    return d


def test_no_dict_makes_rust_panic():
    rng = random.Random(31)
    outcomes = {"loaded": 0, "refused": 0}
    for case in range(300):
        d = _mutate(ball_dict(), rng)
        try:
            snell.load_dict(d)
            outcomes["loaded"] += 1
        except snell.SceneError:
            outcomes["refused"] += 1
        except BaseException as e:  # PanicException is a BaseException
            pytest.fail(f"case {case}: {type(e).__name__}: {e}\n{d!r}")
    # The mutations reach both sides of the loader.
    assert outcomes["loaded"] > 10 and outcomes["refused"] > 100, outcomes


@pytest.mark.parametrize("name", ["three_spheres.xml", "glass_of_water.glb"])
def test_load_file_reads_mitsuba_and_gltf_scenes(scenes, name):
    scene = snell.load_file(str(scenes / name))
    image = snell.render(scene, width=8, height=6, spp=1, threads=1)
    assert image.shape == (6, 8, 3)
    assert np.isfinite(image).all() and image.max() > 0
    assert "[camera]" in scene.to_toml()
    assert scene.set("film.spp", 3).spp == 3


def test_an_imported_file_error_is_located_in_that_file(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text('<scene version="3.0.0">\n  <shape type="no_such_shape"/>\n</scene>\n')
    with pytest.raises(snell.SceneError) as e:
        snell.load_file(str(path))
    assert e.value.file == str(path) and e.value.line == 2
