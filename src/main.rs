//! The `snell` command line.
#![deny(unsafe_code)]
use clap::{Parser, Subcommand};
use snell::dielectric::NestedStrategy;
use snell::render::{RenderOptions, RenderSettings};
use snell::scene::{load_scene, BuildOptions};
use std::path::PathBuf;

/// Print to stdout, ignoring a closed pipe (`snell … | head` must not panic).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}
use std::process::ExitCode;

/// `snell --version`: the build's provenance (commit, Embree, rustc, profile).
const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    "\ncommit ",
    env!("SNELL_GIT_COMMIT"),
    "\nEmbree ",
    env!("SNELL_EMBREE_VERSION"),
    "\n",
    env!("SNELL_RUSTC_VERSION"),
    "\nprofile ",
    env!("SNELL_PROFILE")
);

#[derive(Parser)]
#[command(name = "snell", version = LONG_VERSION, about = "Refraction ray tracer on Intel Embree 3")]
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
        aov: Vec<snell::render::Aov>,
        #[arg(long)]
        quiet: bool,
        /// Write render statistics (with provenance) as JSON.
        #[arg(long)]
        stats_json: Option<PathBuf>,
        /// Override a scene key: objects.water.material.ior=1.34, film.spp=256 (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// A sweep: with --sweep-index I, the same as --set KEY=VI.
        #[arg(long, value_name = "KEY=V1,V2,...", requires = "sweep_index")]
        sweep: Option<String>,
        /// Which value of --sweep to render (counting from 1).
        #[arg(long, value_name = "I", requires = "sweep")]
        sweep_index: Option<u32>,
        #[command(flatten)]
        farm: FarmFlags,
    },
    /// Merge part EXRs (regions, sample ranges; directories stand for their .exr files)
    /// into the whole render, bit for bit equal to a single render.
    Merge {
        #[arg(short, long)]
        output: PathBuf,
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Also write an sRGB PNG of the merged image.
        #[arg(long)]
        png: Option<PathBuf>,
        /// Write the parts' stats, summed.
        #[arg(long)]
        stats_json: Option<PathBuf>,
        /// Keep the exact sums in the output (a part covering the whole render).
        #[arg(long)]
        part: bool,
        /// Create the output's directory when it is missing.
        #[arg(long)]
        mkdir: bool,
        #[arg(long)]
        quiet: bool,
    },
    /// Print a Markdown table of stats JSON files (a sweep's tasks; directories
    /// stand for their .json files), optionally to a file.
    Table {
        #[arg(required = true)]
        stats: Vec<PathBuf>,
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Audits: `snell audit nested SCENE --rays N` compares interior lists with point-in-solid tests.
    Audit {
        #[command(subcommand)]
        which: AuditCmd,
    },
    /// Trace single rays in gradient-index fields (JSON in, JSON out).
    GrinTrace {
        queries: PathBuf,
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Warp points through a plate or a hollow cylinder (JSON in, JSON out).
    WarpPoints {
        queries: PathBuf,
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Render a [warp] scene with straight primary rays through warped meshes
    /// (Mukai et al.); --compare also runs the exact trace and reports the error.
    WarpRender {
        scene: PathBuf,
        #[arg(short, long, default_value = "warp.png")]
        output: PathBuf,
        #[arg(long)]
        width: Option<u32>,
        #[arg(long)]
        height: Option<u32>,
        #[arg(long)]
        threads: Option<usize>,
        /// Longest projected edge after subdivision, in pixels (overrides [warp].subdivide).
        #[arg(long)]
        subdivide: Option<f64>,
        /// exact or paper (overrides [warp].method).
        #[arg(long)]
        method: Option<String>,
        /// Weight by the Fresnel transmittance of each pixel's path.
        #[arg(long)]
        fresnel: bool,
        /// Run the exact trace too; write a heatmap of the position error to this file
        /// (black 0, red 1 pixel, yellow >= 2, magenta: different objects).
        #[arg(long)]
        compare: Option<PathBuf>,
        /// Write the exact trace's image here as well (with --compare).
        #[arg(long)]
        exact_output: Option<PathBuf>,
        #[arg(long)]
        stats_json: Option<PathBuf>,
        #[arg(long)]
        quiet: bool,
    },
    /// Mutation-fuzz the scene loader and renderer with the shipped scenes as seeds.
    Fuzz {
        #[arg(long, default_value_t = 100_000)]
        cases: u64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        #[arg(long, default_value = "scenes")]
        scenes_dir: PathBuf,
        /// Start at this scene case (to reproduce one: --first N --cases 1 --json-cases 0).
        #[arg(long, default_value_t = 0)]
        first: u64,
        /// Mutated grin-trace / warp-points documents (default: as many as --cases).
        #[arg(long)]
        json_cases: Option<u64>,
        #[arg(long, default_value = "tests/data/fuzz")]
        json_dir: PathBuf,
    },
    /// Run the measurements and write DIR/index.html (plots, pictures) and DIR/figures.json.
    Report {
        #[arg(short, long, value_name = "DIR")]
        output: PathBuf,
        /// Small images and few repetitions (about 3 minutes on 2 cores).
        #[arg(long)]
        quick: bool,
        #[arg(long, default_value = "scenes")]
        scenes_dir: PathBuf,
    },
    /// Benchmarks that print ratios measured in one run, with provenance.
    Bench {
        #[command(subcommand)]
        which: BenchCmd,
    },
}

/// Render-farm options of `snell render` (docs/farm.md).
#[derive(clap::Args)]
struct FarmFlags {
    /// Render only pixels x0..x1, y0..y1 (half-open; the EXR's data window).
    #[arg(long, value_name = "x0,x1,y0,y1")]
    region: Option<String>,
    /// Render cell IX,IY of an NX x NY grid over the film.
    #[arg(long, value_name = "IX/NX,IY/NY")]
    region_cell: Option<String>,
    /// Render sample indices START..START+COUNT of the film's spp.
    #[arg(long, value_name = "START:COUNT")]
    samples: Option<String>,
    /// Render chunk K of the film's spp cut into N ranges.
    #[arg(long, value_name = "K/N")]
    sample_chunk: Option<String>,
    /// Continue a partial part EXR (Ctrl-C): render the samples it lacks.
    #[arg(long, value_name = "PART.exr")]
    resume: Option<PathBuf>,
    /// Continue OUTPUT's own partial (NAME.partial.exr) when there is one, and
    /// remove it once the render completes (farm tasks that are retried).
    #[arg(long)]
    resume_partial: bool,
    /// Write the EXR as a part (with exact sums) even for a whole render.
    #[arg(long)]
    part: bool,
    /// Print progress lines (`openjd_progress: P`) to stderr, for farm logs.
    #[arg(long)]
    progress_lines: bool,
    /// Create the output's directory when it is missing.
    #[arg(long)]
    mkdir: bool,
}

#[derive(Subcommand)]
enum AuditCmd {
    /// Cast N rays (a share exactly at mesh vertices and edges and at analytic
    /// silhouettes); on every segment between true hits compare the medium the
    /// interior list claims with a point-in-solid test; report per strategy.
    Nested {
        scene: PathBuf,
        #[arg(long, default_value_t = 1_000_000)]
        rays: u64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Strategies to audit.
        #[arg(long, value_delimiter = ',', default_value = "filter,recast,toggle")]
        nested: Vec<NestedStrategy>,
        #[arg(long)]
        threads: Option<usize>,
        #[arg(long)]
        json: Option<PathBuf>,
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

/// The first few findings of a fuzz run, each with its document.
fn print_findings(panics: &[String], unlocated: &[String], slow: &[(String, f64)]) {
    for p in panics.iter().take(5) {
        say!("PANIC {p}");
    }
    for e in unlocated.iter().take(5) {
        say!("UNLOCATED {e}");
    }
    for (d, el) in slow.iter().take(5) {
        say!("SLOW {el:.2} s: {d}");
    }
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
        Cmd::Report {
            output,
            quick,
            scenes_dir,
        } => {
            let opts = snell::report::ReportOptions {
                out: output,
                quick,
                scenes_dir,
            };
            let command = std::env::args().collect::<Vec<_>>().join(" ");
            let index = snell::report::run(&opts, &command, |m| eprintln!("{m}"))?;
            say!("{}", index.display());
            Ok(())
        }
        Cmd::GrinTrace { queries, output } => {
            let text = std::fs::read_to_string(&queries).map_err(|e| snell::Error::io(&queries, e))?;
            let out = snell::media::grin_trace_json(&text)
                .map_err(|e| snell::Error::Invalid(format!("{}: {e}", queries.display())))?;
            match output {
                Some(p) => snell::image_io::write_atomic(&p, out.as_bytes())?,
                None => say!("{out}"),
            }
            Ok(())
        }
        Cmd::WarpPoints { queries, output } => {
            let text = std::fs::read_to_string(&queries).map_err(|e| snell::Error::io(&queries, e))?;
            let out = snell::warp::points::warp_points_json(&queries.display().to_string(), &text)
                .map_err(snell::Error::Invalid)?;
            match output {
                Some(p) => snell::image_io::write_atomic(&p, out.as_bytes())?,
                None => say!("{out}"),
            }
            Ok(())
        }
        Cmd::WarpRender {
            scene,
            output,
            width,
            height,
            threads,
            subdivide,
            method,
            fresnel,
            compare,
            exact_output,
            stats_json,
            quiet,
        } => {
            use snell::warp::render::{run as warp_run, WarpRunOptions};
            let method = match method.as_deref() {
                None => None,
                Some("exact") => Some(snell::warp::WarpMethod::Exact),
                Some("paper") => Some(snell::warp::WarpMethod::Paper),
                Some(o) => {
                    return Err(snell::Error::Invalid(format!(
                        "--method: expected exact or paper, got \"{o}\""
                    )))
                }
            };
            if exact_output.is_some() && compare.is_none() {
                return Err(snell::Error::Invalid("--exact-output needs --compare".into()));
            }
            let mut s = load_scene(&scene, &BuildOptions::default())?;
            if width.is_some() || height.is_some() {
                s.set_resolution(width.unwrap_or(s.width), height.unwrap_or(s.height))?;
            }
            let rep = warp_run(
                &s,
                &WarpRunOptions {
                    threads,
                    subdivide,
                    method,
                    fresnel: fresnel.then_some(true),
                    compare: compare.is_some(),
                },
            )?;
            snell::image_io::save(
                &output,
                rep.frame.width,
                rep.frame.height,
                &rep.frame.pixels,
                &[],
                &[],
            )?;
            if let (Some(path), Some((ex, cmp, heat))) = (&compare, &rep.exact) {
                snell::image_io::save(path, ex.width, ex.height, heat, &[], &[])?;
                if let Some(p) = &exact_output {
                    snell::image_io::save(p, ex.width, ex.height, &ex.pixels, &[], &[])?;
                }
                if !quiet {
                    eprintln!(
                        "compare: RMSE {:.4}; position error over {} matched pixels: mean {:.3e} / median {:.3e} / p95 {:.3e} / max {:.3e} units = mean {:.3} / median {:.3} / p95 {:.3} / max {:.2} pixel footprints; {} pixels ({:.2}%) show different objects; heatmap {}",
                        cmp.rmse,
                        cmp.matched,
                        cmp.pos_mean,
                        cmp.pos_median,
                        cmp.pos_p95,
                        cmp.pos_max,
                        cmp.px_mean,
                        cmp.px_median,
                        cmp.px_p95,
                        cmp.px_max,
                        cmp.mismatched,
                        100.0 * cmp.mismatched as f64 / cmp.pixels.max(1) as f64,
                        path.display()
                    );
                    eprintln!(
                        "speed: warp frame {:.4} s (warp {:.4} + copies {:.4} + primary rays {:.4}) vs exact trace {:.4} s: {:.2}x (render only {:.2}x)",
                        rep.frame_s(),
                        rep.warp_s,
                        rep.build_s,
                        rep.frame.render_s,
                        ex.render_s,
                        ex.render_s / rep.frame_s().max(1e-12),
                        ex.render_s / rep.frame.render_s.max(1e-12)
                    );
                }
            }
            if !quiet {
                eprintln!(
                    "warp: {} vertices, {} triangles (longest projected edge {:.2} px), {} images, {} triangles in no copy; copies {:?}",
                    rep.vertices, rep.triangles, rep.max_edge_px, rep.images, rep.dropped_triangles, rep.copies
                );
            }
            if let Some(p) = stats_json {
                let text = serde_json::to_string_pretty(&rep.to_json())
                    .map_err(|e| snell::Error::Invalid(e.to_string()))?;
                snell::image_io::write_atomic(&p, text.as_bytes())?;
            }
            say!("{}", output.display());
            Ok(())
        }
        Cmd::Fuzz {
            cases,
            seed,
            scenes_dir,
            first,
            json_cases,
            json_dir,
        } => {
            let seeds = snell::fuzz::shipped_scenes(&scenes_dir);
            if seeds.is_empty() {
                return Err(snell::Error::Invalid(format!(
                    "no .toml scenes in {}",
                    scenes_dir.display()
                )));
            }
            let t = std::time::Instant::now();
            let rep = snell::fuzz::run_from(
                &seeds,
                &scenes_dir,
                first,
                cases,
                seed,
                std::time::Duration::from_secs(1),
            );
            say!(
                "{} cases in {:.1} s: {} rendered, {} located errors, {} other errors, {} panics, {} slower than 1 s; slowest {:.3} s ({})",
                rep.cases,
                t.elapsed().as_secs_f64(),
                rep.rendered,
                rep.errors - rep.unlocated_errors.len() as u64,
                rep.unlocated_errors.len(),
                rep.panics.len(),
                rep.slow.len(),
                rep.slowest.0,
                rep.slowest.1
            );
            print_findings(&rep.panics, &rep.unlocated_errors, &rep.slow);
            let json_seeds = snell::fuzz::json_seeds(&json_dir);
            let jcases = json_cases.unwrap_or(cases);
            let t = std::time::Instant::now();
            let jr = snell::fuzz::run_json(&json_seeds, jcases, seed, std::time::Duration::from_secs(1));
            say!(
                "{} grin-trace/warp-points documents in {:.1} s ({} seeds): {} answered ({} queries or points with an error status), {} refused with a located error, {} unlocated, {} panics, {} slower than 1 s; slowest {:.3} s ({})",
                jr.cases,
                t.elapsed().as_secs_f64(),
                json_seeds.len(),
                jr.answered,
                jr.item_errors,
                jr.refused - jr.unlocated.len() as u64,
                jr.unlocated.len(),
                jr.panics.len(),
                jr.slow.len(),
                jr.slowest.0,
                jr.slowest.1
            );
            print_findings(&jr.panics, &jr.unlocated, &jr.slow);
            if json_seeds.is_empty() && jcases > 0 {
                say!("warning: no JSON seeds in {}", json_dir.display());
            }
            let json_ok = jr.panics.is_empty() && jr.unlocated.is_empty() && jr.slow.is_empty();
            if json_ok && rep.panics.is_empty() && rep.unlocated_errors.is_empty() && rep.slow.is_empty() {
                Ok(())
            } else {
                Err(snell::Error::Invalid(
                    "the fuzzer found problems (see above)".into(),
                ))
            }
        }
        Cmd::Audit {
            which:
                AuditCmd::Nested {
                    scene,
                    rays,
                    seed,
                    nested,
                    threads,
                    json,
                },
        } => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads.unwrap_or(0))
                .build()
                .map_err(|e| snell::Error::Invalid(e.to_string()))?;
            say!("{}", snell::bench_header());
            let mut out = Vec::new();
            let s = load_scene(&scene, &BuildOptions::default())?;
            for strategy in nested {
                let t = std::time::Instant::now();
                let tr = snell::integrator::Tracer { scene: &s, strategy };
                let r = pool.install(|| snell::audit::audit_scene(tr, rays, seed))?;
                say!(
                    "{:<7} {} rays ({} at vertices/edges, {} at silhouettes), {} segments: {} mismatches (+{} within f32 resolution of a surface), {} left non-empty, {} wrong rays ({:.4}%) [{:.1} s]",
                    strategy.name(),
                    r.rays,
                    r.vertex_edge_rays,
                    r.silhouette_rays,
                    r.segments,
                    r.mismatches,
                    r.ambiguous,
                    r.left_nonempty,
                    r.wrong_rays,
                    100.0 * r.wrong_rays as f64 / r.rays.max(1) as f64,
                    t.elapsed().as_secs_f64()
                );
                out.push(serde_json::json!({"scene": scene.display().to_string(), "strategy": strategy.name(), "report": r, "provenance": snell::provenance::json()}));
            }
            if let Some(p) = json {
                let text =
                    serde_json::to_string_pretty(&out).map_err(|e| snell::Error::Invalid(e.to_string()))?;
                snell::image_io::write_atomic(&p, text.as_bytes())?;
            }
            Ok(())
        }
        Cmd::Bench {
            which: BenchCmd::Embree { rays, reps },
        } => {
            say!("{}", snell::bench_header());
            let f = snell::bench::embree_bare(rays, reps)?;
            say!(
                "bare Embree, 1 thread, {} incoherent rays against two overlapping meshes ({} triangles), median of {reps}:",
                f.rays, f.triangles
            );
            say!("  no filter          {:8.3} Mrays/s  1.000", f.no_filter);
            say!(
                "  accept-all filter  {:8.3} Mrays/s  {:.3}",
                f.accept_all,
                f.accept_all / f.no_filter
            );
            say!(
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
            say!("{}", snell::bench_header());
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
            say!("{}", snell::bench::nested_ratios(&runs).trim_end());
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
        Cmd::Merge {
            output,
            parts,
            png,
            stats_json,
            part,
            mkdir,
            quiet,
        } => {
            if mkdir {
                snell::farm::make_parent(&output)?;
            }
            let files = snell::merge::collect_inputs(&parts)?;
            let parts = files
                .iter()
                .map(|f| snell::part::read_part(f))
                .collect::<snell::Result<Vec<_>>>()?;
            let m = snell::merge::merge(&parts)?;
            let (w, h) = (m.meta.film_width, m.meta.film_height);
            let is_exr = output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
            let attrs = [
                ("spp", m.meta.spp.to_string()),
                ("complete", "true".to_string()),
                ("merged_parts", files.len().to_string()),
                ("provenance", snell::provenance::line()),
            ];
            if part && is_exr {
                snell::part::write_part(&output, &m.meta, &m.pixels, &m.accum, &attrs, Some(&m.stats))?;
            } else {
                snell::image_io::save(&output, w, h, &m.pixels, &[], &attrs)?;
            }
            if let Some(p) = &png {
                snell::image_io::save(p, w, h, &m.pixels, &[], &[])?;
            }
            if let Some(p) = stats_json {
                let text = serde_json::to_string_pretty(&m.stats)
                    .map_err(|e| snell::Error::Invalid(e.to_string()))?;
                snell::image_io::write_atomic(&p, text.as_bytes())?;
            }
            if !quiet {
                eprintln!(
                    "merged {} parts into {w}x{h} at {} spp: {} rays, {:.2} s of task time",
                    files.len(),
                    m.meta.spp,
                    m.stats["rays"],
                    m.stats["wall_s"].as_f64().unwrap_or(0.0)
                );
            }
            say!("{}", output.display());
            Ok(())
        }
        Cmd::Table { stats, output } => {
            let t = snell::farm::stats_table(&stats)?;
            match output {
                Some(p) => snell::image_io::write_atomic(&p, t.as_bytes())?,
                None => say!("{}", t.trim_end()),
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
            mut set,
            sweep,
            sweep_index,
            farm,
        } => {
            if let (Some(sw), Some(i)) = (&sweep, sweep_index) {
                set.push(snell::overrides::sweep_value(sw, i)?);
            }
            if farm.mkdir {
                snell::farm::make_parent(&output)?;
            }
            let load_t = std::time::Instant::now();
            let (s, scene_id) = snell::farm::load(&scene, &set, &BuildOptions::default(), nested)?;
            let load_s = load_t.elapsed().as_secs_f64();
            for w in &s.warnings {
                eprintln!("warning: {w}");
            }
            let mut settings = RenderSettings::from_scene(&s).with_strategy(nested);
            if let Some(v) = spp {
                if v == 0 {
                    return Err(snell::Error::Invalid("--spp must be at least 1".into()));
                }
                settings = settings.with_spp(v);
            }
            if let Some(v) = seed {
                settings = settings.with_seed(v);
            }
            if width.is_some() || height.is_some() {
                settings = settings.with_resolution(width.unwrap_or(s.width), height.unwrap_or(s.height))?;
            }
            let is_exr = output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
            let own_partial = snell::farm::partial_path(&output);
            let auto_resume = farm.resume_partial && farm.resume.is_none() && own_partial.is_file();
            if auto_resume && !quiet {
                eprintln!("resuming {}", own_partial.display());
            }
            let fa = snell::farm::FarmArgs {
                region: farm.region,
                region_cell: farm.region_cell,
                samples: farm.samples,
                sample_chunk: farm.sample_chunk,
                resume: if auto_resume {
                    Some(own_partial.clone())
                } else {
                    farm.resume
                },
                part: farm.part,
            };
            let plan = snell::farm::plan(&settings, &scene_id, &fa, is_exr)?;
            if plan.is_part && !aov.is_empty() {
                return Err(snell::Error::Invalid(
                    "--aov layers are not merged: render them in one piece (no --region, --samples, --resume or --part)"
                        .into(),
                ));
            }
            snell::render::PROGRESS_LINES.store(farm.progress_lines, std::sync::atomic::Ordering::Relaxed);
            // Ctrl-C (or SIGTERM, SIGHUP: a farm cancelling the task) stops at
            // the next tile boundary and the image so far is written, clearly
            // named; a second signal exits at once.
            let _ = ctrlc::set_handler(|| {
                if snell::render::INTERRUPT.swap(true, std::sync::atomic::Ordering::SeqCst) {
                    std::process::exit(130);
                }
                eprintln!("\ninterrupted: finishing the tiles in progress (Ctrl-C again to exit at once)");
            });
            let complete_output = output.clone();
            let r = snell::render::render_part(
                &s,
                &settings,
                &RenderOptions {
                    threads,
                    quiet,
                    want_aovs: !aov.is_empty(),
                },
                &plan.spec,
            )?;
            let output = if r.complete {
                output
            } else {
                let p = snell::farm::partial_path(&output);
                eprintln!(
                    "interrupted: {} of {} tiles done ({} spp each, the rest black); writing {}",
                    r.tiles_done,
                    r.tiles_total,
                    r.spp_done,
                    p.display()
                );
                p
            };
            let mut layers: Vec<(&str, &[f32])> = aov.iter().map(|&a| (a.name(), r.aovs.layer(a))).collect();
            if !r.complete {
                layers.push(("spp", &r.pixel_spp));
            }
            let attrs = [
                ("spp", r.spp_done.to_string()),
                ("complete", r.complete.to_string()),
                ("tiles_done", format!("{}/{}", r.tiles_done, r.tiles_total)),
                ("provenance", snell::provenance::line()),
            ];
            let mut st = r.stats.to_json(&settings, r.spp_done);
            st["cpu_s"] = serde_json::json!(snell::farm::cpu_seconds());
            st["load_s"] = serde_json::json!(load_s);
            st["region"] = serde_json::json!(r.region.to_string());
            st["samples_range"] = serde_json::json!(format!("{}:{}", r.sample_start, r.sample_count));
            st["scene_id"] = serde_json::json!(scene_id);
            st["overrides"] = serde_json::json!(set);
            match (&r.accum, is_exr && (plan.is_part || !r.complete)) {
                (Some(acc), true) => {
                    snell::part::write_part(&output, &plan.meta, &r.pixels, acc, &attrs, Some(&st))?;
                }
                _ => snell::image_io::save(
                    &output,
                    r.width,
                    r.height,
                    &r.pixels,
                    if is_exr { &layers } else { &[] },
                    &attrs,
                )?,
            }
            if !is_exr {
                for (name, vals) in layers.iter().filter(|l| l.0 != "spp") {
                    let max = vals.iter().cloned().fold(0.0f32, f32::max).max(1e-9);
                    let px: Vec<glam::Vec3A> = vals.iter().map(|v| glam::Vec3A::splat(v / max)).collect();
                    let p = output.with_extension(format!("{name}.png"));
                    snell::image_io::save(&p, r.width, r.height, &px, &[], &[])?;
                    if !quiet {
                        eprintln!("{name}: {} (white = {max})", p.display());
                    }
                }
            }
            if let Some(p) = stats_json {
                let text =
                    serde_json::to_string_pretty(&st).map_err(|e| snell::Error::Invalid(e.to_string()))?;
                snell::image_io::write_atomic(&p, text.as_bytes())?;
            }
            if auto_resume && r.complete && output == complete_output {
                // The partial is consumed: a directory of parts must not hold it twice.
                let _ = std::fs::remove_file(&own_partial);
            }
            if r.stats.counters.nan > 0 {
                eprintln!(
                    "warning: {} samples were NaN or Inf and were dropped",
                    r.stats.counters.nan
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
            say!("{}", output.display());
            Ok(())
        }
    }
}
