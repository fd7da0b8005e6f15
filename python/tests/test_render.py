"""Renders through Python: the CLI's pixels bit for bit, the array's form,
the GIL released while rendering, Ctrl-C, and images in and out."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import snell


def bits(a):
    """The float32 values as integers: equal bits, not merely equal values."""
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


@pytest.mark.parametrize(
    "scene, args",
    [
        # Nested dielectrics (the filter skips false hits), with an override.
        ("glass_of_water_nested.toml", ["--set", "objects.water.material.ior=1.34", "--seed", "3"]),
        # The paper's strategy on the same kind of scene, with a region.
        ("nested_spheres_a.toml", ["--nested", "recast", "--region", "8,40,4,28"]),
    ],
)
def test_render_equals_the_cli_exr_bit_for_bit(cli, scenes, tmp_path, scene, args):
    out = tmp_path / "cli.exr"
    cli("render", scenes / scene, "-o", out, "--spp", 2, "--width", 64, "--height", 48, "--quiet", *args)
    from_cli = snell.read(out)

    s = snell.load_file(str(scenes / scene))
    kw = {}
    it = iter(args)
    for flag in it:
        value = next(it)
        if flag == "--set":
            key, v = value.split("=", 1)
            s = s.set(key, float(v))
        elif flag == "--seed":
            kw["seed"] = int(value)
        elif flag == "--nested":
            kw["nested"] = value
        elif flag == "--region":
            kw["region"] = tuple(int(x) for x in value.split(","))
    image = snell.render(s, spp=2, width=64, height=48, threads=2, **kw)
    assert image.shape == from_cli.shape
    assert np.array_equal(bits(image), bits(from_cli))
    # Not trivially equal: the image has content.
    assert image.std() > 0.01


def test_image_dtype_shape_and_layers(scenes):
    s = snell.load_file(str(scenes / "three_spheres.toml"))
    image = snell.render(s, spp=1, width=40, height=30)
    assert image.dtype == np.float32
    assert image.shape == (30, 40, 3)
    assert image.flags["C_CONTIGUOUS"]
    image, layers = snell.render(s, spp=1, width=40, height=30, aovs=["tir", "list_depth"])
    assert sorted(layers) == ["list_depth", "tir"]
    for layer in layers.values():
        assert layer.dtype == np.float32 and layer.shape == (30, 40) and layer.flags["C_CONTIGUOUS"]
    r = snell.render_result(s, spp=2, width=40, height=30)
    assert r.stats["samples"] == 40 * 30 * 2
    assert r.stats["spp"] == 2 and r.complete
    assert r.variance.shape == (30, 40, 3)
    with pytest.raises(ValueError, match="aovs"):
        snell.render(s, spp=1, width=8, height=8, aovs=["colour"])
    with pytest.raises(ValueError, match="nested"):
        snell.render(s, spp=1, width=8, height=8, nested="sometimes")


def test_a_region_is_the_same_pixels_as_the_whole(scenes):
    s = snell.load_file(str(scenes / "nested_spheres_b.toml"))
    whole = snell.render(s, spp=2, width=48, height=32)
    part = snell.render(s, spp=2, width=48, height=32, region=(5, 30, 7, 20))
    assert part.shape == (13, 25, 3)
    assert np.array_equal(bits(part), bits(whole[7:20, 5:30]))
    with pytest.raises(ValueError, match="region"):
        snell.render(s, spp=2, width=48, height=32, region=(0, 60, 0, 10))


def _seconds(scene, **kw):
    t = time.perf_counter()
    snell.render(scene, **kw)
    return time.perf_counter() - t


def test_other_threads_run_while_rendering(scenes):
    s = snell.load_file(str(scenes / "glass_of_water_nested.toml"))
    kw = dict(spp=16, width=160, height=120, threads=1)
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.005)

    t = threading.Thread(target=count)
    start = time.perf_counter()
    t.start()
    snell.render(s, **kw)
    end = time.perf_counter()
    done.set()
    t.join()
    during = [x for x in ticks if start < x < end]
    # A render that held the GIL would let the counter tick at most a few
    # times (at its entry and exit); released, it ticks every ~5 ms.
    assert end - start > 0.2, "render too short to tell"
    assert len(during) >= 0.3 * (end - start) / 0.005, (len(during), end - start)


def test_ctrl_c_stops_a_long_render(scenes):
    s = snell.load_file(str(scenes / "glass_of_water_nested.toml"))
    # Python's own Ctrl-C handler, also where SIGINT was ignored when the
    # process started (a background job of a shell).
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    # At full size and 512 spp this render would take minutes.
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            snell.render(s, spp=512, threads=2)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    elapsed = time.perf_counter() - start
    # A tile of 16x16 pixels at 512 spp takes well under a second.
    assert elapsed < 30, elapsed
    # The cancellation belonged to that render: the next one completes.
    r = snell.render_result(s, spp=1, width=32, height=24)
    assert r.complete and r.stats["tiles_done"] == r.stats["tiles_total"]


def test_progress_reaches_every_tile(scenes):
    s = snell.load_file(str(scenes / "nested_spheres_a.toml"))
    seen = []
    snell.render(s, spp=8, width=96, height=64, threads=1, progress=seen.append)
    assert seen, "no progress was reported"
    done = [p["tiles_done"] for p in seen]
    assert done == sorted(done) and seen[-1]["tiles_total"] == 6 * 4
    assert done[-1] == 24 and seen[-1]["samples_done"] == 96 * 64 * 8

    def stop(p):
        raise RuntimeError("enough")

    # A callback that raises stops the render and the error reaches the caller.
    with pytest.raises(RuntimeError, match="enough"):
        snell.render(s, spp=64, width=320, height=240, threads=1, progress=stop)


def test_write_and_read_back(tmp_path):
    rng = np.random.default_rng(1)
    image = rng.random((12, 20, 3), dtype=np.float32) * 4
    snell.write(str(tmp_path / "x.exr"), image, aovs={"tir": np.ones((12, 20))})
    back = snell.read(str(tmp_path / "x.exr"))
    assert back.dtype == np.float32 and back.shape == (12, 20, 3)
    assert np.array_equal(bits(back), bits(image))
    snell.write(str(tmp_path / "x.png"), image.astype(np.float64))
    png = snell.read(str(tmp_path / "x.png"))
    assert png.shape == (12, 20, 3)
    # 8-bit sRGB: values above 1 are clamped, the rest agree to quantisation.
    assert np.allclose(png, np.clip(image, 0, 1), atol=0.02)
    with pytest.raises(ValueError, match="shape"):
        snell.write(str(tmp_path / "y.exr"), np.zeros((4, 4)))
    with pytest.raises(OSError, match="extension"):
        snell.write(str(tmp_path / "y.jpg"), image)
    with pytest.raises(OSError):
        snell.read(str(tmp_path / "missing.exr"))
