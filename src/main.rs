//! The `snell` command line.
use clap::{Parser, Subcommand};
use snell::dielectric::NestedStrategy;
use snell::render::{render, RenderOptions};
use snell::scene::{load_scene, BuildOptions};
use std::path::PathBuf;
use std::process::ExitCode;

fn long_version() -> &'static str {
    Box::leak(
        format!(
            "{}\ncommit {}\nEmbree {}\n{}\nprofile {}",
            env!("CARGO_PKG_VERSION"),
            snell::provenance::GIT_COMMIT,
            snell::provenance::EMBREE_VERSION,
            snell::provenance::RUSTC_VERSION,
            snell::provenance::PROFILE
        )
        .into_boxed_str(),
    )
}

#[derive(Parser)]
#[command(name = "snell", version = long_version(), about = "Refraction ray tracer on Intel Embree 3")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Render a TOML scene to .png (sRGB 8-bit) or .exr (linear float32).
    Render {
        scene: PathBuf,
        #[arg(short, long, default_value = "out.png")]
        output: PathBuf,
        #[arg(long)]
        spp: Option<u32>,
        #[arg(long)]
        threads: Option<usize>,
        #[arg(long)]
        seed: Option<u64>,
        #[arg(long)]
        width: Option<u32>,
        #[arg(long)]
        height: Option<u32>,
        /// How false hits of nested dielectrics are skipped.
        #[arg(long, default_value = "filter")]
        nested: NestedStrategy,
        /// Diagnostic layers: false_hits,list_depth,tir,fallbacks (EXR channels, or PNGs beside a PNG).
        #[arg(long, value_delimiter = ',')]
        aov: Vec<String>,
        #[arg(long)]
        quiet: bool,
        /// Write render statistics (with provenance) as JSON.
        #[arg(long)]
        stats_json: Option<PathBuf>,
    },
    /// Benchmarks that print ratios measured in one run, with provenance.
    Bench {
        #[command(subcommand)]
        which: BenchCmd,
    },
}

#[derive(Subcommand)]
enum BenchCmd {
    /// Bare Embree rays/s: no filter, accept-all filter, recording filter (one thread).
    Embree {
        #[arg(long, default_value_t = 1_000_000)]
        rays: usize,
        #[arg(long, default_value_t = 5)]
        reps: usize,
    },
    /// Nested-dielectric strategies on every nested and reference scene: trace-only and full render.
    Nested {
        /// Write one JSON object per run (a JSON array) to this file.
        #[arg(long)]
        json: Option<PathBuf>,
        #[arg(long, default_value_t = 5)]
        reps: usize,
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Only these scenes (names in scenes/, without .toml).
        #[arg(long, value_delimiter = ',')]
        scenes: Vec<String>,
        #[arg(long, default_value = "scenes")]
        scenes_dir: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn run(cli: Cli) -> snell::Result<()> {
    match cli.cmd {
        Cmd::Bench {
            which: BenchCmd::Embree { rays, reps },
        } => {
            println!("{}", snell::bench_header());
            let f = snell::bench::embree_bare(rays, reps)?;
            println!(
                "bare Embree, 1 thread, {} incoherent rays against two overlapping meshes ({} triangles), median of {reps}:",
                f.rays, f.triangles
            );
            println!("  no filter          {:8.3} Mrays/s  1.000", f.no_filter);
            println!(
                "  accept-all filter  {:8.3} Mrays/s  {:.3}",
                f.accept_all,
                f.accept_all / f.no_filter
            );
            println!(
                "  recording filter   {:8.3} Mrays/s  {:.3}",
                f.recording,
                f.recording / f.no_filter
            );
            Ok(())
        }
        Cmd::Bench {
            which:
                BenchCmd::Nested {
                    json,
                    reps,
                    threads,
                    scenes,
                    scenes_dir,
                },
        } => {
            println!("{}", snell::bench_header());
            let mut opts = snell::bench::NestedBenchOptions {
                reps,
                threads,
                scenes_dir,
                ..Default::default()
            };
            if !scenes.is_empty() {
                opts.scenes = scenes;
            }
            let runs = snell::bench::nested(&opts, |m| eprintln!("{m}"))?;
            print!("{}", snell::bench::nested_ratios(&runs));
            if let Some(p) = json {
                let prov = snell::provenance::json();
                let v: Vec<serde_json::Value> = runs
                    .iter()
                    .map(|r| {
                        let mut o = serde_json::to_value(r).unwrap_or_default();
                        o["provenance"] = prov.clone();
                        o
                    })
                    .collect();
                let text =
                    serde_json::to_string_pretty(&v).map_err(|e| snell::Error::Invalid(e.to_string()))?;
                snell::image_io::write_atomic(&p, text.as_bytes())?;
            }
            Ok(())
        }
        Cmd::Render {
            scene,
            output,
            spp,
            threads,
            seed,
            width,
            height,
            nested,
            aov,
            quiet,
            stats_json,
        } => {
            for a in &aov {
                if !["false_hits", "list_depth", "tir", "fallbacks"].contains(&a.as_str()) {
                    return Err(snell::Error::Invalid(format!(
                        "--aov: unknown layer \"{a}\"; expected false_hits, list_depth, tir, fallbacks"
                    )));
                }
            }
            let opts = BuildOptions {
                nested,
                ..Default::default()
            };
            let mut s = load_scene(&scene, &opts)?;
            for w in &s.warnings {
                eprintln!("warning: {w}");
            }
            if let Some(v) = spp {
                if v == 0 {
                    return Err(snell::Error::Invalid("--spp must be at least 1".into()));
                }
                s.spp = v;
            }
            if let Some(v) = seed {
                s.seed = v;
            }
            if width.is_some() || height.is_some() {
                s.set_resolution(width.unwrap_or(s.width), height.unwrap_or(s.height))?;
            }
            let r = render(
                &s,
                &RenderOptions {
                    threads,
                    quiet,
                    want_aovs: !aov.is_empty(),
                },
            )?;
            let layers: Vec<(&str, &[f32])> = aov
                .iter()
                .map(|a| {
                    let v: &[f32] = match a.as_str() {
                        "false_hits" => &r.aovs.false_hits,
                        "list_depth" => &r.aovs.list_depth,
                        "tir" => &r.aovs.tir,
                        _ => &r.aovs.fallbacks,
                    };
                    (a.as_str(), v)
                })
                .collect();
            let attrs = [
                ("spp", r.spp_done.to_string()),
                ("provenance", snell::provenance::line()),
            ];
            let is_exr = output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
            snell::image_io::save(
                &output,
                r.width,
                r.height,
                &r.pixels,
                if is_exr { &layers } else { &[] },
                &attrs,
            )?;
            if !is_exr {
                for (name, vals) in &layers {
                    let max = vals.iter().cloned().fold(0.0f32, f32::max).max(1e-9);
                    let px: Vec<glam::Vec3A> = vals.iter().map(|v| glam::Vec3A::splat(v / max)).collect();
                    let p = output.with_extension(format!("{name}.png"));
                    snell::image_io::save(&p, r.width, r.height, &px, &[], &[])?;
                    if !quiet {
                        eprintln!("{name}: {} (white = {max})", p.display());
                    }
                }
            }
            let st = r.stats.to_json(&s, r.spp_done);
            if let Some(p) = stats_json {
                let text =
                    serde_json::to_string_pretty(&st).map_err(|e| snell::Error::Invalid(e.to_string()))?;
                snell::image_io::write_atomic(&p, text.as_bytes())?;
            }
            if r.stats.nan > 0 {
                eprintln!(
                    "warning: {} samples were NaN or Inf and were dropped",
                    r.stats.nan
                );
            }
            if !quiet {
                eprintln!(
                    "rendered {}x{} at {} spp in {:.2} s ({:.3} Msamples/s, {:.3} Mrays/s)",
                    r.width,
                    r.height,
                    r.spp_done,
                    r.stats.wall_s,
                    st["samples_per_s"].as_f64().unwrap_or(0.0) / 1e6,
                    st["rays_per_s"].as_f64().unwrap_or(0.0) / 1e6
                );
            }
            println!("{}", output.display());
            Ok(())
        }
    }
}
