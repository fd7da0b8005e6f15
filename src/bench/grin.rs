//! `snell bench grin`: every curved-ray scene of a directory (a TOML file
//! with a `[medium]`) against its no-field twin (`NAME_nofield.toml`, the
//! same scene without the `[medium]` table), rendered at the scene's own
//! film, repetitions interleaved; [`grin_table`] formats the Markdown table.
use super::{at_least_one_rep, ratio_spread};
use crate::error::{Error, Result};
use crate::render::{render, RenderOptions, RenderSettings};
use crate::scene::{load_scene, BuildOptions, RenderScene};
use crate::timing::median;
use std::path::{Path, PathBuf};

/// Options of the curved-ray benchmark (the default: every medium scene in
/// `scenes/`, 5 repetitions, one thread, the scenes' own film).
#[derive(Debug, Clone)]
pub struct GrinBenchOptions {
    /// Directory whose `*.toml` files are read (not its subdirectories).
    pub scenes_dir: PathBuf,
    /// Repetitions (at least 1); each renders the scene and its twin back to
    /// back, the order alternating.
    pub reps: usize,
    /// Samples per pixel (`None`: the scene's own).
    pub spp: Option<u32>,
    /// Factor on the scene's film width and height (finite, > 0; at least
    /// one pixel a side). The chords do not change with it: a medium's
    /// pixel tolerance follows the scene's `[film]`.
    pub scale: f64,
    /// Render threads.
    pub threads: usize,
}

impl Default for GrinBenchOptions {
    fn default() -> Self {
        GrinBenchOptions {
            scenes_dir: "scenes".into(),
            reps: 5,
            spp: None,
            scale: 1.0,
            threads: 1,
        }
    }
}

/// One scene and its twin over all repetitions (serialised as is in
/// `snell bench grin --json`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct GrinRun {
    /// The scene's file stem.
    pub scene: String,
    /// The twin's file stem (`SCENE_nofield`).
    pub twin: String,
    /// The medium's field kind (`hot_ground`, `profile`, …).
    pub field: String,
    /// The method the medium is traced by, `auto` resolved.
    pub method: String,
    /// True when the scene leaves the method to `auto` (no `method` key, or
    /// `method = "auto"`), false when it names one.
    pub method_auto: bool,
    /// Film of the renders: width, height, samples per pixel.
    pub film: (u32, u32, u32),
    /// Straight chords cast per path segment that entered the medium's
    /// bounds (the scene's last render; the same in every repetition).
    pub chords_per_medium_segment: f64,
    /// Wall time of every repetition of the scene (seconds).
    pub scene_walls: Vec<f64>,
    /// Wall time of every repetition of the twin (seconds).
    pub twin_walls: Vec<f64>,
    /// The render pool's CPU time of every repetition of the scene
    /// (seconds); empty when a reading is missing.
    pub scene_cpus: Vec<f64>,
    /// The same for the twin.
    pub twin_cpus: Vec<f64>,
}

impl GrinRun {
    /// Scene time / twin time per repetition, from wall times: median, min, max.
    pub fn wall_ratio(&self) -> (f64, f64, f64) {
        ratio_spread(&self.twin_walls, &self.scene_walls)
    }

    /// The same from CPU times (`None` without them).
    pub fn cpu_ratio(&self) -> Option<(f64, f64, f64)> {
        (!self.scene_cpus.is_empty() && !self.twin_cpus.is_empty())
            .then(|| ratio_spread(&self.twin_cpus, &self.scene_cpus))
    }
}

/// A medium scene found in a directory, with its twin.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GrinPair {
    /// The scene file.
    pub scene: PathBuf,
    /// Its twin, `STEM_nofield.toml` beside it.
    pub twin: PathBuf,
    /// The scene leaves the method to `auto`.
    pub method_auto: bool,
}

/// Every `*.toml` in `dir` with a top-level `medium` table, in name order,
/// each with its twin.
///
/// # Errors
///
/// [`Error::Io`] naming the directory when it cannot be read, naming a file
/// that cannot be read or is not TOML, or naming a medium scene whose twin
/// is missing or has a `[medium]` itself; [`Error::Invalid`] when no file
/// has a `[medium]`.
pub fn grin_pairs(dir: &Path) -> Result<Vec<GrinPair>> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, format!("cannot read the scenes directory: {e}")))?;
    let mut files = Vec::new();
    for e in entries {
        let p = e.map_err(|e| Error::io(dir, e))?.path();
        if p.extension().is_some_and(|x| x == "toml") && p.is_file() {
            files.push(p);
        }
    }
    files.sort();
    // Parsing the TOML alone decides whether a file has a medium, so that
    // scenes without one are not built.
    let medium_of = |p: &Path| -> Result<Option<toml::Value>> {
        let text = std::fs::read_to_string(p).map_err(|e| Error::io(p, e))?;
        let table: toml::Table =
            toml::from_str(&text).map_err(|e| Error::io(p, format!("not a TOML scene: {e}")))?;
        Ok(table.get("medium").cloned())
    };
    let mut pairs = Vec::new();
    for p in &files {
        let Some(medium) = medium_of(p)? else {
            continue;
        };
        let stem = p
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        let twin = p.with_file_name(format!("{stem}_nofield.toml"));
        if !twin.is_file() {
            return Err(Error::io(
                p,
                format!(
                    "has a [medium] but no twin {} (the same scene without the [medium] table)",
                    twin.display()
                ),
            ));
        }
        if medium_of(&twin)?.is_some() {
            return Err(Error::io(
                &twin,
                format!("is the twin of {} but has a [medium] itself", p.display()),
            ));
        }
        let method_auto = match medium.get("method") {
            None => true,
            Some(m) => m.as_str() == Some("auto"),
        };
        pairs.push(GrinPair {
            scene: p.clone(),
            twin,
            method_auto,
        });
    }
    if pairs.is_empty() {
        return Err(Error::io(dir, "no scene with a [medium] in this directory"));
    }
    Ok(pairs)
}

/// The file stem of `p`.
fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default()
}

/// Run the curved-ray benchmark on every pair [`grin_pairs`] finds;
/// `progress` receives a line per scene.
///
/// # Errors
///
/// [`Error::Invalid`] when `reps` or `threads` is 0, `spp` is 0 or `scale`
/// is not finite and positive; an error of [`grin_pairs`]; a scene that does
/// not load or render (its error names the file).
pub fn grin(opts: &GrinBenchOptions, mut progress: impl FnMut(&str)) -> Result<Vec<GrinRun>> {
    at_least_one_rep(opts.reps)?;
    if !(opts.scale.is_finite() && opts.scale > 0.0) {
        return Err(Error::Invalid(format!(
            "bench grin: scale must be finite and positive, got {}",
            opts.scale
        )));
    }
    if opts.spp == Some(0) || opts.threads == 0 {
        return Err(Error::Invalid(
            "bench grin: spp and threads must be at least 1".into(),
        ));
    }
    let pairs = grin_pairs(&opts.scenes_dir)?;
    let mut runs = Vec::new();
    for pair in &pairs {
        let scene = load_scene(&pair.scene, &BuildOptions::default())?;
        let twin = load_scene(&pair.twin, &BuildOptions::default())?;
        let Some(medium) = scene.medium.as_ref() else {
            return Err(Error::io(&pair.scene, "loaded without a medium"));
        };
        let scaled = |v: u32| ((v as f64 * opts.scale).round() as u32).max(1);
        // The twin is rendered with the scene's settings: the same film,
        // samples and seed, so only the medium differs.
        let mut settings =
            RenderSettings::from_scene(&scene).with_resolution(scaled(scene.width), scaled(scene.height))?;
        if let Some(spp) = opts.spp {
            settings = settings.with_spp(spp);
        }
        let mut run = GrinRun {
            scene: stem(&pair.scene),
            twin: stem(&pair.twin),
            field: medium.field().kind().into(),
            method: medium.method().name().into(),
            method_auto: pair.method_auto,
            film: (settings.width, settings.height, settings.spp),
            chords_per_medium_segment: 0.0,
            scene_walls: vec![],
            twin_walls: vec![],
            scene_cpus: vec![],
            twin_cpus: vec![],
        };
        progress(&format!(
            "{}: {}x{}x{}, {} (auto: {}) against {}",
            run.scene, settings.width, settings.height, settings.spp, run.method, run.method_auto, run.twin
        ));
        let (mut scene_cpus, mut twin_cpus) = (vec![], vec![]);
        let options = RenderOptions {
            threads: Some(opts.threads),
            ..RenderOptions::default()
        };
        let one = |s: &RenderScene| render(s, &settings, &options);
        for rep in 0..opts.reps {
            // Alternating which goes first spreads the cost of caches the
            // other render left cold over both.
            let (a, b) = if rep % 2 == 0 {
                let a = one(&scene)?;
                (a, one(&twin)?)
            } else {
                let b = one(&twin)?;
                (one(&scene)?, b)
            };
            let c = &a.stats.counters;
            run.chords_per_medium_segment = c.chords as f64 / c.medium_segments.max(1) as f64;
            run.scene_walls.push(a.stats.wall_s);
            run.twin_walls.push(b.stats.wall_s);
            scene_cpus.push(a.stats.cpu_s);
            twin_cpus.push(b.stats.cpu_s);
        }
        let all = |v: Vec<Option<f64>>| v.into_iter().collect::<Option<Vec<f64>>>().unwrap_or_default();
        run.scene_cpus = all(scene_cpus);
        run.twin_cpus = all(twin_cpus);
        if run.scene_cpus.is_empty() || run.twin_cpus.is_empty() {
            run.scene_cpus.clear();
            run.twin_cpus.clear();
        }
        runs.push(run);
    }
    Ok(runs)
}

/// The Markdown document of a run: the provenance line (machine, SIMD
/// levels, commit, Embree), the options, then one table row per scene.
/// `command` is the command line that made it (shown so the table can be
/// regenerated). Every line ends in a newline.
pub fn grin_table(runs: &[GrinRun], opts: &GrinBenchOptions, command: &str) -> String {
    let mut out = format!("provenance: {}\n\n", crate::provenance::line());
    out.push_str(&format!(
        "`{command}`: {} thread(s), film scaled by {} of each scene's own{}, median of {} interleaved repetitions.\n\n",
        opts.threads,
        opts.scale,
        opts.spp.map_or(String::new(), |s| format!(", {s} spp")),
        opts.reps
    ));
    out.push_str(
        "| scene | twin | field | method | film | chords / medium segment | scene s | twin s | scene / twin (min–max) | CPU scene / twin (min–max) |\n",
    );
    out.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    let ratio = |(m, lo, hi): (f64, f64, f64)| format!("{m:.2}× ({lo:.2}–{hi:.2})");
    for r in runs {
        out.push_str(&format!(
            "| {} | {} | {} | {} ({}) | {}×{}×{} | {:.2} | {:.4} | {:.4} | {} | {} |\n",
            r.scene,
            r.twin,
            r.field,
            r.method,
            if r.method_auto { "auto" } else { "set" },
            r.film.0,
            r.film.1,
            r.film.2,
            r.chords_per_medium_segment,
            median(&r.scene_walls),
            median(&r.twin_walls),
            ratio(r.wall_ratio()),
            r.cpu_ratio().map_or("-".into(), ratio)
        ));
    }
    out.push_str(
        "\nscene / twin: the render's wall time over its twin's, per repetition (the two rendered back to back), median and range; CPU: the same from the render threads' CPU time, which a loaded machine does not inflate. method: the one the medium is traced by, chosen by `auto` or set in the scene.\n",
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("snell-bench-grin-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// Medium scenes are found by their table, twins by name; a missing or
    /// a curved twin is an error naming the files.
    #[test]
    fn pairs_are_found_and_missing_twins_named() {
        let d = dir("pairs");
        let w = |n: &str, t: &str| std::fs::write(d.join(n), t).unwrap();
        w("a.toml", "[medium]\nmethod = \"rk45\"\n");
        w("a_nofield.toml", "x = 1\n");
        w("b.toml", "[camera]\n");
        w("c.toml", "[medium]\n");
        w("c_nofield.toml", "");
        w("notes.txt", "[medium]\n");
        let p = grin_pairs(&d).unwrap();
        assert_eq!(p.len(), 2, "{p:?}");
        assert_eq!(
            (stem(&p[0].scene), stem(&p[0].twin), p[0].method_auto),
            ("a".into(), "a_nofield".into(), false)
        );
        assert!(p[1].method_auto);
        w("e.toml", "[medium]\n");
        let e = grin_pairs(&d).unwrap_err().to_string();
        assert!(e.contains("e.toml") && e.contains("e_nofield.toml"), "{e}");
        w("e_nofield.toml", "[medium]\n");
        let e = grin_pairs(&d).unwrap_err().to_string();
        assert!(
            e.contains("e_nofield.toml") && e.contains("has a [medium]"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&d);
        let e = grin_pairs(&d).unwrap_err().to_string();
        assert!(e.contains(&d.display().to_string()), "{e}");
    }
}
