//! `snell bench`: the benchmarks that print ratios measured in one run.
use crate::args::{BenchEmbreeArgs, BenchGrinArgs, BenchNestedArgs, BenchRenderArgs};
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

pub fn bench_grin(a: BenchGrinArgs) -> Result<()> {
    let opts = snell::bench::GrinBenchOptions {
        scenes_dir: a.scenes,
        reps: a.reps,
        spp: a.spp,
        scale: a.scale,
        threads: a.threads,
    };
    // The command that regenerates the table, as the document shows it:
    // the output files are left out, they do not change the figures.
    let mut command = vec!["snell".to_string()];
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--markdown" | "--json" => {
                args.next();
            }
            a if a.starts_with("--markdown=") || a.starts_with("--json=") => {}
            _ => command.push(arg),
        }
    }
    let command = command.join(" ");
    say!("{}", snell::bench_header());
    let runs = snell::bench::grin(&opts, |m| eprintln!("{m}"))?;
    let doc = snell::bench::grin_table(&runs, &opts, &command);
    // The document's own first line is the provenance printed above.
    say!("{}", doc.split_once('\n').map_or(doc.as_str(), |(_, t)| t).trim());
    if let Some(p) = &a.markdown {
        snell::image_io::write_atomic(p, doc.as_bytes())?;
    }
    if let Some(p) = &a.json {
        write_runs_json(p, &runs)?;
    }
    Ok(())
}
