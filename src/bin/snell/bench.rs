//! `snell bench`: the benchmarks that print ratios measured in one run.
use crate::args::{BenchEmbreeArgs, BenchNestedArgs, BenchRenderArgs};
use crate::write::write_runs_json;
use snell::{Error, Result};

pub fn bench_embree(a: BenchEmbreeArgs) -> Result<()> {
    say!("{}", snell::bench_header());
    let f = snell::bench::embree_bare(a.rays, a.reps)?;
    say!("{f}");
    Ok(())
}

pub fn bench_nested(a: BenchNestedArgs) -> Result<()> {
    say!("{}", snell::bench_header());
    let mut opts = snell::bench::NestedBenchOptions {
        reps: a.reps,
        threads: a.threads,
        scenes_dir: a.scenes_dir,
        trace_rays_per_rep: a.trace_rays_per_rep,
        ..Default::default()
    };
    if !a.scenes.is_empty() {
        opts.scenes = a.scenes;
    }
    if !a.strategies.is_empty() {
        opts.strategies = a.strategies;
    }
    if let Some(m) = &a.mode {
        opts.trace = m == "trace";
        opts.render_mode = m == "render";
    }
    let runs = snell::bench::nested(&opts, |m| eprintln!("{m}"))?;
    say!("{}", snell::bench::nested_ratios(&runs).trim_end());
    if let Some(p) = &a.json {
        write_runs_json(p, &runs)?;
    }
    Ok(())
}

pub fn bench_render(a: BenchRenderArgs) -> Result<()> {
    let bad = || {
        Error::Invalid(format!(
            "--size {}: expected WIDTHxHEIGHTxSPP, e.g. 320x240x16",
            a.size
        ))
    };
    let v: Vec<u32> = a
        .size
        .split('x')
        .map(|t| t.trim().parse().map_err(|_| bad()))
        .collect::<Result<_>>()?;
    let [w, h, spp] = v[..] else {
        return Err(bad());
    };
    if w == 0 || h == 0 || spp == 0 {
        return Err(bad());
    }
    let mut opts = snell::ceiling::CeilingOptions {
        scenes_dir: a.scenes_dir,
        render: (w, h, spp),
        record_spp: a.record_spp,
        threads: a.threads,
        reps: a.reps,
        ..Default::default()
    };
    if !a.scenes.is_empty() {
        opts.scenes = a.scenes;
    }
    say!("{}", snell::bench_header());
    let runs = snell::ceiling::ceiling(&opts, |m| eprintln!("{m}"))?;
    say!("{}", snell::ceiling::table(&runs, &opts).trim_end());
    if let Some(p) = &a.json {
        write_runs_json(p, &runs)?;
    }
    Ok(())
}
