//! The `snell` command line: the clap types, then one function per
//! subcommand; `run` only dispatches.
#![deny(unsafe_code)]
use clap::{Args, Parser, Subcommand, ValueEnum};
use snell::dielectric::NestedStrategy;
use snell::render::{Aov, RenderOptions, RenderSettings, Rendered};
use snell::scene::{load_scene, BuildOptions, RenderScene};
use snell::{Error, Result};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Print to stdout, ignoring a closed pipe (`snell … | head` must not panic).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

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

// ---------------------------------------------------------------------------
// The command line. A subcommand's help text is the doc comment on its
// variant; its options are the fields of its `*Args` struct.

#[derive(Parser)]
#[command(name = "snell", version = LONG_VERSION, about = "Refraction ray tracer on Intel Embree 3")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Render a scene (TOML, glTF .gltf/.glb, Mitsuba .xml) to .png (sRGB 8-bit) or .exr (linear float32).
    Render(RenderArgs),
    /// Write a glTF or Mitsuba scene as snell TOML (docs/import-gltf.md, docs/import-mitsuba.md).
    Convert(ConvertArgs),
    /// Merge part EXRs (regions, sample ranges; directories stand for their .exr files)
    /// into the whole render, bit for bit equal to a single render.
    Merge(MergeArgs),
    /// Print a Markdown table of stats JSON files (a sweep's tasks; directories
    /// stand for their .json files), optionally to a file.
    Table(TableArgs),
    /// Audits: `snell audit nested SCENE --rays N` compares interior lists with point-in-solid tests.
    Audit {
        #[command(subcommand)]
        which: AuditCmd,
    },
    /// Trace single rays in gradient-index fields (JSON in, JSON out).
    GrinTrace(QueriesArgs),
    /// Warp points through a plate or a hollow cylinder (JSON in, JSON out).
    WarpPoints(QueriesArgs),
    /// Render a [warp] scene with straight primary rays through warped meshes
    /// (Mukai et al.); --compare also runs the exact trace and reports the error.
    WarpRender(WarpRenderArgs),
    /// Mutation-fuzz the scene loader and renderer with the shipped scenes as seeds.
    Fuzz(FuzzArgs),
    /// Run the measurements and write DIR/index.html (plots, pictures) and DIR/figures.json.
    Report(ReportArgs),
    /// Benchmarks that print ratios measured in one run, with provenance.
    Bench {
        #[command(subcommand)]
        which: BenchCmd,
    },
}

#[derive(Subcommand)]
enum AuditCmd {
    /// Cast N rays (a share exactly at mesh vertices and edges and at analytic
    /// silhouettes); on every segment between true hits compare the medium the
    /// interior list claims with a point-in-solid test; report per strategy.
    Nested(AuditNestedArgs),
}

#[derive(Subcommand)]
enum BenchCmd {
    /// Bare Embree rays/s: no filter, accept-all filter, recording filter (one thread).
    Embree(BenchEmbreeArgs),
    /// Nested-dielectric strategies on every nested and reference scene: trace-only and full render.
    Nested(BenchNestedArgs),
    /// The renderer against the Embree ceiling of its own rays (recorded, replayed through bare Embree).
    Render(BenchRenderArgs),
}

// `snell render`.
#[derive(Args)]
struct RenderArgs {
    scene: PathBuf,
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    #[arg(long, value_parser = at_least_one::<u32>)]
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
    aov: Vec<Aov>,
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
    #[command(flatten)]
    import: ImportFlags,
}

/// How glTF and Mitsuba scenes are imported (docs/import-gltf.md, docs/import-mitsuba.md).
#[derive(Args)]
struct ImportFlags {
    /// A Mitsuba parameter: -D spp=16 gives $spp the value 16 (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    define: Vec<String>,
    /// Refuse what cannot be mapped exactly (roughness, metals, ...) instead of warning.
    #[arg(long)]
    strict: bool,
    /// Skip unknown plugins and parameters with a warning instead of refusing the scene.
    #[arg(long)]
    lenient: bool,
}

impl ImportFlags {
    fn options(&self) -> Result<snell::scene::ImportOptions> {
        let mut defines = Vec::new();
        for d in &self.define {
            let (k, v) = d
                .split_once('=')
                .filter(|(k, _)| !k.is_empty())
                .ok_or_else(|| Error::Invalid(format!("-D {d}: expected NAME=VALUE")))?;
            defines.push((k.to_string(), v.to_string()));
        }
        Ok(snell::scene::ImportOptions {
            defines,
            strict: self.strict,
            lenient: self.lenient,
        })
    }
}

// `snell convert`.
#[derive(Args)]
struct ConvertArgs {
    /// The glTF (.gltf, .glb) or Mitsuba (.xml) scene.
    input: PathBuf,
    /// The TOML to write (default: print it).
    #[arg(short, long)]
    output: Option<PathBuf>,
    #[command(flatten)]
    import: ImportFlags,
}

/// Render-farm options of `snell render` (docs/farm.md).
#[derive(Args)]
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

// `snell merge`.
#[derive(Args)]
struct MergeArgs {
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
}

// `snell table`.
#[derive(Args)]
struct TableArgs {
    #[arg(required = true)]
    stats: Vec<PathBuf>,
    #[arg(short, long)]
    output: Option<PathBuf>,
}

// `snell audit nested`.
#[derive(Args)]
struct AuditNestedArgs {
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
}

// `snell grin-trace` and `snell warp-points`: a JSON document of queries.
#[derive(Args)]
struct QueriesArgs {
    queries: PathBuf,
    #[arg(short, long)]
    output: Option<PathBuf>,
}

// `snell warp-render`.
#[derive(Args)]
struct WarpRenderArgs {
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
    #[arg(long, hide_possible_values = true)]
    method: Option<Method>,
    /// Weight by the Fresnel transmittance of each pixel's path.
    #[arg(long)]
    fresnel: bool,
    /// Run the exact trace too; write a heatmap of the position error to this file
    /// (black 0, red 1 pixel, yellow >= 2, magenta: different objects).
    #[arg(long)]
    compare: Option<PathBuf>,
    /// Write the exact trace's image here as well (with --compare).
    #[arg(long, requires = "compare")]
    exact_output: Option<PathBuf>,
    #[arg(long)]
    stats_json: Option<PathBuf>,
    #[arg(long)]
    quiet: bool,
}

/// `--method` of `snell warp-render` (`snell::warp::WarpMethod` is no
/// `ValueEnum`: this is its command-line spelling).
#[derive(Clone, Copy, ValueEnum)]
enum Method {
    Exact,
    Paper,
}

impl From<Method> for snell::warp::WarpMethod {
    fn from(m: Method) -> Self {
        match m {
            Method::Exact => snell::warp::WarpMethod::Exact,
            Method::Paper => snell::warp::WarpMethod::Paper,
        }
    }
}

// `snell fuzz`.
#[derive(Args)]
struct FuzzArgs {
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
    /// Mutated Mitsuba XML / glTF scenes of --scenes-dir (default: as many as --cases), from --first.
    #[arg(long)]
    import_cases: Option<u64>,
}

// `snell report`.
#[derive(Args)]
struct ReportArgs {
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Small images and few repetitions (about 3 minutes on 2 cores).
    #[arg(long)]
    quick: bool,
    #[arg(long, default_value = "scenes")]
    scenes_dir: PathBuf,
}

// `snell bench embree`.
#[derive(Args)]
struct BenchEmbreeArgs {
    #[arg(long, default_value_t = 1_000_000)]
    rays: usize,
    #[arg(long, default_value_t = 5, value_parser = at_least_one::<usize>)]
    reps: usize,
}

// `snell bench nested`.
#[derive(Args)]
struct BenchNestedArgs {
    /// Write one JSON object per run (a JSON array) to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    #[arg(long, default_value_t = 5, value_parser = at_least_one::<usize>)]
    reps: usize,
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Only these scenes (names in scenes/, without .toml).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    #[arg(long, default_value = "scenes")]
    scenes_dir: PathBuf,
    /// Only these strategies (filter, recast, toggle, off); the ratio table
    /// needs all four, with fewer each run's speed is listed (for profiling).
    #[arg(long, value_delimiter = ',')]
    strategies: Vec<snell::dielectric::NestedStrategy>,
    /// Only this mode: `trace` (the fixed ray set, no shading) or `render`.
    #[arg(long, value_parser = ["trace", "render"])]
    mode: Option<String>,
    /// Rays a trace-mode repetition casts at least, in whole passes over the
    /// ray set (0: one pass, e.g. to count one pass's instructions).
    #[arg(long, default_value_t = snell::bench::TRACE_RAYS_PER_REP)]
    trace_rays_per_rep: usize,
}

// `snell bench render`.
#[derive(Args)]
struct BenchRenderArgs {
    /// Write the table as a JSON array (one object per scene, with provenance).
    #[arg(long)]
    json: Option<PathBuf>,
    #[arg(long, default_value_t = 3, value_parser = at_least_one::<usize>)]
    reps: usize,
    #[arg(long, default_value_t = 2, value_parser = at_least_one::<usize>)]
    threads: usize,
    /// Film of the timed renders: WIDTHxHEIGHTxSPP.
    #[arg(long, default_value = "320x240x16")]
    size: String,
    /// Samples per pixel of the render whose rays are recorded and replayed.
    #[arg(long, default_value_t = 4, value_parser = at_least_one::<u32>)]
    record_spp: u32,
    /// Only these scenes (names in scenes/, without .toml; default: the reference and nested scenes).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    #[arg(long, default_value = "scenes")]
    scenes_dir: PathBuf,
}

/// `--spp`, `--reps`: a count of at least 1.
fn at_least_one<T>(s: &str) -> std::result::Result<T, String>
where
    T: std::str::FromStr + PartialEq + From<u8>,
    T::Err: std::fmt::Display,
{
    match s.parse::<T>().map_err(|e| e.to_string())? {
        v if v == T::from(0) => Err("must be at least 1".into()),
        v => Ok(v),
    }
}

// ---------------------------------------------------------------------------
// Dispatch.

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Render(a) => render(a),
        Cmd::Convert(a) => convert(a),
        Cmd::Merge(a) => merge(a),
        Cmd::Table(a) => table(a),
        Cmd::Audit {
            which: AuditCmd::Nested(a),
        } => audit_nested(a),
        Cmd::GrinTrace(a) => grin_trace(a),
        Cmd::WarpPoints(a) => warp_points(a),
        Cmd::WarpRender(a) => warp_render(a),
        Cmd::Fuzz(a) => fuzz(a),
        Cmd::Report(a) => report(a),
        Cmd::Bench {
            which: BenchCmd::Embree(a),
        } => bench_embree(a),
        Cmd::Bench {
            which: BenchCmd::Nested(a),
        } => bench_nested(a),
        Cmd::Bench {
            which: BenchCmd::Render(a),
        } => bench_render(a),
    }
}

// ---------------------------------------------------------------------------
// Shared helpers.

/// Write `value` as pretty JSON to `path` (atomically).
fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| Error::Invalid(e.to_string()))?;
    snell::image_io::write_atomic(path, text.as_bytes())
}

/// Write benchmark runs as a JSON array, each object with the provenance.
fn write_runs_json(path: &Path, runs: &[impl serde::Serialize]) -> Result<()> {
    let prov = snell::provenance::json();
    let v: Vec<serde_json::Value> = runs
        .iter()
        .map(|r| {
            let mut o = serde_json::to_value(r).unwrap_or_default();
            o["provenance"] = prov.clone();
            o
        })
        .collect();
    write_json(path, &v)
}

/// Write `text` to `output`, or print it when there is none.
fn write_or_print(output: Option<PathBuf>, text: &str) -> Result<()> {
    match output {
        Some(p) => snell::image_io::write_atomic(&p, text.as_bytes())?,
        None => say!("{text}"),
    }
    Ok(())
}

fn is_exr(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

// ---------------------------------------------------------------------------
// `snell render`.

fn render(mut a: RenderArgs) -> Result<()> {
    if let (Some(sw), Some(i)) = (&a.sweep, a.sweep_index) {
        a.set.push(snell::overrides::sweep_value(sw, i)?);
    }
    let (output, aov, quiet, farm) = (&a.output, &a.aov, a.quiet, &a.farm);
    if farm.mkdir {
        snell::farm::make_parent(output)?;
    }
    let load_t = Instant::now();
    let build = BuildOptions {
        import: a.import.options()?,
        ..BuildOptions::default()
    };
    let (s, scene_id) = snell::farm::load(&a.scene, &a.set, &build, a.nested)?;
    let load_s = load_t.elapsed().as_secs_f64();
    for w in &s.warnings {
        eprintln!("warning: {w}");
    }
    let settings = render_settings(&a, &s)?;
    let is_exr = is_exr(output);
    let own_partial = snell::farm::partial_path(output);
    let auto_resume = farm.resume_partial && farm.resume.is_none() && own_partial.is_file();
    if auto_resume && !quiet {
        eprintln!("resuming {}", own_partial.display());
    }
    let fa = snell::farm::FarmArgs {
        region: farm.region.clone(),
        region_cell: farm.region_cell.clone(),
        samples: farm.samples.clone(),
        sample_chunk: farm.sample_chunk.clone(),
        resume: if auto_resume {
            Some(own_partial.clone())
        } else {
            farm.resume.clone()
        },
        part: farm.part,
    };
    let plan = snell::farm::plan(&settings, &scene_id, &fa, is_exr)?;
    if plan.is_part && !aov.is_empty() {
        return Err(Error::Invalid(
            "--aov layers are not merged: render them in one piece (no --region, --samples, --resume or --part)"
                .into(),
        ));
    }
    snell::render::PROGRESS_LINES.store(farm.progress_lines, std::sync::atomic::Ordering::Relaxed);
    stop_on_signals();
    let r = snell::render::render_part(
        &s,
        &settings,
        &RenderOptions {
            threads: a.threads,
            quiet,
            want_aovs: !aov.is_empty(),
        },
        &plan.spec,
    )?;
    let written = if r.complete {
        output.clone()
    } else {
        let p = snell::farm::partial_path(output);
        eprintln!(
            "interrupted: {} of {} tiles done ({} spp each, the rest black); writing {}",
            r.tiles_done,
            r.tiles_total,
            r.spp_done,
            p.display()
        );
        p
    };
    let mut layers: Vec<(&str, &[f32])> = aov.iter().map(|&l| (l.name(), r.aovs.layer(l))).collect();
    if !r.complete {
        layers.push(("spp", &r.pixel_spp));
    }
    let attrs = [
        ("spp", r.spp_done.to_string()),
        ("complete", r.complete.to_string()),
        ("tiles_done", format!("{}/{}", r.tiles_done, r.tiles_total)),
        ("provenance", snell::provenance::line()),
    ];
    let st = render_stats(&r, &settings, load_s, &scene_id, &a.set);
    match (&r.accum, is_exr && (plan.is_part || !r.complete)) {
        (Some(acc), true) => {
            snell::part::write_part(&written, &plan.meta, &r.pixels, acc, &attrs, Some(&st))?;
        }
        _ => snell::image_io::save(
            &written,
            r.width,
            r.height,
            &r.pixels,
            if is_exr { &layers } else { &[] },
            &attrs,
        )?,
    }
    if !is_exr {
        save_aov_pngs(&written, &r, &layers, quiet)?;
    }
    if let Some(p) = &a.stats_json {
        write_json(p, &st)?;
    }
    if auto_resume && r.complete && written == *output {
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
    say!("{}", written.display());
    Ok(())
}

/// The scene's render settings with the command line's strategy, spp, seed
/// and resolution.
fn render_settings(a: &RenderArgs, s: &RenderScene) -> Result<RenderSettings> {
    let mut settings = RenderSettings::from_scene(s).with_strategy(a.nested);
    if let Some(v) = a.spp {
        settings = settings.with_spp(v);
    }
    if let Some(v) = a.seed {
        settings = settings.with_seed(v);
    }
    if a.width.is_some() || a.height.is_some() {
        settings = settings.with_resolution(a.width.unwrap_or(s.width), a.height.unwrap_or(s.height))?;
    }
    Ok(settings)
}

/// Ctrl-C (or SIGTERM, SIGHUP: a farm cancelling the task) stops at the next
/// tile boundary and the image so far is written, clearly named; a second
/// signal exits at once.
fn stop_on_signals() {
    let _ = ctrlc::set_handler(|| {
        if snell::render::INTERRUPT.swap(true, std::sync::atomic::Ordering::SeqCst) {
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing the tiles in progress (Ctrl-C again to exit at once)");
    });
}

/// The stats JSON of a render: the render's own, plus the run's CPU and load
/// time, the part it covers, the scene's identity and the overrides.
fn render_stats(
    r: &Rendered,
    settings: &RenderSettings,
    load_s: f64,
    scene_id: &str,
    set: &[String],
) -> serde_json::Value {
    let mut st = r.stats.to_json(settings, r.spp_done);
    st["cpu_s"] = serde_json::json!(snell::farm::cpu_seconds());
    st["load_s"] = serde_json::json!(load_s);
    st["region"] = serde_json::json!(r.region.to_string());
    st["samples_range"] = serde_json::json!(format!("{}:{}", r.sample_start, r.sample_count));
    st["scene_id"] = serde_json::json!(scene_id);
    st["overrides"] = serde_json::json!(set);
    st
}

/// Beside a PNG, each AOV layer as its own grey PNG (NAME.LAYER.png), scaled
/// so that its maximum is white.
fn save_aov_pngs(output: &Path, r: &Rendered, layers: &[(&str, &[f32])], quiet: bool) -> Result<()> {
    for (name, vals) in layers.iter().filter(|l| l.0 != "spp") {
        let max = vals.iter().cloned().fold(0.0f32, f32::max).max(1e-9);
        let px: Vec<glam::Vec3A> = vals.iter().map(|v| glam::Vec3A::splat(v / max)).collect();
        let p = output.with_extension(format!("{name}.png"));
        snell::image_io::save(&p, r.width, r.height, &px, &[], &[])?;
        if !quiet {
            eprintln!("{name}: {} (white = {max})", p.display());
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// `snell merge` and `snell table`.

/// `snell convert`: the imported scene as TOML, its warnings on stderr.
fn convert(a: ConvertArgs) -> Result<()> {
    let dir = a
        .output
        .as_ref()
        .map(|o| o.parent().map(Path::to_path_buf).unwrap_or_default());
    let (toml, warnings) = snell::scene::import::convert(&a.input, dir.as_deref(), &a.import.options()?)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    write_or_print(a.output, &toml)
}

fn merge(a: MergeArgs) -> Result<()> {
    if a.mkdir {
        snell::farm::make_parent(&a.output)?;
    }
    let files = snell::merge::collect_inputs(&a.parts)?;
    let parts = files
        .iter()
        .map(|f| snell::part::read_part(f))
        .collect::<Result<Vec<_>>>()?;
    let m = snell::merge::merge(&parts)?;
    let (w, h) = (m.meta.film_width, m.meta.film_height);
    let attrs = [
        ("spp", m.meta.spp.to_string()),
        ("complete", "true".to_string()),
        ("merged_parts", files.len().to_string()),
        ("provenance", snell::provenance::line()),
    ];
    if a.part && is_exr(&a.output) {
        snell::part::write_part(&a.output, &m.meta, &m.pixels, &m.accum, &attrs, Some(&m.stats))?;
    } else {
        snell::image_io::save(&a.output, w, h, &m.pixels, &[], &attrs)?;
    }
    if let Some(p) = &a.png {
        snell::image_io::save(p, w, h, &m.pixels, &[], &[])?;
    }
    if let Some(p) = &a.stats_json {
        write_json(p, &m.stats)?;
    }
    if !a.quiet {
        eprintln!(
            "merged {} parts into {w}x{h} at {} spp: {} rays, {:.2} s of task time",
            files.len(),
            m.meta.spp,
            m.stats["rays"],
            m.stats["wall_s"].as_f64().unwrap_or(0.0)
        );
    }
    say!("{}", a.output.display());
    Ok(())
}

fn table(a: TableArgs) -> Result<()> {
    let t = snell::farm::stats_table(&a.stats)?;
    match a.output {
        Some(p) => snell::image_io::write_atomic(&p, t.as_bytes()),
        None => {
            say!("{}", t.trim_end());
            Ok(())
        }
    }
}

// ---------------------------------------------------------------------------
// `snell audit nested`.

fn audit_nested(a: AuditNestedArgs) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Invalid(e.to_string()))?;
    say!("{}", snell::bench_header());
    let mut out = Vec::new();
    let s = load_scene(&a.scene, &BuildOptions::default())?;
    for strategy in a.nested {
        let t = Instant::now();
        let tr = snell::integrator::Tracer { scene: &s, strategy };
        let r = pool.install(|| snell::audit::audit_scene(tr, a.rays, a.seed))?;
        say!("{:<7} {r} [{:.1} s]", strategy.name(), t.elapsed().as_secs_f64());
        out.push(serde_json::json!({
            "scene": a.scene.display().to_string(),
            "strategy": strategy.name(),
            "report": r,
            "provenance": snell::provenance::json(),
        }));
    }
    if let Some(p) = &a.json {
        write_json(p, &out)?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// `snell grin-trace` and `snell warp-points`.

fn grin_trace(a: QueriesArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.queries).map_err(|e| Error::io(&a.queries, e))?;
    let out = snell::media::grin_trace_json(&text)
        .map_err(|e| Error::Invalid(format!("{}: {e}", a.queries.display())))?;
    write_or_print(a.output, &out)
}

fn warp_points(a: QueriesArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.queries).map_err(|e| Error::io(&a.queries, e))?;
    let out = snell::warp::points::warp_points_json(&a.queries.display().to_string(), &text)
        .map_err(Error::Invalid)?;
    write_or_print(a.output, &out)
}

// ---------------------------------------------------------------------------
// `snell warp-render`.

fn warp_render(a: WarpRenderArgs) -> Result<()> {
    use snell::warp_render::{run as warp_run, WarpRunOptions};
    let mut s = load_scene(&a.scene, &BuildOptions::default())?;
    if a.width.is_some() || a.height.is_some() {
        s.set_resolution(a.width.unwrap_or(s.width), a.height.unwrap_or(s.height))?;
    }
    let rep = warp_run(
        &s,
        &WarpRunOptions {
            threads: a.threads,
            subdivide: a.subdivide,
            method: a.method.map(Into::into),
            fresnel: a.fresnel.then_some(true),
            compare: a.compare.is_some(),
        },
    )?;
    let f = &rep.frame;
    snell::image_io::save(&a.output, f.width, f.height, &f.pixels, &[], &[])?;
    if let (Some(path), Some((ex, cmp, heat))) = (&a.compare, &rep.exact) {
        snell::image_io::save(path, ex.width, ex.height, heat, &[], &[])?;
        if let Some(p) = &a.exact_output {
            snell::image_io::save(p, ex.width, ex.height, &ex.pixels, &[], &[])?;
        }
        if !a.quiet {
            eprintln!("{}", warp_comparison_line(cmp, path));
            eprintln!("{}", warp_speed_line(&rep, ex));
        }
    }
    if !a.quiet {
        eprintln!("{}", warp_summary_line(&rep));
    }
    if let Some(p) = &a.stats_json {
        write_json(p, &rep.to_json())?;
    }
    say!("{}", a.output.display());
    Ok(())
}

// The warp report's lines (its types live in `snell::warp_render`).

/// Warp frame against the exact trace: image RMSE and position error, in
/// scene units and in pixel footprints.
fn warp_comparison_line(cmp: &snell::warp_render::Comparison, heatmap: &Path) -> String {
    format!(
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
        heatmap.display()
    )
}

/// Seconds per warp frame (and its parts) against the exact trace; the
/// ratios are exact time / warp time (> 1: the warp is faster).
fn warp_speed_line(rep: &snell::warp_render::WarpReport, exact: &snell::warp_render::Frame) -> String {
    format!(
        "speed: warp frame {:.4} s (warp {:.4} + copies {:.4} + primary rays {:.4}) vs exact trace {:.4} s: {:.2}x (render only {:.2}x)",
        rep.frame_s(),
        rep.warp_s,
        rep.build_s,
        rep.frame.render_s,
        exact.render_s,
        exact.render_s / rep.frame_s().max(1e-12),
        exact.render_s / rep.frame.render_s.max(1e-12)
    )
}

/// The warped meshes: size, images, dropped triangles, copies per object.
fn warp_summary_line(rep: &snell::warp_render::WarpReport) -> String {
    format!(
        "warp: {} vertices, {} triangles (longest projected edge {:.2} px), {} images, {} triangles in no copy, {} outside the view; copies {:?}",
        rep.vertices, rep.triangles, rep.max_edge_px, rep.images, rep.dropped_triangles, rep.culled_triangles, rep.copies
    )
}

// ---------------------------------------------------------------------------
// `snell fuzz`.

fn fuzz(a: FuzzArgs) -> Result<()> {
    let seeds = snell::fuzz::shipped_scenes(&a.scenes_dir);
    if seeds.is_empty() {
        return Err(Error::Invalid(format!(
            "no .toml scenes in {}",
            a.scenes_dir.display()
        )));
    }
    let limit = Duration::from_secs(1);
    let t = Instant::now();
    let rep = snell::fuzz::run_from(&seeds, &a.scenes_dir, a.first, a.cases, a.seed, limit);
    say!("{}", scene_fuzz_line(&rep, t.elapsed()));
    print_findings(&rep.panics, &rep.unlocated_errors, &rep.slow);
    let json_seeds = snell::fuzz::json_seeds(&a.json_dir);
    let jcases = a.json_cases.unwrap_or(a.cases);
    let t = Instant::now();
    let jr = snell::fuzz::run_json(&json_seeds, jcases, a.seed, limit);
    say!("{}", json_fuzz_line(&jr, t.elapsed(), json_seeds.len()));
    print_findings(&jr.panics, &jr.unlocated, &jr.slow);
    if json_seeds.is_empty() && jcases > 0 {
        say!("warning: no JSON seeds in {}", a.json_dir.display());
    }
    let json_ok = jr.panics.is_empty() && jr.unlocated.is_empty() && jr.slow.is_empty();
    let t = Instant::now();
    // Imported scenes get 3 s of CPU: the glTF glass of water (two
    // overlapping mesh solids) takes about 0.8 s to build and start.
    let ir = snell::fuzz_import::run_from(
        &a.scenes_dir,
        a.first,
        a.import_cases.unwrap_or(a.cases),
        a.seed,
        Duration::from_secs(3),
    );
    say!(
        "{} imported scenes (Mitsuba XML, glTF) in {:.1} s: {} rendered, {} refused with a located error, {} unlocated, {} panics, {} over 3 s of CPU; costliest {:.3} s ({})",
        ir.cases,
        t.elapsed().as_secs_f64(),
        ir.rendered,
        ir.refused,
        ir.unlocated.len(),
        ir.panics.len(),
        ir.slow.len(),
        ir.slowest.0,
        ir.slowest.1
    );
    print_findings(&ir.panics, &ir.unlocated, &ir.slow);
    let import_ok = ir.panics.is_empty() && ir.unlocated.is_empty() && ir.slow.is_empty();
    if json_ok && import_ok && rep.panics.is_empty() && rep.unlocated_errors.is_empty() && rep.slow.is_empty()
    {
        Ok(())
    } else {
        Err(Error::Invalid("the fuzzer found problems (see above)".into()))
    }
}

// The fuzz reports' summary lines (their types live in `snell::fuzz`).

/// The scene fuzzer's totals.
fn scene_fuzz_line(rep: &snell::fuzz::FuzzReport, elapsed: Duration) -> String {
    format!(
        "{} cases in {:.1} s: {} rendered, {} located errors, {} other errors, {} panics, {} slower than 1 s; slowest {:.3} s ({})",
        rep.cases,
        elapsed.as_secs_f64(),
        rep.rendered,
        rep.errors - rep.unlocated_errors.len() as u64,
        rep.unlocated_errors.len(),
        rep.panics.len(),
        rep.slow.len(),
        rep.slowest.0,
        rep.slowest.1
    )
}

/// The JSON-document fuzzer's totals.
fn json_fuzz_line(jr: &snell::fuzz::JsonFuzzReport, elapsed: Duration, seeds: usize) -> String {
    format!(
        "{} grin-trace/warp-points documents in {:.1} s ({} seeds): {} answered ({} queries or points with an error status), {} refused with a located error, {} unlocated, {} panics, {} slower than 1 s; slowest {:.3} s ({})",
        jr.cases,
        elapsed.as_secs_f64(),
        seeds,
        jr.answered,
        jr.item_errors,
        jr.refused - jr.unlocated.len() as u64,
        jr.unlocated.len(),
        jr.panics.len(),
        jr.slow.len(),
        jr.slowest.0,
        jr.slowest.1
    )
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

// ---------------------------------------------------------------------------
// `snell report`.

fn report(a: ReportArgs) -> Result<()> {
    let opts = snell::report::ReportOptions {
        out: a.output,
        quick: a.quick,
        scenes_dir: a.scenes_dir,
    };
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let index = snell::report::run(&opts, &command, |m| eprintln!("{m}"))?;
    say!("{}", index.display());
    Ok(())
}

// ---------------------------------------------------------------------------
// `snell bench`.

fn bench_embree(a: BenchEmbreeArgs) -> Result<()> {
    say!("{}", snell::bench_header());
    let f = snell::bench::embree_bare(a.rays, a.reps)?;
    say!("{f}");
    Ok(())
}

fn bench_nested(a: BenchNestedArgs) -> Result<()> {
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

fn bench_render(a: BenchRenderArgs) -> Result<()> {
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
