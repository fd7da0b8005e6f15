//! The command line's shape as clap types. A subcommand's help text is the
//! doc comment on its variant; its options are the fields of its `*Args`
//! struct, and a field's doc comment is its option's help.
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, Parser, Subcommand, ValueEnum};
use snell::dielectric::NestedStrategy;
use snell::render::Aov;
use snell::scene::ImportOptions;
use snell::{Error, Result};
use std::path::PathBuf;

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
pub struct Cli {
    #[command(subcommand)]
    pub cmd: Cmd,
}

#[derive(Subcommand)]
pub enum Cmd {
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
    /// Draw a fan of rays from the scene's camera through its medium as
    /// height against distance (SVG), with the scene's profile and the hits:
    /// where to put the camera and objects for a mirage.
    GrinFan(GrinFanArgs),
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
pub enum AuditCmd {
    /// Cast N rays (a share exactly at mesh vertices and edges and at analytic
    /// silhouettes); on every segment between true hits compare the medium the
    /// interior list claims with a point-in-solid test; report per strategy.
    Nested(AuditNestedArgs),
}

#[derive(Subcommand)]
pub enum BenchCmd {
    /// Bare Embree rays/s: no filter, accept-all filter, recording filter (one thread).
    Embree(BenchEmbreeArgs),
    /// Nested-dielectric strategies on every nested and reference scene: trace-only and full render.
    Nested(BenchNestedArgs),
    /// The renderer against the Embree ceiling of its own rays (recorded, replayed through bare Embree).
    Render(BenchRenderArgs),
    /// Every curved-ray scene (a TOML with a [medium]) against its no-field
    /// twin (NAME_nofield.toml): render times, their ratio and the chords, as
    /// a Markdown table.
    Grin(BenchGrinArgs),
}

// `snell render`.
#[derive(Args)]
pub struct RenderArgs {
    pub scene: PathBuf,
    #[arg(short, long, default_value = "out.png")]
    pub output: PathBuf,
    #[arg(long, value_parser = at_least_one::<u32>)]
    pub spp: Option<u32>,
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(long)]
    pub seed: Option<u64>,
    #[arg(long)]
    pub width: Option<u32>,
    #[arg(long)]
    pub height: Option<u32>,
    /// How false hits of nested dielectrics are skipped.
    #[arg(long, default_value = "filter")]
    pub nested: NestedStrategy,
    /// Who intersects the analytic shapes for the path tracer's packets:
    /// `auto` (snell itself when the scene has at most 8 analytic primitives
    /// and no medium: the same hits, without Embree's callbacks; rects are
    /// then analytic too when they are its only meshes) or `embree` (rects stay two
    /// triangles).
    #[arg(long, value_enum, default_value = "auto")]
    pub analytic_shapes: AnalyticShapes,
    /// Paths per Embree packet in the path tracer: `auto` (16 where Embree's
    /// 16-wide packets are native, i.e. with AVX-512; else 8), `8` or `16`.
    /// The image is the same at every width.
    #[arg(long, value_enum, default_value = "auto")]
    pub packet_width: PacketWidthArg,
    /// How the path tracer shades a packet's paths: `vector` (side by side
    /// in vector registers, f32, at the hits the kernel models: diffuse,
    /// black, mirrors, smooth and GGX-rough glass and nested solids' boundaries,
    /// smooth and GGX metals and plastics, under every kind of light; the
    /// other hits one by one; the analytic shapes' packet queries in f32
    /// where no solids overlap) or `scalar` (one by one, Fresnel and Snell in f64,
    /// the analytic shapes' queries in f64 as single rays make them). The
    /// images agree up to rounding.
    #[arg(long, value_enum, default_value = "vector")]
    pub shading: ShadingArg,
    /// How the path tracer's camera rays fly through a 3-D gradient-index
    /// field (a plume) where no geometry is near: `side-by-side` (a tile
    /// row's rays together, their field evaluations eight per vector
    /// operation) or `one-by-one`. The image is the same either way.
    #[arg(long, value_enum, default_value = "side-by-side")]
    pub flights: FlightsArg,
    /// How paths find lights: `mis` (next-event estimation combined with
    /// BSDF sampling by multiple importance sampling) or `bsdf` (BSDF
    /// sampling alone: emitters count where paths meet them; point,
    /// directional and spot lights add nothing). `bsdf` is the reference
    /// next-event estimation is checked against.
    #[arg(long, value_enum, default_value = "mis")]
    pub light_sampling: LightSamplingArg,
    /// Diagnostic layers: false_hits,list_depth,tir,fallbacks (EXR channels, or PNGs beside a PNG).
    #[arg(long, value_delimiter = ',', value_parser = aov_parser())]
    pub aov: Vec<Aov>,
    #[arg(long)]
    pub quiet: bool,
    /// Write render statistics (with provenance) as JSON.
    #[arg(long)]
    pub stats_json: Option<PathBuf>,
    /// Override a scene key: objects.water.material.ior=1.34, film.spp=256 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// A sweep: with --sweep-index I, the same as --set KEY=VI.
    #[arg(long, value_name = "KEY=V1,V2,...", requires = "sweep_index")]
    pub sweep: Option<String>,
    /// Which value of --sweep to render (counting from 1).
    #[arg(long, value_name = "I", requires = "sweep")]
    pub sweep_index: Option<u32>,
    #[command(flatten)]
    pub farm: FarmFlags,
    #[command(flatten)]
    pub import: ImportFlags,
}

/// How glTF and Mitsuba scenes are imported (docs/import-gltf.md, docs/import-mitsuba.md).
#[derive(Args)]
pub struct ImportFlags {
    /// A Mitsuba parameter: -D spp=16 gives $spp the value 16 (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<String>,
    /// Refuse what cannot be mapped exactly (roughness, metals, ...) instead of warning.
    #[arg(long)]
    pub strict: bool,
    /// Skip unknown plugins and parameters with a warning instead of refusing the scene.
    #[arg(long)]
    pub lenient: bool,
}

impl ImportFlags {
    /// The library's import options; a `-D` without `NAME=` is refused.
    pub fn options(&self) -> Result<ImportOptions> {
        let mut defines = Vec::new();
        for d in &self.define {
            let (k, v) = d
                .split_once('=')
                .filter(|(k, _)| !k.is_empty())
                .ok_or_else(|| Error::Invalid(format!("-D {d}: expected NAME=VALUE")))?;
            defines.push((k.to_string(), v.to_string()));
        }
        Ok(ImportOptions {
            defines,
            strict: self.strict,
            lenient: self.lenient,
        })
    }
}

// `snell convert`.
#[derive(Args)]
pub struct ConvertArgs {
    /// The glTF (.gltf, .glb) or Mitsuba (.xml) scene.
    pub input: PathBuf,
    /// The TOML to write (default: print it).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub import: ImportFlags,
}

/// Render-farm options of `snell render` (docs/farm.md).
#[derive(Args)]
pub struct FarmFlags {
    /// Render only pixels x0..x1, y0..y1 (half-open; the EXR's data window).
    #[arg(long, value_name = "x0,x1,y0,y1")]
    pub region: Option<String>,
    /// Render cell IX,IY of an NX x NY grid over the film.
    #[arg(long, value_name = "IX/NX,IY/NY")]
    pub region_cell: Option<String>,
    /// Render sample indices START..START+COUNT of the film's spp.
    #[arg(long, value_name = "START:COUNT")]
    pub samples: Option<String>,
    /// Render chunk K of the film's spp cut into N ranges.
    #[arg(long, value_name = "K/N")]
    pub sample_chunk: Option<String>,
    /// Continue a partial part EXR (Ctrl-C): render the samples it lacks.
    #[arg(long, value_name = "PART.exr")]
    pub resume: Option<PathBuf>,
    /// Continue OUTPUT's own partial (NAME.partial.exr) when there is one, and
    /// remove it once the render completes (farm tasks that are retried).
    #[arg(long)]
    pub resume_partial: bool,
    /// Write the EXR as a part (with exact sums) even for a whole render.
    #[arg(long)]
    pub part: bool,
    /// Print progress lines (`openjd_progress: P`) to stderr, for farm logs.
    #[arg(long)]
    pub progress_lines: bool,
    /// Create the output's directory when it is missing.
    #[arg(long)]
    pub mkdir: bool,
}

// `snell merge`.
#[derive(Args)]
pub struct MergeArgs {
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Also write an sRGB PNG of the merged image.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Write the parts' stats, summed.
    #[arg(long)]
    pub stats_json: Option<PathBuf>,
    /// Keep the exact sums in the output (a part covering the whole render).
    #[arg(long)]
    pub part: bool,
    /// Create the output's directory when it is missing.
    #[arg(long)]
    pub mkdir: bool,
    #[arg(long)]
    pub quiet: bool,
}

// `snell table`.
#[derive(Args)]
pub struct TableArgs {
    #[arg(required = true)]
    pub stats: Vec<PathBuf>,
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

// `snell audit nested`.
#[derive(Args)]
pub struct AuditNestedArgs {
    pub scene: PathBuf,
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: u64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Strategies to audit.
    #[arg(long, value_delimiter = ',', default_value = "filter,recast,toggle")]
    pub nested: Vec<NestedStrategy>,
    /// Also audit each strategy with its true hits found as the path
    /// tracer's wavefront finds them: packet queries (masked inside
    /// overlapping solids) where it makes them, checked and settled.
    #[arg(long)]
    pub packets: bool,
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(long)]
    pub json: Option<PathBuf>,
}

// `snell grin-trace` and `snell warp-points`: a JSON document of queries.
#[derive(Args)]
pub struct QueriesArgs {
    pub queries: PathBuf,
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

// `snell grin-fan`.
#[derive(Args)]
pub struct GrinFanArgs {
    pub scene: PathBuf,
    #[arg(short, long, default_value = "fan.svg")]
    pub output: PathBuf,
    /// Rays in the fan (at least 2).
    #[arg(long, default_value_t = 41)]
    pub rays: u32,
    /// Lowest elevation, degrees above the horizontal (default: the bottom of the camera's view).
    #[arg(long, allow_hyphen_values = true, requires = "to")]
    pub from: Option<f64>,
    /// Highest elevation, degrees above the horizontal (default: the top of the camera's view).
    #[arg(long, allow_hyphen_values = true, requires = "from")]
    pub to: Option<f64>,
    /// How far to draw, metres (default: a tenth beyond the farthest hit).
    #[arg(long)]
    pub max_distance: Option<f64>,
    /// rk45 error tolerance of the rays, metres (default: the medium's, at most 1 mm).
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Turn the fan's plane toward this world point (e.g. an object beside the view's centre).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub toward: Option<String>,
    /// Also write the fan (paths, hits, profile) as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Override a scene key, as for `snell render` (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    #[command(flatten)]
    pub import: ImportFlags,
}

// `snell warp-render`.
#[derive(Args)]
pub struct WarpRenderArgs {
    pub scene: PathBuf,
    #[arg(short, long, default_value = "warp.png")]
    pub output: PathBuf,
    #[arg(long)]
    pub width: Option<u32>,
    #[arg(long)]
    pub height: Option<u32>,
    #[arg(long)]
    pub threads: Option<usize>,
    /// Longest projected edge after subdivision, in pixels (overrides [warp].subdivide).
    #[arg(long)]
    pub subdivide: Option<f64>,
    /// exact or paper (overrides [warp].method).
    #[arg(long, hide_possible_values = true)]
    pub method: Option<Method>,
    /// Weight by the Fresnel transmittance of each pixel's path.
    #[arg(long)]
    pub fresnel: bool,
    /// Run the exact trace too; write a heatmap of the position error to this file
    /// (black 0, red 1 pixel, yellow >= 2, magenta: different objects).
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// Write the exact trace's image here as well (with --compare).
    #[arg(long, requires = "compare")]
    pub exact_output: Option<PathBuf>,
    #[arg(long)]
    pub stats_json: Option<PathBuf>,
    #[arg(long)]
    pub quiet: bool,
}

/// `--shading` of `snell render`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ShadingArg {
    Vector,
    Scalar,
}

impl From<ShadingArg> for snell::render::Shading {
    fn from(s: ShadingArg) -> Self {
        match s {
            ShadingArg::Vector => Self::Vector,
            ShadingArg::Scalar => Self::Scalar,
        }
    }
}

/// `--packet-width` of `snell render`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PacketWidthArg {
    Auto,
    #[value(name = "8")]
    Eight,
    #[value(name = "16")]
    Sixteen,
}

/// `--light-sampling` of `snell render`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LightSamplingArg {
    Mis,
    Bsdf,
}

impl From<LightSamplingArg> for snell::integrator::LightSampling {
    fn from(l: LightSamplingArg) -> Self {
        match l {
            LightSamplingArg::Mis => Self::Mis,
            LightSamplingArg::Bsdf => Self::Bsdf,
        }
    }
}

/// `--flights` of `snell render`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FlightsArg {
    SideBySide,
    OneByOne,
}

impl From<FlightsArg> for snell::render::Flights {
    fn from(f: FlightsArg) -> Self {
        match f {
            FlightsArg::SideBySide => Self::SideBySide,
            FlightsArg::OneByOne => Self::OneByOne,
        }
    }
}

impl From<PacketWidthArg> for snell::render::PacketWidth {
    fn from(w: PacketWidthArg) -> Self {
        match w {
            PacketWidthArg::Auto => Self::Auto,
            PacketWidthArg::Eight => Self::Eight,
            PacketWidthArg::Sixteen => Self::Sixteen,
        }
    }
}

/// `--analytic-shapes` of `snell render`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AnalyticShapes {
    Auto,
    Embree,
}

/// `--method` of `snell warp-render` (`snell::warp::WarpMethod` is no
/// `ValueEnum`: this is its command-line spelling).
#[derive(Clone, Copy, ValueEnum)]
pub enum Method {
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
pub struct FuzzArgs {
    #[arg(long, default_value_t = 100_000)]
    pub cases: u64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[arg(long, default_value = "scenes")]
    pub scenes_dir: PathBuf,
    /// Start at this scene case (to reproduce one: --first N --cases 1 --json-cases 0).
    #[arg(long, default_value_t = 0)]
    pub first: u64,
    /// Mutated grin-trace / warp-points documents (default: as many as --cases).
    #[arg(long)]
    pub json_cases: Option<u64>,
    #[arg(long, default_value = "tests/data/fuzz")]
    pub json_dir: PathBuf,
    /// Mutated Mitsuba XML / glTF scenes of --scenes-dir (default: as many as --cases), from --first.
    #[arg(long)]
    pub import_cases: Option<u64>,
    /// The importer whose scenes are mutated (a run of one draws its cases from that format's seeds only).
    #[arg(long, value_enum, default_value = "all")]
    pub import_format: ImportFormatArg,
    /// CPU seconds an imported scene may take to import, build and render at 4×3 pixels.
    #[arg(long, default_value_t = 3.0)]
    pub import_limit: f64,
    /// Write each imported-scene finding's document to this directory (as c<case>_<seed file>).
    #[arg(long)]
    pub save_findings: Option<PathBuf>,
}

/// `--import-format`.
#[derive(Clone, Copy, ValueEnum)]
pub enum ImportFormatArg {
    All,
    Xml,
    Gltf,
}

impl From<ImportFormatArg> for snell::fuzz_import::ImportFormat {
    fn from(f: ImportFormatArg) -> Self {
        match f {
            ImportFormatArg::All => snell::fuzz_import::ImportFormat::All,
            ImportFormatArg::Xml => snell::fuzz_import::ImportFormat::Xml,
            ImportFormatArg::Gltf => snell::fuzz_import::ImportFormat::Gltf,
        }
    }
}

// `snell report`.
#[derive(Args)]
pub struct ReportArgs {
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Small images and few repetitions (about 3 minutes on 2 cores).
    #[arg(long)]
    pub quick: bool,
    #[arg(long, default_value = "scenes")]
    pub scenes_dir: PathBuf,
}

// `snell bench embree`.
#[derive(Args)]
pub struct BenchEmbreeArgs {
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    #[arg(long, default_value_t = 5, value_parser = at_least_one::<usize>)]
    pub reps: usize,
}

// `snell bench nested`.
#[derive(Args)]
pub struct BenchNestedArgs {
    /// Write one JSON object per run (a JSON array) to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    #[arg(long, default_value_t = 5, value_parser = at_least_one::<usize>)]
    pub reps: usize,
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Only these scenes (names in scenes/, without .toml).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    #[arg(long, default_value = "scenes")]
    pub scenes_dir: PathBuf,
    /// Only these strategies (filter, recast, toggle, off); the ratio table
    /// needs all four, with fewer each run's speed is listed (for profiling).
    #[arg(long, value_delimiter = ',')]
    pub strategies: Vec<snell::dielectric::NestedStrategy>,
    /// Only this mode: `trace` (the fixed ray set, no shading) or `render`.
    #[arg(long, value_parser = ["trace", "render"])]
    pub mode: Option<String>,
    /// Rays a trace-mode repetition casts at least, in whole passes over the
    /// ray set (0: one pass, e.g. to count one pass's instructions).
    #[arg(long, default_value_t = snell::bench::TRACE_RAYS_PER_REP)]
    pub trace_rays_per_rep: usize,
}

// `snell bench render`.
#[derive(Args)]
pub struct BenchRenderArgs {
    /// Write the table as a JSON array (one object per scene, with provenance).
    #[arg(long)]
    pub json: Option<PathBuf>,
    #[arg(long, default_value_t = 3, value_parser = at_least_one::<usize>)]
    pub reps: usize,
    #[arg(long, default_value_t = 2, value_parser = at_least_one::<usize>)]
    pub threads: usize,
    /// Film of the timed renders: WIDTHxHEIGHTxSPP.
    #[arg(long, default_value = "320x240x16")]
    pub size: String,
    /// Samples per pixel of the render whose rays are recorded and replayed.
    #[arg(long, default_value_t = 4, value_parser = at_least_one::<u32>)]
    pub record_spp: u32,
    /// Only these scenes (names in scenes/, without .toml; default: the reference and nested scenes).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    #[arg(long, default_value = "scenes")]
    pub scenes_dir: PathBuf,
}

// `snell bench grin`.
#[derive(Args)]
pub struct BenchGrinArgs {
    /// Write the Markdown document (provenance, options, table) to this file.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
    /// Write one JSON object per scene (a JSON array, with provenance).
    #[arg(long)]
    pub json: Option<PathBuf>,
    #[arg(long, default_value_t = 5, value_parser = at_least_one::<usize>)]
    pub reps: usize,
    /// Samples per pixel (default: each scene's own).
    #[arg(long, value_parser = at_least_one::<u32>)]
    pub spp: Option<u32>,
    /// Factor on each scene's film width and height.
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    #[arg(long, default_value_t = 1, value_parser = at_least_one::<usize>)]
    pub threads: usize,
    /// Directory whose *.toml scenes with a [medium] are benched, each with
    /// its NAME_nofield.toml twin.
    #[arg(long, default_value = "scenes")]
    pub scenes: PathBuf,
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

/// `--aov`: the layers' names (listed with their meaning in `--help`), parsed
/// by the library's `FromStr`.
fn aov_parser() -> impl TypedValueParser<Value = Aov> {
    let help = |aov: Aov| match aov {
        Aov::FalseHits => "False hits skipped per sample",
        Aov::ListDepth => "Deepest interior list of any sample (a maximum)",
        Aov::Tir => "Total internal reflections per sample",
        Aov::Fallbacks => "Filtered queries finished by re-casting, per sample",
    };
    PossibleValuesParser::new(Aov::ALL.map(|a| PossibleValue::new(a.name()).help(help(a))))
        .try_map(|s| s.parse::<Aov>())
}
