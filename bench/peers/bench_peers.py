#!/usr/bin/env python3
"""The peer race: snell against Mitsuba 3 on the reference scenes.

Run through `make bench-peers` (which builds snell, prepares the venv and sets
DRJIT_LIBLLVM_PATH); see docs/peers.md. Per reference scene of
../shared/reference-scenes/scenes.json:

1. checks that snell's scene file (scenes/NAME.toml) says what scenes.json says
   (camera, film, integrator, lights, shapes, materials, mesh files);
2. loads the same scene for Mitsuba from scenes/NAME.xml with mi.load_file (the
   XML snell imports too, whose description tests/import_mitsuba.rs checks
   equals the TOML's), with the run's width, height, spp and seed as its
   $parameters;
3. renders snell and Mitsuba alternately, --reps times each, at the same size,
   spp and thread count (Mitsuba's repetition k uses seed k; snell uses its
   scene's seed), timing the render only (not scene loading or BVH builds);
4. prints samples/s of snell / Mitsuba per repetition pair: the median and the
   min-max range, against Mitsuba's render wall time both without and with its
   JIT compile (codegen + LLVM backend time from Dr.Jit's kernel history);
5. compares 16x16 block means: RMSE(snell, Mitsuba seed 0) and RMSE(snell,
   Mitsuba seed 1) must stay within --limit times RMSE(Mitsuba seed 0, Mitsuba
   seed 1), the seed-to-seed noise. Exit status 1 when a scene fails.

With --materials it compares images instead of speed, on the material scenes
of bench/peers/materials/NAME.xml (rough glass, rough gold, plastics), each
rendered by both renderers from the one XML file (snell through its
importer) at --seeds seeds: the block-mean difference over its noise, the
image means, and the median over pixels of snell's per-pixel variance over
Mitsuba's (both estimated across the seeds; about 1 when the estimators are
equally noisy).
"""
import argparse
import ctypes
import datetime
import filecmp
import json
import math
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SCENES = ["three_spheres", "glass_of_water", "cylinder_refraction"]


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--snell", default=str(REPO / "target/release/snell"), help="snell binary")
    p.add_argument(
        "--reference",
        default=os.environ.get("SNELL_REFERENCE_SCENES", str(REPO.parent / "shared/reference-scenes/scenes.json")),
        help="scenes.json (default ../shared/reference-scenes/scenes.json, or $SNELL_REFERENCE_SCENES)",
    )
    p.add_argument("--snell-scenes", default=str(REPO / "scenes"),
                   help="directory of snell's NAME.toml and of NAME.xml, the same scene for Mitsuba")
    p.add_argument("--scene", action="append", choices=SCENES, help="only this scene (repeatable)")
    p.add_argument("--reps", type=int, default=3, help="timed renders per renderer and scene (interleaved)")
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant")
    p.add_argument(
        "--mitsuba-llvm-target",
        metavar="CPU:FEATURES:WIDTH",
        help="hold Mitsuba's LLVM kernels to this CPU, feature string and vector width "
        "(Dr.Jit's jit_llvm_set_target), e.g. 'haswell:+avx2,+fma:8' to see what the machine's "
        "wider vectors give it; default: Dr.Jit's choice for this machine",
    )
    p.add_argument("--block", type=int, default=16, help="block size for the image comparison")
    p.add_argument(
        "--limit",
        type=float,
        default=1.5,
        help="allowed block RMSE(snell, Mitsuba) / block RMSE(Mitsuba seed 0, seed 1)",
    )
    p.add_argument(
        "--power-check",
        action="store_true",
        help="also render snell once with every emitter 5%% dimmer and show that the comparison catches it",
    )
    p.add_argument(
        "--snell-noise",
        action="store_true",
        help="also render snell with seed 1: its own seed-to-seed block RMSE beside Mitsuba's",
    )
    p.add_argument("--materials", action="store_true",
                   help="compare images of bench/peers/materials/*.xml instead of timing the reference scenes")
    p.add_argument("--material", action="append", help="with --materials: only this scene (repeatable)")
    p.add_argument("--seeds", type=int, default=3, help="with --materials: renders per renderer and scene")
    p.add_argument("--out", default=str(REPO / "out/peers"), help="directory for the EXR/PNG images")
    p.add_argument("--json", metavar="FILE", help="write the table, image figures and provenance as JSON")
    a = p.parse_args()
    if a.reps < 1:
        p.error("--reps must be at least 1")
    if a.seeds < 2:
        p.error("--seeds must be at least 2 (noise is estimated across seeds)")
    return a


# ---------------------------------------------------------------- scene check


def _same(a, b, path, out):
    """Deep comparison of scene values (numbers as floats); differences into out."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}.{k}: {'missing in snell' if k not in b else 'only in snell'}")
            else:
                _same(a[k], b[k], f"{path}.{k}", out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: {a} vs {b}")
        else:
            for i, (x, y) in enumerate(zip(a, b)):
                _same(x, y, f"{path}[{i}]", out)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if float(a) != float(b):
            out.append(f"{path}: scenes.json {a} vs snell {b}")
    elif a != b:
        out.append(f"{path}: scenes.json {a!r} vs snell {b!r}")


def check_snell_scene(name, js, ref_dir, toml_path):
    """Differences between scenes.json's scene and snell's TOML (empty = same scene)."""
    t = tomllib.loads(Path(toml_path).read_text())
    diff = []
    cam = dict(js["camera"])
    cam["fov"] = cam.pop("fov_deg")
    _same(cam, t.get("camera", {}), "camera", diff)
    tf = {k: v for k, v in t.get("film", {}).items() if k != "seed"}
    _same(js["film"], tf, "film", diff)
    _same(js["integrator"], t.get("integrator", {}), "integrator", diff)
    _same(js.get("ambient_ior", 1.0), t.get("ambient_ior"), "ambient_ior", diff)
    env = t.get("environment")
    if env is not None and env.get("type") == "black":
        env = None
    _same(js.get("environment"), env, "environment", diff)
    tl = {l.get("name"): {k: v for k, v in l.items() if k != "name"} for l in t.get("lights", [])}
    jl = {l["name"]: {k: v for k, v in l.items() if k != "name"} for l in js.get("lights", [])}
    _same(jl, tl, "lights", diff)
    tobj = {o.get("name"): o for o in t.get("objects", [])}
    for o in js["objects"]:
        so = tobj.pop(o["name"], None)
        if so is None:
            diff.append(f"objects.{o['name']}: missing in snell")
            continue
        shape = {k: v for k, v in o.items() if k not in ("name", "material", "emission", "parts")}
        sshape = dict(so.get("shape", {}))
        if shape.get("type") == "mesh":
            a, b = Path(ref_dir) / shape.pop("file"), Path(toml_path).parent / sshape.pop("file", "")
            if not (b.is_file() and filecmp.cmp(a, b, shallow=False)):
                diff.append(f"objects.{o['name']}.shape.file: {b} differs from {a}")
        _same(shape, sshape, f"objects.{o['name']}.shape", diff)
        smat = dict(so.get("material", {}))
        if smat.get("type") == "diffuse" and smat.get("two_sided") is False:
            smat.pop("two_sided")
        _same(o["material"], smat, f"objects.{o['name']}.material", diff)
        _same(o.get("emission"), so.get("emission"), f"objects.{o['name']}.emission", diff)
    for n in tobj:
        diff.append(f"objects.{n}: only in snell")
    return diff


# ------------------------------------------------------------------- renders


def run_snell(a, toml, exr, seed, extra=()):
    stats = exr.with_suffix(".stats.json")
    cmd = [a.snell, "render", str(toml), "-o", str(exr), "--spp", str(a.spp), "--threads", str(a.threads),
           "--width", str(a.width), "--height", str(a.height), "--quiet", "--stats-json", str(stats)]
    if seed is not None:
        cmd += ["--seed", str(seed)]
    for s in extra:
        cmd += ["--set", s]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    process_s = time.perf_counter() - t0
    st = json.loads(stats.read_text())
    return {
        "wall_s": st["wall_s"],
        "cpu_s": st.get("cpu_s"),
        "load_s": st.get("load_s"),
        "process_s": process_s,
        "samples_per_s": st["samples_per_s"],
        "rays_per_s": st.get("rays_per_s"),
        "provenance": st.get("provenance", {}),
    }


def run_mitsuba(mi, dr, scene, spp, seed):
    dr.kernel_history()  # clear
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    hist = dr.kernel_history()
    ms = lambda key: sum(float(k.get(key, 0.0)) for k in hist) / 1000.0
    jit = ms("codegen_time") + ms("backend_time")
    return img, {
        "wall_s": wall,
        "jit_s": jit,
        "wall_excl_jit_s": wall - jit,
        "kernel_exec_s": ms("execution_time"),
        "kernels": len(hist),
        "cache_hits": sum(1 for k in hist if k.get("cache_hit")),
        "cache_disk": sum(1 for k in hist if k.get("cache_disk")),
        "cpu_s": (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime),
    }


def block_means(img, b):
    import numpy as np

    h, w = img.shape[0] // b * b, img.shape[1] // b * b
    x = np.asarray(img, dtype=np.float64)[:h, :w, :3]
    return x.reshape(h // b, b, w // b, b, 3).mean(axis=(1, 3))


def rmse(x, y):
    import numpy as np

    return float(np.sqrt(np.mean((x - y) ** 2)))


def read_exr(mi, path):
    import numpy as np

    bmp = mi.Bitmap(str(path)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.array(bmp)


def write_images(mi, img, stem):
    bmp = mi.Bitmap(img)
    bmp.write(str(stem) + ".exr")
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(str(stem) + ".png")


# ---------------------------------------------------------------- provenance


def cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def mitsuba_embree_version(mi):
    """The Embree that Mitsuba's wheel bundles, asked through rtcGetDeviceProperty."""
    lib = Path(mi.__file__).parent / "libembree3.so"
    if not lib.exists():
        lib = Path(mi.__file__).parent / "libembree4.so"
    # Mitsuba builds Embree with its API in namespace mitsuba (C++-mangled names).
    names = [
        ("rtcNewDevice", "rtcGetDeviceProperty", "rtcReleaseDevice"),
        (
            "_ZN7mitsuba12rtcNewDeviceEPKc",
            "_ZN7mitsuba20rtcGetDevicePropertyEPNS_11RTCDeviceTyENS_17RTCDevicePropertyE",
            "_ZN7mitsuba16rtcReleaseDeviceEPNS_11RTCDeviceTyE",
        ),
    ]
    try:
        e = ctypes.CDLL(str(lib))
    except OSError:
        return "unknown"
    for new_, get_, rel_ in names:
        try:
            new, get, rel = getattr(e, new_), getattr(e, get_), getattr(e, rel_)
        except AttributeError:
            continue
        new.restype, new.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
        get.restype, get.argtypes = ctypes.c_ssize_t, [ctypes.c_void_p, ctypes.c_int]
        rel.restype, rel.argtypes = None, [ctypes.c_void_p]
        dev = new(None)
        if not dev:
            return "unknown"
        v = get(dev, 0)  # RTC_DEVICE_PROPERTY_VERSION, e.g. 31304
        rel(dev)
        return f"{v // 10000}.{v // 100 % 100}.{v % 100}"
    return "unknown"


def git(*args):
    try:
        return subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def snell_version(snell):
    out = subprocess.run([snell, "--version"], capture_output=True, text=True, check=True).stdout
    info = {}
    for line in out.splitlines():
        k, _, v = line.partition(" ")
        info[k] = v.strip()
    return info


def loadavg():
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "unknown"


# ---------------------------------------------------------------------- main


def summary(xs):
    return {"median": statistics.median(xs), "min": min(xs), "max": max(xs), "all": xs}


def set_llvm_target(spec):
    """Dr.Jit's LLVM target, through the C function libdrjit-core exports
    (jit_llvm_set_target(cpu, features, vector_width)); the Python API has no
    binding for it. Call after mi.set_variant, before the first kernel."""
    import drjit

    try:
        cpu, features, width = spec.split(":")
        width = int(width)
    except ValueError:
        sys.exit(f"bench-peers: --mitsuba-llvm-target {spec!r}: expected CPU:FEATURES:WIDTH")
    if width not in (1, 4, 8, 16):
        sys.exit(f"bench-peers: --mitsuba-llvm-target {spec!r}: WIDTH must be 1, 4, 8 or 16")
    core = ctypes.CDLL(str(Path(drjit.__file__).parent / "libdrjit-core.so"))
    fn = getattr(core, "_Z19jit_llvm_set_targetPKcS0_j", None)
    if fn is None:
        sys.exit("bench-peers: this Dr.Jit exports no jit_llvm_set_target")
    fn.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    fn.restype = None
    fn(cpu.encode(), features.encode(), width)
    return f"{cpu} {features} x{width}"


def materials_main(a):
    """The material scenes: snell against Mitsuba by block means and per-pixel variance."""
    import numpy as np

    os.environ.setdefault("DRJIT_CACHE_DIR", tempfile.mkdtemp(prefix="bench-peers-drjit-"))
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    dr.set_thread_count(a.threads)
    out = Path(a.out) / "materials"
    out.mkdir(parents=True, exist_ok=True)
    scenes = sorted((REPO / "bench/peers/materials").glob("*.xml"))
    if a.material:
        scenes = [x for x in scenes if x.stem in a.material]
    print(f"bench-peers --materials: snell vs Mitsuba {mi.__version__} {a.variant}, {a.width}x{a.height}, "
          f"{a.spp} spp, {a.seeds} seeds each, {a.block}x{a.block} blocks", flush=True)
    print(f"  {'scene':26} {'block ratio':>11} {'5% darker':>9} {'mean snell':>10} {'mean Mitsuba':>12} "
          f"{'var ratio':>9}", flush=True)
    results = {}
    failed = []
    for xml in scenes:
        name = xml.stem
        s_imgs, m_imgs = [], []
        scene = mi.load_file(str(xml), width=a.width, height=a.height, spp=a.spp, seed=0)
        for seed in range(a.seeds):
            exr = out / f"{name}.snell.seed{seed}.exr"
            subprocess.run([a.snell, "render", str(xml), "-o", str(exr), "--threads", str(a.threads),
                            "-D", f"width={a.width}", "-D", f"height={a.height}", "-D", f"spp={a.spp}",
                            "--seed", str(seed + 1), "--quiet"], check=True, stdout=subprocess.DEVNULL)
            s_imgs.append(read_exr(mi, exr)[..., :3].astype(np.float64))
            img = mi.render(scene, spp=a.spp, seed=seed)
            m_imgs.append(np.array(img, dtype=np.float64)[..., :3])
            if seed == 0:
                write_images(mi, img, out / f"{name}.mitsuba.seed0")
        k = a.seeds
        s_arr, m_arr = np.stack(s_imgs), np.stack(m_imgs)
        # Block means: the difference of the seed means over the noise of that
        # difference (each method's variance of its seed mean, from the seeds).
        sb = np.stack([block_means(x, a.block) for x in s_imgs])
        mb = np.stack([block_means(x, a.block) for x in m_imgs])
        noise_var = sb.var(axis=0, ddof=1) / k + mb.var(axis=0, ddof=1) / k

        def block_ratio(scale):
            diff = scale * sb.mean(axis=0) - mb.mean(axis=0)
            return float(np.sqrt(np.mean(diff ** 2) / np.mean(noise_var)))

        ratio = block_ratio(1.0)
        # Power: the same comparison of a snell image 5% too dark must fail.
        dim = block_ratio(0.95)
        # Per-pixel variance of one render, across seeds (channel mean).
        sv = s_arr.mean(axis=3).var(axis=0, ddof=1)
        mv = m_arr.mean(axis=3).var(axis=0, ddof=1)
        both = (sv > 0) & (mv > 0)
        var_ratio = float(np.median(sv[both] / mv[both])) if both.any() else math.nan
        ms, mm = float(s_arr.mean()), float(m_arr.mean())
        ok = ratio <= a.limit
        if not ok:
            failed.append(name)
        results[name] = {"block_ratio": ratio, "block_ratio_snell_5pct_darker": dim, "mean_snell": ms, "mean_mitsuba": mm,
                         "median_pixel_variance_ratio": var_ratio, "agree": ok}
        print(f"  {name:26} {ratio:11.3f} {dim:9.2f} {ms:10.5f} {mm:12.5f} {var_ratio:9.3f}"
              + ("" if ok else f"   (above --limit {a.limit})"), flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps({
            "settings": {"width": a.width, "height": a.height, "spp": a.spp, "seeds": a.seeds,
                         "block": a.block, "limit": a.limit},
            "mitsuba": mi.__version__, "variant": a.variant,
            "repo_commit": git("rev-parse", "--short=12", "HEAD"),
            "materials": results}, indent=2))
    return 1 if failed else 0


def main():
    a = parse_args()
    if a.materials:
        sys.exit(materials_main(a))
    ref_path = Path(a.reference)
    if not ref_path.is_file():
        sys.exit(f"bench-peers: {ref_path} not found (set SNELL_REFERENCE_SCENES or --reference)")
    ref = json.loads(ref_path.read_text())
    names = a.scene or SCENES
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)

    # A fresh kernel cache, so that each scene's first render compiles cold and the
    # JIT time is that of a first render (unless DRJIT_CACHE_DIR says otherwise).
    jit_cache_tmp = None
    if "DRJIT_CACHE_DIR" not in os.environ:
        jit_cache_tmp = tempfile.mkdtemp(prefix="bench-peers-drjit-")
        os.environ["DRJIT_CACHE_DIR"] = jit_cache_tmp
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    llvm_target = set_llvm_target(a.mitsuba_llvm_target) if a.mitsuba_llvm_target else "Dr.Jit's default"
    dr.set_thread_count(a.threads)
    dr.set_flag(dr.JitFlag.KernelHistory, True)

    sv = snell_version(a.snell)
    prov = {
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "cpu": f"{cpu_model()}, {os.cpu_count()} logical cores",
        "load_average_start": loadavg(),
        "repo_commit": git("rev-parse", "--short=12", "HEAD"),
        "repo_dirty": bool(git("status", "--porcelain", "--untracked-files=no")),
        "snell_commit": sv.get("commit", "unknown"),
        "snell_embree": sv.get("Embree", "unknown"),
        "snell_rustc": sv.get("rustc", "unknown"),
        "snell_profile": sv.get("profile", "unknown"),
        "mitsuba": mi.__version__,
        "drjit": dr.__version__,
        "mitsuba_variant": a.variant,
        "mitsuba_llvm_target": llvm_target,
        "mitsuba_embree": mitsuba_embree_version(mi),
        "libllvm": os.environ.get("DRJIT_LIBLLVM_PATH", "(Dr.Jit's search)"),
        "python": platform.python_version(),
        "drjit_cache": "fresh (each scene's first render compiles cold)" if jit_cache_tmp
        else os.environ["DRJIT_CACHE_DIR"],
        "reference": str(ref_path),
    }
    settings = {
        "width": a.width, "height": a.height, "spp": a.spp, "threads": a.threads, "reps": a.reps,
        "block": a.block, "limit": a.limit,
    }
    print(
        f"bench-peers: snell vs Mitsuba {mi.__version__} {a.variant}, {a.width}x{a.height}, {a.spp} spp, "
        f"{a.threads} threads, {a.reps} interleaved repetitions per renderer (load average {prov['load_average_start']})",
        flush=True,
    )

    results = {}
    failed = []
    for name in names:
        js = ref["scenes"][name]
        toml = Path(a.snell_scenes) / f"{name}.toml"
        diffs = check_snell_scene(name, js, ref_path.parent, toml)
        for d in diffs:
            print(f"  {name}: snell's scene differs from scenes.json: {d}", flush=True)
        if not diffs:
            print(f"  {name}: {toml} says what scenes.json says (camera, film, integrator, lights, shapes, "
                  "materials, mesh files)", flush=True)
        t0 = time.perf_counter()
        xml = Path(a.snell_scenes) / f"{name}.xml"
        scene = mi.load_file(str(xml), width=a.width, height=a.height, spp=a.spp, seed=0)
        m_load = time.perf_counter() - t0
        seeds = list(range(max(a.reps, 2)))
        s_runs, m_runs, m_imgs = [], [], {}
        for k, seed in enumerate(seeds):
            timed = k < a.reps
            if timed:
                s = run_snell(a, toml, out / f"{name}.snell.exr", None)
                s_runs.append(s)
            img, m = run_mitsuba(mi, dr, scene, a.spp, seed)
            if seed in (0, 1):
                m_imgs[seed] = img
                write_images(mi, img, out / f"{name}.mitsuba.seed{seed}")
            if timed:
                m_runs.append(m)
            print(
                f"  {name} rep {k + 1}: "
                + (f"snell {s['wall_s']:.2f} s (cpu {s['cpu_s']:.1f} s), " if timed else "(untimed seed) ")
                + f"Mitsuba seed {seed} {m['wall_s']:.2f} s (JIT {m['jit_s']:.2f} s, "
                f"{m['cache_hits']}/{m['kernels']} kernels cached, cpu {m['cpu_s']:.1f} s)",
                flush=True,
            )
        # Images: block means of linear radiance.
        import numpy as np

        s_img = read_exr(mi, out / f"{name}.snell.exr")
        mi.Bitmap(str(out / f"{name}.snell.exr")).convert(
            mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True
        ).write(str(out / f"{name}.snell.png"))
        m0, m1 = np.array(m_imgs[0]), np.array(m_imgs[1])
        bs, b0, b1 = (block_means(x, a.block) for x in (s_img, m0, m1))
        noise = rmse(b0, b1)
        d0, d1 = rmse(bs, b0), rmse(bs, b1)
        ratio = max(d0, d1) / noise if noise > 0 else math.inf
        ok = ratio <= a.limit
        images = {
            "block": a.block,
            "rmse_snell_mitsuba_seed0": d0,
            "rmse_snell_mitsuba_seed1": d1,
            "rmse_mitsuba_seed0_seed1": noise,
            "ratio": ratio,
            "limit": a.limit,
            "agree": ok,
            "mean_snell": float(s_img[..., :3].mean()),
            "mean_mitsuba": float((m0.mean() + m1.mean()) / 2),
        }
        if a.snell_noise:
            run_snell(a, toml, out / f"{name}.snell.seed1.exr", 1)
            images["rmse_snell_seed0_seed1"] = rmse(bs, block_means(read_exr(mi, out / f"{name}.snell.seed1.exr"), a.block))
        if a.power_check:
            sets = [f"lights.{l['name']}.radiance={[0.95 * x for x in l['radiance']]}" for l in js.get("lights", [])]
            for o in js["objects"]:
                em = o.get("emission")
                if em:
                    r = em["radiance"]
                    if isinstance(r, dict):
                        for c in ("color0", "color1"):
                            sets.append(f"objects.{o['name']}.emission.radiance.{c}={[0.95 * x for x in r[c]]}")
                    else:
                        sets.append(f"objects.{o['name']}.emission.radiance={[0.95 * x for x in r]}")
            run_snell(a, toml, out / f"{name}.snell.dim5.exr", None, sets)
            bd = block_means(read_exr(mi, out / f"{name}.snell.dim5.exr"), a.block)
            pr = max(rmse(bd, b0), rmse(bd, b1)) / noise
            images["power_check_dimmer_5pct_ratio"] = pr
            images["power_check_caught"] = pr > a.limit
        if not ok:
            failed.append(name)
        ratio_excl = [m["wall_excl_jit_s"] / s["wall_s"] for s, m in zip(s_runs, m_runs)]
        # The JIT compile happens once per scene (the first render; later ones hit the
        # in-memory cache): with JIT, every render is charged that cold compile.
        cold_jit = max(m["jit_s"] for m in m_runs)
        ratio_incl = [(m["wall_excl_jit_s"] + cold_jit) / s["wall_s"] for s, m in zip(s_runs, m_runs)]
        ratio_cpu = [m["cpu_s"] / s["cpu_s"] for s, m in zip(s_runs, m_runs) if s["cpu_s"]]
        samples = a.width * a.height * a.spp
        results[name] = {
            "scene_differences": diffs,
            "samples": samples,
            "snell": {
                **{k: summary([r[k] for r in s_runs]) for k in ("wall_s", "cpu_s", "load_s", "rays_per_s")},
                "samples_per_s": summary([samples / r["wall_s"] for r in s_runs]),
            },
            "mitsuba": {
                **{k: summary([r[k] for r in m_runs]) for k in ("wall_s", "wall_excl_jit_s", "jit_s", "kernel_exec_s", "cpu_s")},
                "samples_per_s": summary([samples / r["wall_excl_jit_s"] for r in m_runs]),
                "load_s": m_load,
                "cold_jit_s": cold_jit,
                "runs": m_runs,
            },
            "ratio_samples_per_s_snell_over_mitsuba": summary(ratio_excl),
            "ratio_incl_jit": summary(ratio_incl),
            "ratio_cpu_time": summary(ratio_cpu) if ratio_cpu else None,
            "images": images,
        }
    prov["load_average_end"] = loadavg()

    # ------------------------------------------------------------- the table
    med = lambda x: x["median"]
    rng = lambda x, f="{:.2f}": f"{f.format(x['min'])}-{f.format(x['max'])}"
    print()
    print(f"snell / Mitsuba samples/s ({a.width}x{a.height}x{a.spp}, {a.threads} threads; median of {a.reps}, min-max; render wall time only)")
    print("  Mitsuba s = render wall time minus its JIT compile (Dr.Jit codegen + LLVM backend); JIT s = the compile of")
    print("  the scene's first render (later ones reuse the kernel); (+JIT) and incl. JIT charge it to every render;")
    print("  snell/Mitsuba = Mitsuba s / snell s per repetition pair (= samples/s ratio); cpu = the same with CPU seconds")
    hdr = (f"{'scene':<21} {'snell s':>8} {'Mitsuba s':>10} {'(+JIT)':>7} {'JIT s':>6} {'snell/Mitsuba':>21} "
           f"{'incl. JIT':>21} {'cpu':>21}")
    print(hdr)
    print("-" * len(hdr))
    for name, r in results.items():
        s, m = r["snell"], r["mitsuba"]
        q, qi, qc = r["ratio_samples_per_s_snell_over_mitsuba"], r["ratio_incl_jit"], r["ratio_cpu_time"]
        cpu = f"{med(qc):>8.2f} ({rng(qc):>10})" if qc else f"{'-':>21}"
        print(
            f"{name:<21} {med(s['wall_s']):>8.2f} {med(m['wall_excl_jit_s']):>10.2f} "
            f"{med(m['wall_excl_jit_s']) + m['cold_jit_s']:>7.2f} {m['cold_jit_s']:>6.2f} "
            f"{med(q):>8.2f} ({rng(q):>10}) {med(qi):>8.2f} ({rng(qi):>10}) {cpu}"
        )
    print()
    print(f"images: RMSE of {a.block}x{a.block} block means (linear radiance), limit {a.limit:g} x Mitsuba seed-to-seed")
    print("  snell-M0, snell-M1: snell against Mitsuba seeds 0 and 1; M0-M1: Mitsuba seed to seed (its noise);")
    print("  ratio = max(snell-M0, snell-M1) / M0-M1; mean s/M = image mean of snell / Mitsuba's")
    hdr2 = f"{'scene':<21} {'snell-M0':>9} {'snell-M1':>9} {'M0-M1':>9} {'ratio':>6} {'mean s/M':>9}  verdict "
    if a.snell_noise:
        hdr2 += "     s0-s1"
    if a.power_check:
        hdr2 += "   5% dimmer snell"
    print(hdr2)
    print("-" * len(hdr2))
    for name, r in results.items():
        i = r["images"]
        line = (
            f"{name:<21} {i['rmse_snell_mitsuba_seed0']:>9.5f} {i['rmse_snell_mitsuba_seed1']:>9.5f} "
            f"{i['rmse_mitsuba_seed0_seed1']:>9.5f} {i['ratio']:>6.2f} {i['mean_snell'] / i['mean_mitsuba']:>9.4f}  "
            f"{'agree   ' if i['agree'] else 'DISAGREE'}"
        )
        if a.snell_noise:
            line += f" {i['rmse_snell_seed0_seed1']:>9.5f}"
        if a.power_check:
            pr = i["power_check_dimmer_5pct_ratio"]
            line += f"   ratio {pr:.2f}: {'caught' if i['power_check_caught'] else 'NOT caught'}"
        print(line)
    print()
    print("provenance:")
    for k in ("date", "cpu", "load_average_start", "load_average_end", "repo_commit", "repo_dirty", "snell_commit",
              "snell_embree", "snell_rustc", "mitsuba", "drjit", "mitsuba_variant", "mitsuba_llvm_target", "mitsuba_embree", "libllvm", "drjit_cache", "python"):
        print(f"  {k:<19} {prov[k]}")
    print(f"  images in {out}")

    if a.json:
        doc = {"format": "snell bench-peers v1", "provenance": prov, "settings": settings, "scenes": results,
               "images_agree": not failed}
        tmp = Path(a.json + ".tmp")
        tmp.write_text(json.dumps(doc, indent=1) + "\n")
        tmp.replace(a.json)
        print(f"  JSON in {a.json}")
    if jit_cache_tmp:
        shutil.rmtree(jit_cache_tmp, ignore_errors=True)
    if failed:
        print(f"bench-peers: images disagree beyond {a.limit:g}x Mitsuba's seed-to-seed noise: {', '.join(failed)}")
        sys.exit(1)


if __name__ == "__main__":
    main()
