#!/usr/bin/env python3
"""Mitsuba's work per sample on the reference scenes: rays, shadow rays, path
lengths and end reasons of its `path` integrator, counted.

The counting integrator below is Mitsuba 3.9.1's `path` integrator
(src/integrators/path.cpp, `sample`) written out in Python with the same
calls in the same order, run as a wavefront (a Python loop, one evaluation
per depth) so that every mask can be counted between depths. It draws the
same random numbers as the C++ integrator, so its image must equal
`mi.render` with the scene's own `path` integrator at the same seed: the
script checks that before printing (`max |diff|`), which is what makes the
counts Mitsuba's.

Run with the venv of `make bench-peers` (DRJIT_LIBLLVM_PATH as there):

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so \\
        .venv-peers/bin/python bench/peers/same_work.py --json out/same_work.mitsuba.json

The packet shares model Dr.Jit's LLVM megakernel: blocks of 16 lanes, each
looping until its last lane is done, lane i being sample i mod spp of pixel
i div spp (so spp >= 16 makes a block one pixel's samples, as snell's
packets are). docs/same-work.md puts the figures beside snell's
`--stats-json` counters.
"""
import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np

REPO = Path(__file__).resolve().parents[2]
SCENES = ["three_spheres", "glass_of_water", "cylinder_refraction"]
# The variant bench_peers.py times (a Python integrator needs it set before
# its class is defined).
mi.set_variant("llvm_ad_rgb")


def mis_weight(pdf_a, pdf_b):
    """Mitsuba's power heuristic (MonteCarloIntegrator::mis_weight)."""
    a2, b2 = pdf_a * pdf_a, pdf_b * pdf_b
    w = a2 / (a2 + b2)
    return dr.select(dr.isfinite(w), w, 0.0)


class Counts:
    """Per-lane event counts (UInt32 arrays, evaluated with the loop state
    once per depth), summed at the end."""

    def __init__(self, width):
        self.width = width
        self.lanes = {}

    def add(self, name, mask):
        one = dr.select(mask, mi.UInt32(1), mi.UInt32(0))
        self.lanes[name] = self.lanes.get(name, dr.zeros(mi.UInt32, self.width)) + one

    def totals(self):
        return {k: int(np.array(v, dtype=np.uint64).sum()) for k, v in self.lanes.items()}


# Dr.Jit's LLVM megakernel runs the wavefront in blocks of this many lanes
# (its vector width on AVX-512), each block looping until all its lanes are
# done; lane i is sample i % spp of pixel i // spp, so with spp >= 16 a block
# is 16 samples of one pixel, as snell's packets are.
BLOCK = 16


def block_slots(mask):
    """Vector slots of the queries `mask` asks for: BLOCK per block of
    consecutive lanes with at least one set."""
    m = np.array(mask, dtype=bool)
    if m.size % BLOCK:
        return 0
    return int(m.reshape(-1, BLOCK).any(axis=1).sum()) * BLOCK


class CountingPath(mi.SamplingIntegrator):
    def __init__(self, props):
        super().__init__(props)
        self.max_depth = props.get("max_depth", -1)
        self.rr_depth = props.get("rr_depth", 5)
        if self.max_depth < 0:
            self.max_depth = 2**32 - 1
        self.totals = defaultdict(int)
        self.depth_hist = defaultdict(int)

    def sample(self, scene, sampler, ray, medium=None, active=True):
        ray = mi.Ray3f(ray)
        w = dr.width(ray.o.x)
        c = Counts(w)
        active = dr.full(mi.Bool, True, w) & mi.Bool(active)
        throughput = dr.full(mi.Spectrum, 1.0, w)
        result = dr.zeros(mi.Spectrum, w)
        eta = dr.full(mi.Float, 1.0, w)
        depth = dr.zeros(mi.UInt32, w)
        valid_ray = dr.full(mi.Bool, scene.environment() is not None, w)  # hide_emitters = false
        prev_si = dr.zeros(mi.Interaction3f, w)
        prev_bsdf_pdf = dr.full(mi.Float, 1.0, w)
        prev_bsdf_delta = dr.full(mi.Bool, True, w)
        ctx = mi.BSDFContext()
        # The depth at which each path ended.
        end_depth = dr.full(mi.UInt32, 99, w)

        c.add("samples", active)
        c.add("camera_rays", active)
        self.totals["camera_slots"] += block_slots(active)
        pi = scene.ray_intersect_preliminary(ray, coherent=True, active=active)

        while dr.any(active):
            si = pi.compute_surface_interaction(ray, mi.RayFlags.All, active)

            # Direct emission (path.cpp: "Direct emission"). A lane without
            # an emitter gets 0 from the null pointer's call.
            ds = mi.DirectionSample3f(scene, si, prev_si)
            em_pdf = scene.pdf_emitter_direction(prev_si, ds, active & ~prev_bsdf_delta)
            em_pdf = dr.select(prev_bsdf_delta, 0.0, em_pdf)
            mis_bsdf = mis_weight(prev_bsdf_pdf, em_pdf)
            le = ds.emitter.eval(si, active & (prev_bsdf_pdf > 0.0))
            result = dr.select(active, dr.fma(throughput, le * mis_bsdf, result), result)

            active_next = active & (depth + 1 < self.max_depth) & si.is_valid()
            c.add("ended_escaped", active & ~si.is_valid())
            c.add("ended_max_depth", active & si.is_valid() & ~(depth + 1 < self.max_depth))
            c.add("vertices", active & si.is_valid())

            bsdf = si.bsdf(ray)

            # Emitter sampling: scene.sample_emitter_direction with the
            # visibility test written out (as in scene.cpp), so that its
            # shadow rays are counted.
            active_em = active_next & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
            c.add("nee_vertices", active_em)
            ds, em_weight = scene.sample_emitter_direction(si, sampler.next_2d(active), False, active_em)
            # (No in-place `&=` below: it would change `shadow` too.)
            active_em = active_em & (ds.pdf != 0.0)
            shadow = active_em
            em_unoccluded = em_weight
            c.add("shadow_rays", shadow)
            c.add("shadow_rays_to_environment",
                  shadow & mi.has_flag(ds.emitter.flags(), mi.EmitterFlags.Infinite))
            from_light = shadow & si.shape.is_emitter()
            c.add("shadow_rays_from_light_surface", from_light)
            dr.eval(shadow)
            self.totals["shadow_slots"] += block_slots(shadow)
            # The same without the shadow rays from a light's own surface
            # (which snell does not cast).
            self.totals["shadow_slots_off_lights"] += block_slots(shadow & ~from_light)
            occluded = scene.ray_test(si.spawn_ray_to(ds.p), shadow)
            em_weight = dr.select(occluded, 0.0, em_weight)
            ds.pdf = dr.select(occluded, 0.0, ds.pdf)
            active_em = active_em & (ds.pdf != 0.0)
            wo = si.to_local(ds.d)

            # BSDF evaluation and sampling.
            sample_1 = sampler.next_1d(active)
            sample_2 = sampler.next_2d(active)
            bsdf_val, bsdf_pdf, bsdf_sample, bsdf_weight = bsdf.eval_pdf_sample(
                ctx, si, wo, sample_1, sample_2, active)

            # Shadow rays whose connection weighs 0 whatever they find: the
            # sample below the surface (the BSDF's value 0), behind the
            # light (its radiance 0), or at a black surface. snell knows
            # these before it would cast them and does not.
            weighs_0 = shadow & ((dr.max(bsdf_val) == 0.0) | (dr.max(em_unoccluded) == 0.0))
            c.add("shadow_rays_weighing_0", weighs_0)
            c.add("shadow_rays_weighing_0_below_surface",
                  weighs_0 & ~from_light & (mi.Frame3f.cos_theta(wo) <= 0.0))
            c.add("shadow_rays_weighing_0_from_light_surface", weighs_0 & from_light)

            mis_em = dr.select(ds.delta, 1.0, mis_weight(ds.pdf, bsdf_pdf))
            result = dr.select(active_em, dr.fma(throughput, bsdf_val * em_weight * mis_em, result), result)

            # BSDF sampling: the next ray.
            new_ray = si.spawn_ray(si.to_world(bsdf_sample.wo))
            ray = dr.select(active, new_ray, ray)
            throughput = dr.select(active, throughput * bsdf_weight, throughput)
            eta = dr.select(active, eta * bsdf_sample.eta, eta)
            valid_ray |= active & si.is_valid() & ~mi.has_flag(bsdf_sample.sampled_type, mi.BSDFFlags.Null)
            prev_si = dr.select(active, mi.Interaction3f(si), prev_si)
            prev_bsdf_pdf = dr.select(active, bsdf_sample.pdf, prev_bsdf_pdf)
            prev_bsdf_delta = dr.select(active, mi.has_flag(bsdf_sample.sampled_type, mi.BSDFFlags.Delta),
                                        prev_bsdf_delta)

            # Stopping criterion (path.cpp, unchanged: RR from depth rr_depth
            # with q = min(max(throughput) * eta^2, 0.95)).
            depth = dr.select(active & si.is_valid(), depth + 1, depth)
            tmax = dr.max(throughput)
            rr_prob = dr.minimum(tmax * dr.square(eta), 0.95)
            rr_active = depth >= self.rr_depth
            rr_continue = sampler.next_1d(active) < rr_prob
            throughput = dr.select(active & rr_active, throughput * dr.rcp(rr_prob), throughput)
            zero = active_next & (tmax == 0.0)
            c.add("ended_absorbed", zero)
            c.add("ended_roulette", active_next & ~zero & rr_active & ~rr_continue)
            still = active_next & (~rr_active | rr_continue) & (tmax != 0.0)
            end_depth = dr.select(active & ~still, depth, end_depth)
            active = still
            c.add("extension_rays", active)
            dr.eval(active)
            self.totals["extension_slots"] += block_slots(active)
            pi = scene.ray_intersect_preliminary(ray, coherent=False, active=active)
            # One evaluation per depth (the loop test evaluates what is scheduled).
            dr.schedule(ray, pi, throughput, result, eta, depth, valid_ray, prev_si, prev_bsdf_pdf,
                        prev_bsdf_delta, active, end_depth, *c.lanes.values())
            sampler.schedule_state()

        for k, v in c.totals().items():
            self.totals[k] += v
        d, k = np.unique(np.array(end_depth), return_counts=True)
        for di, ki in zip(d.tolist(), k.tolist()):
            self.depth_hist[di] += ki
        return dr.select(valid_ray, result, 0.0), valid_ray, []


mi.register_integrator("counting_path", lambda props: CountingPath(props))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default=str(REPO / "scenes"))
    p.add_argument("--scene", action="append", choices=SCENES)
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", help="write the counts as JSON")
    a = p.parse_args()
    out = {}
    for name in a.scene or SCENES:
        xml = Path(a.scenes) / f"{name}.xml"
        scene = mi.load_file(str(xml), width=a.width, height=a.height, spp=a.spp, seed=a.seed)
        ref = np.array(mi.render(scene, spp=a.spp, seed=a.seed))
        other = np.array(mi.render(scene, spp=a.spp, seed=a.seed + 1))
        # The scenes' integrator: path, max_depth 16, rr_depth 5.
        cp = mi.load_dict({"type": "counting_path", "max_depth": 16, "rr_depth": 5})
        img = mi.render(scene, spp=a.spp, seed=a.seed, integrator=cp)
        img = np.array(img)
        diff = float(np.abs(img - ref).max())
        # What a difference of noise looks like: the next seed's image.
        seed_diff = float(np.abs(other - ref).max())
        mean = float(ref.mean())
        c = dict(cp.totals)
        s = c["samples"]
        per = {k: v / s for k, v in sorted(c.items()) if k != "samples"}
        per["segments"] = (c["camera_rays"] + c["extension_rays"]) / s
        # snell's packet_lane_share and shadow_packet_lane_share.
        per["packet_lane_share"] = (c["camera_rays"] + c["extension_rays"]) / (
            c["camera_slots"] + c["extension_slots"])
        per["shadow_packet_lane_share"] = c["shadow_rays"] / max(c["shadow_slots"], 1)
        per["shadow_packet_lane_share_off_lights"] = (
            c["shadow_rays"] - c.get("shadow_rays_from_light_surface", 0)) / max(c["shadow_slots_off_lights"], 1)
        for k in ("camera_slots", "extension_slots", "shadow_slots", "shadow_slots_off_lights"):
            per.pop(k)
        hist = {d: k / s for d, k in sorted(cp.depth_hist.items())}
        out[name] = {"samples": s, "per_sample": per, "ended_at_depth": hist,
                     "max_abs_diff_vs_path": diff, "max_abs_diff_next_seed": seed_diff,
                     "image_mean": mean, "width": a.width, "height": a.height, "spp": a.spp,
                     "seed": a.seed, "mitsuba": mi.__version__, "drjit": dr.__version__}
        print(f"{name}: {s} samples, image mean {mean:.6f}; "
              f"vs Mitsuba's own path integrator: max |diff| = {diff:.3g} "
              f"(against seed {a.seed + 1}: {seed_diff:.3g})")
        for k, v in per.items():
            print(f"  {k:34s} {v:.4f}")
        print("  ended at depth (share of paths):", {d: round(v, 4) for d, v in hist.items()})
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        Path(a.json).write_text(json.dumps(out, indent=1))
    # Counts of an integrator that draws otherwise are not Mitsuba's.
    bad = [k for k, v in out.items() if v["max_abs_diff_vs_path"] != 0.0]
    if bad:
        print(f"the counting integrator's image differs from Mitsuba's on {bad}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
