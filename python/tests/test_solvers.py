"""The solvers on arrays give the CLI's numbers: `snell.grin.trace` against
`snell grin-trace`, the warps against `snell warp-points`, on the same inputs."""

import json

import numpy as np
import pytest

import snell

ROAD = {"kind": "hot_ground", "n_inf": 1.000293, "dn": 0.0001, "h0": 0.3}
LINEAR = {"kind": "linear", "n0": 1.0, "m": 0.01}


def _rays(n, seed):
    """Rays whose coordinates have six decimals: serde_json (without its
    float_roundtrip feature) reads such numbers exactly, so the CLI gets the
    very inputs Python passes."""
    rng = np.random.default_rng(seed)
    origins = np.column_stack([np.zeros(n), rng.uniform(0.5, 2.0, n), rng.uniform(-1, 1, n)])
    directions = np.column_stack([np.ones(n), rng.uniform(-0.02, 0.01, n), rng.uniform(-0.01, 0.01, n)])
    return origins.round(6), directions.round(6)


def _cli_grin(cli, tmp_path, field, origins, directions, stop, method, extra):
    queries = [
        {
            "id": str(i),
            "field": field,
            "start": o.tolist(),
            "direction": d.tolist(),
            "stop": stop,
            "method": method,
            **extra,
        }
        for i, (o, d) in enumerate(zip(origins, directions))
    ]
    doc = tmp_path / "q.json"
    doc.write_text(json.dumps({"queries": queries}))
    return json.loads(cli("grin-trace", doc).stdout)["results"]


@pytest.mark.parametrize(
    "field, method, stop, extra",
    [
        (ROAD, "rk45", {"s": 300.0}, {"tolerance": 1e-9}),
        (ROAD, "rk4", {"x": 250.0}, {"step": 0.5}),
        (LINEAR, "exact", {"s": 50.0}, {}),
        (ROAD, "slab", {"x": 100.0}, {"step": 0.01}),
    ],
)
def test_grin_trace_equals_the_cli(cli, tmp_path, field, method, stop, extra):
    origins, directions = _rays(24, 5)
    # One ray that cannot reach its stop: its status, not the batch, fails.
    directions[3] = [-1.0, 0.0, 0.0]
    results = _cli_grin(cli, tmp_path, field, origins, directions, stop, method, extra)
    kw = {"length": stop["s"]} if "s" in stop else {"x": stop["x"]}
    t = snell.grin.trace(field, origins, directions, method=method, **kw, **extra)
    assert len(t) == len(results) == 24
    for i, r in enumerate(results):
        if r["status"] != "ok":
            assert not t.ok[i] and r["status"] == f"queries[{i}].{t.status[i]}"
            assert np.isnan(t.end[i]).all()
            continue
        assert t.ok[i] and t.status[i] == "ok"
        assert t.end[i].tolist() == r["end"]
        assert t.direction[i].tolist() == r["end_direction"]
        assert t.length[i] == r["arc_length"]
        assert (int(t.evaluations[i]), int(t.steps[i])) == (r["evaluations"], r["steps"])
    assert sum(r["status"] == "ok" for r in results) >= 20


def test_grin_trace_arrays_and_errors():
    origins, directions = _rays(7, 2)
    t = snell.grin.trace(ROAD, origins.astype(np.float32), directions.tolist(), length=10.0)
    assert t.end.shape == (7, 3) and t.end.dtype == np.float64 and t.end.flags["C_CONTIGUOUS"]
    assert t.length.shape == (7,) and t.evaluations.dtype == np.uint64 and t.ok.all()
    with pytest.raises(ValueError, match="exactly one"):
        snell.grin.trace(ROAD, origins, directions)
    with pytest.raises(ValueError, match="field"):
        snell.grin.trace({"kind": "swamp"}, origins, directions, length=1.0)
    with pytest.raises(ValueError, match="method"):
        snell.grin.trace(ROAD, origins, directions, method="exact", length=1.0)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        snell.grin.trace(ROAD, origins[:, :2], directions, length=1.0)
    with pytest.raises(ValueError, match="as many rows"):
        snell.grin.trace(ROAD, origins[:3], directions, length=1.0)


def _cli_warp(cli, tmp_path, glass, eye, points, method="exact"):
    doc = tmp_path / "w.json"
    doc.write_text(json.dumps({"eye": eye, "glass": glass, "method": method, "points": points.tolist()}))
    return json.loads(cli("warp-points", doc).stdout)["points"]


def _assert_same(w, answers, exact=True):
    assert len(w) == len(answers)
    names = snell.warp.FAMILIES
    messages = w.messages()
    for i, a in enumerate(answers):
        assert messages[i] == a["status"], i
        ims = a["images"]
        lo, hi = w.offsets[i], w.offsets[i + 1]
        assert hi - lo == len(ims) == w.counts[i]
        for k, im in zip(range(lo, hi), ims):
            assert names[w.family[k]] == im["family"]
            assert (int(w.refractions[k]), int(w.parity[k])) == (im["refractions"], im["parity"])
            assert w.vertex[k] == i
            if exact:
                assert w.positions[k].tolist() == im["position"]
                assert w.directions[k].tolist() == im["direction"]
            else:
                assert np.allclose(w.directions[k], im["direction"], rtol=0, atol=1e-12)
                assert np.allclose(w.positions[k], im["position"], rtol=0, atol=1e-9)


def _grid(n, z):
    xs, ys = np.meshgrid(np.linspace(-3, 3, n), np.linspace(-2, 2, n))
    # Six decimals: read exactly by the CLI (see `_rays`).
    return np.column_stack([xs.ravel(), ys.ravel(), np.full(n * n, z)]).round(6)


def test_plate_equals_the_cli(cli, tmp_path):
    glass = {"kind": "plate", "near_face_point": [0, 0, 1], "normal": [0.2, -0.1, -1.0], "thickness": 0.3, "ior": 1.5}
    eye = [0.0, 0.0, 4.0]
    pts = np.vstack([_grid(9, -3.0), [[0, 0, 3.0], [0, 0, 0.9]]])
    args = (pts, eye, glass["near_face_point"], glass["normal"], glass["thickness"], glass["ior"])
    answers = _cli_warp(cli, tmp_path, glass, eye, pts)
    _assert_same(snell.warp.plate(*args, solver="scalar"), answers, exact=True)
    w = snell.warp.plate(*args)
    _assert_same(w, answers, exact=False)
    assert set(w.messages()) >= {"ok", "error: the point is inside the glass"}


TUBE = {
    "kind": "hollow_cylinder",
    "axis_point": [0, 0, 0],
    "axis_direction": [0, 1, 0],
    "outer_radius": 1.0,
    "inner_radius": 0.8,
    "ior": 1.5,
}


def _tube(pts, **kw):
    t = TUBE
    return snell.warp.hollow_cylinder(
        pts, [0, 0, 4], t["axis_point"], t["axis_direction"], t["outer_radius"], t["inner_radius"], t["ior"], **kw
    )


def test_hollow_cylinder_equals_the_cli(cli, tmp_path):
    pts = np.vstack([_grid(7, -3.0), [[0.9, 0, 0], [0.2, 0.1, 0.1]]])
    answers = _cli_warp(cli, tmp_path, TUBE, [0, 0, 4], pts)
    _assert_same(_tube(pts, solver="sampler"), answers, exact=True)
    _assert_same(_tube(pts), answers, exact=False)
    no_parity = _tube(pts, parity=False)
    assert (no_parity.parity == 0).all() and np.array_equal(no_parity.counts, _tube(pts).counts)
    assert sum(len(a["images"]) > 1 for a in answers) > 5
    paper = _cli_warp(cli, tmp_path, TUBE, [0, 0, 4], pts, method="paper")
    _assert_same(_tube(pts, method="paper"), paper, exact=True)


def test_warp_arrays_and_errors():
    pts = _grid(5, -3.0)
    w = _tube(pts)
    assert w.positions.shape == (int(w.counts.sum()), 3) and w.offsets.shape == (26,)
    assert w.offsets[-1] == len(w.family) and w.status.dtype == np.uint8
    with pytest.raises(ValueError, match="radii"):
        snell.warp.hollow_cylinder(pts, [0, 0, 4], [0, 0, 0], [0, 1, 0], 0.5, 0.8, 1.5)
    with pytest.raises(ValueError, match="method"):
        _tube(pts, method="magic")
    with pytest.raises(ValueError, match="solver"):
        _tube(pts, solver="magic")
    # JSON has no NaN: the CLI's "non-finite" status is checked here.
    nan = _tube(np.array([[np.nan, 0.0, 0.0], [0.5, 0.0, -2.5]]))
    assert nan.messages()[0] == "error: point has non-finite coordinates" and nan.counts[0] == 0
    assert nan.counts[1] > 0
    inside = snell.warp.hollow_cylinder(pts, [0, 0, 0.5], [0, 0, 0], [0, 1, 0], 1.0, 0.8, 1.5)
    assert set(inside.messages()) == {"error: the eye is not outside the tube"}
    with pytest.raises(ValueError, match="solver"):
        snell.warp.plate(pts, [0, 0, 4], [0, 0, 1], [0, 0, -1], 0.3, 1.5, solver="magic")
    with pytest.raises(ValueError, match="thickness"):
        snell.warp.plate(pts, [0, 0, 4], [0, 0, 1], [0, 0, -1], 0.0, 1.5)


def test_plate_positions_are_the_plates_in_float32():
    plate = ([0.0, 0.0, 1.0], [0.2, -0.1, -1.0], 0.3, 1.5)
    eye = [0.0, 0.0, 4.0]
    pts = np.vstack([_grid(40, -3.0), [[0, 0, 3.0], [0, 0, 0.9]]]).astype(np.float32)
    out = np.full(pts.shape, np.nan, dtype=np.float32)
    pos, warped = snell.warp.plate_positions(pts, eye, *plate, out=out)
    assert pos is out and warped.dtype == np.int8
    full = snell.warp.plate(pts.astype(np.float64), eye, *plate)
    names = [snell.warp.FAMILIES[f] for f in full.family]
    rows = full.offsets[:-1][full.counts == 1]
    moved = np.array([names[k] == "wall2" for k in rows])
    has = full.counts == 1
    assert np.array_equal(warped[has], np.where(moved, 1, 0)) and (warped[~has] == -1).all()
    # Warped vertices: the plate's positions rounded to float32; the others stay.
    assert np.array_equal(pos[has][moved], full.positions[rows][moved].astype(np.float32))
    assert np.array_equal(pos[warped != 1], pts[warped != 1])
    new, _ = snell.warp.plate_positions(pts.astype(np.float64), eye, *plate)
    assert np.array_equal(new, pos)
    with pytest.raises(ValueError, match="out"):
        snell.warp.plate_positions(pts, eye, *plate, out=np.zeros((3, 3), dtype=np.float32))
