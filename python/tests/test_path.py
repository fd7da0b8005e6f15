"""One ray through nested solids: the events the nested rule keeps."""

import pytest

import snell

NESTED = """
ambient_ior = 1.0
[camera]
position = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[film]
width = 8
height = 8
spp = 1
[[objects]]
name = "water"
shape = { type = "box", center = [0.0, 0.0, 0.0], size = [1.0, 1.0, 1.0] }
material = { type = "dielectric", ior = 1.33, priority = 1 }
[[objects]]
name = "glass"
shape = { type = "box", center = [0.6, 0.0, 0.0], size = [1.0, 2.0, 2.0] }
material = { type = "dielectric", ior = 1.5, priority = 2 }
"""


def test_false_hits_are_skipped_and_events_named():
    s = snell.load_string(NESTED)
    p = snell.trace_path(s, origin=[-3.0, 0.1, 0.2], direction=[1, 0, 0])
    ev = p["events"]
    assert [(e["n1"], e["n2"]) for e in ev] == [
        (1.0, pytest.approx(1.33)),
        (pytest.approx(1.33), 1.5),
        (1.5, 1.0),
    ]
    assert [(e["solid"], e["entering"]) for e in ev] == [("water", True), ("glass", True), ("glass", False)]
    assert ev[0]["point"][0] == pytest.approx(-0.5, abs=1e-5)
    assert sorted(ev[1]["inside"]) == ["glass", "water"]
    assert p["false_hits"] == 1 and p["escaped"] and p["inside"] == []


def test_a_ray_starting_inside():
    s = snell.load_string(NESTED)
    p = snell.trace_path(s, origin=[0.3, 0.1, 0.2], direction=[1, 0, 0])
    # Inside both solids (the glass wins): the water's face at x = 0.5 is a
    # false hit, the one event leaves the glass into air.
    assert [(e["solid"], e["entering"], e["n1"], e["n2"]) for e in p["events"]] == [("glass", False, 1.5, 1.0)]
    assert p["false_hits"] == 1
    # Told it starts in the water only, the same ray meets the glass first.
    q = snell.trace_path(s, [0.3, 0.1, 0.2], [1, 0, 0], inside=["water"])
    assert q["events"][0]["n1"] == pytest.approx(1.33)
    with pytest.raises(ValueError, match="no dielectric solid named"):
        snell.trace_path(s, [0, 0, 0], [1, 0, 0], inside=["ice"])
    with pytest.raises(ValueError, match="direction"):
        snell.trace_path(s, [0, 0, 0], [0, 0, 0])
