//! The mutation fuzzer for imported scenes: the shipped Mitsuba XML and glTF
//! files (their text, a GLB's JSON chunk re-wrapped with correct lengths, or
//! its raw bytes) mutated 1–3 times each case. Every case must end in a
//! built scene (rendered at 4×3 pixels, 1 spp) or an error naming its file
//! and place; a panic, an unlocated error or a case that spends more CPU
//! time than the limit is a finding (CPU time, not wall time: the machine's
//! load must not make findings). `snell fuzz` runs it after the TOML fuzzer;
//! `tests/import_fuzz.rs` runs a smaller count.
use crate::error::Error;
use crate::fuzz::mutate;
use crate::render::{render, RenderOptions, RenderSettings};
use crate::sampling::Rng;
use crate::scene::import::{mitsuba, to_toml, ImportOptions};
use crate::scene::{load_scene, load_scene_str, BuildOptions};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Outcome counts of an import fuzz run.
#[derive(Debug, Clone, Default)]
pub struct ImportFuzzReport {
    /// Cases run.
    pub cases: u64,
    /// Cases imported, built and rendered.
    pub rendered: u64,
    /// Cases refused with an error naming the file and place.
    pub refused: u64,
    /// Findings: panics, `case i (name): message`.
    pub panics: Vec<String>,
    /// Findings: errors naming no place (not an input or file error).
    pub unlocated: Vec<String>,
    /// Findings: cases over the limit twice (a second attempt confirms),
    /// and the lesser of their two CPU times.
    pub slow: Vec<(String, f64)>,
    /// Cases over the limit once but not on the second attempt, and their
    /// two CPU times: not findings (the input did not make them slow).
    pub slow_once: Vec<(String, f64, f64)>,
    /// The costliest case: CPU seconds and `case i (name)`.
    pub slowest: (f64, String),
}

/// A seed file: its name and bytes.
enum Seed {
    Xml(String, String),
    Gltf(String, Vec<u8>),
}

/// The shipped `.xml`, `.gltf` and `.glb` scenes of `dir`.
fn seeds(dir: &Path) -> Vec<Seed> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| rd.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    paths.sort();
    paths
        .into_iter()
        .filter_map(|p| {
            let name = p.file_name()?.to_string_lossy().into_owned();
            match p.extension()?.to_str()? {
                "xml" => Some(Seed::Xml(name, std::fs::read_to_string(&p).ok()?)),
                "gltf" | "glb" => Some(Seed::Gltf(name, std::fs::read(&p).ok()?)),
                _ => None,
            }
        })
        .collect()
}

/// `bytes` mutated: the JSON of a GLB (re-wrapped so the container stays
/// valid and the mutation reaches the document) or of a `.gltf`, or a raw
/// byte flip or truncation.
fn mutate_gltf(bytes: &[u8], rng: &mut Rng) -> Vec<u8> {
    let glb = bytes.starts_with(b"glTF") && bytes.len() >= 20;
    if rng.next_u32().is_multiple_of(4) {
        let mut b = bytes.to_vec();
        if b.is_empty() {
            return b;
        }
        let i = rng.next_u32() as usize % b.len();
        if rng.next_u32().is_multiple_of(2) {
            b[i] ^= 1 << (rng.next_u32() % 8);
        } else {
            b.truncate(i);
        }
        return b;
    }
    if !glb {
        return mutate(&String::from_utf8_lossy(bytes), rng).into_bytes();
    }
    let jlen = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
    let Some(json) = bytes.get(20..20 + jlen) else {
        return bytes.to_vec();
    };
    let rest = &bytes[20 + jlen..];
    let mut js = mutate(&String::from_utf8_lossy(json), rng).into_bytes();
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let total = 20 + js.len() + rest.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((js.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(js);
    out.extend(rest);
    out
}

/// Which importer's seed files a run mutates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ImportFormat {
    /// Every `.xml`, `.gltf` and `.glb` seed.
    #[default]
    All,
    /// The Mitsuba `.xml` seeds.
    Xml,
    /// The `.gltf` and `.glb` seeds.
    Gltf,
}

impl ImportFormat {
    fn admits(self, s: &Seed) -> bool {
        matches!(
            (self, s),
            (ImportFormat::All, _)
                | (ImportFormat::Xml, Seed::Xml(..))
                | (ImportFormat::Gltf, Seed::Gltf(..))
        )
    }
}

/// A mutated document: its seed's file name, its bytes, and whether it is
/// Mitsuba XML (else glTF).
struct Case {
    name: String,
    bytes: Vec<u8>,
    xml: bool,
}

/// Case `i` of seed `seed` drawn from `seeds`.
fn make_case(seeds: &[Seed], seed: u64, i: u64) -> Option<Case> {
    if seeds.is_empty() {
        return None;
    }
    let mut rng = Rng::for_sample(seed, i, 1);
    let s = &seeds[rng.next_u32() as usize % seeds.len()];
    let n = 1 + rng.next_u32() % 3;
    Some(match s {
        Seed::Xml(name, text) => {
            let mut m = text.clone();
            for _ in 0..n {
                m = mutate(&m, &mut rng);
            }
            Case {
                name: name.clone(),
                bytes: m.into_bytes(),
                xml: true,
            }
        }
        Seed::Gltf(name, bytes) => {
            let mut m = bytes.clone();
            for _ in 0..n {
                m = mutate_gltf(&m, &mut rng);
            }
            Case {
                name: name.clone(),
                bytes: m,
                xml: false,
            }
        }
    })
}

/// The mutated document of case `i` (its seed's file name and its bytes),
/// as a run over `format` makes it: write it beside the seed's textures to
/// reproduce a finding with `snell render` or `snell convert`.
pub fn case_document(scene_dir: &Path, format: ImportFormat, seed: u64, i: u64) -> Option<(String, Vec<u8>)> {
    let seeds: Vec<Seed> = seeds(scene_dir)
        .into_iter()
        .filter(|s| format.admits(s))
        .collect();
    make_case(&seeds, seed, i).map(|c| (c.name, c.bytes))
}

/// What an import fuzz run covers.
#[derive(Debug, Clone)]
pub struct ImportFuzzConfig {
    /// The directory of the seed files (and the textures and buffers they use).
    pub scene_dir: PathBuf,
    /// Which seeds are mutated.
    pub format: ImportFormat,
    /// The first case.
    pub first: u64,
    /// How many cases.
    pub cases: u64,
    /// The run's seed.
    pub seed: u64,
    /// CPU time a case may take.
    pub limit: Duration,
    /// Where each finding's document is written (`c{i}_{seed file name}`).
    pub save_findings: Option<PathBuf>,
}

/// Run `cases` mutated imported scenes from the `.xml`/`.gltf`/`.glb` files
/// in `scene_dir`. Case i draws from `Rng::for_sample(seed, i, 1)`. Mutated
/// glTF files are written to a private temporary directory beside copies of
/// the files they refer to (their meshes are read from there when built).
pub fn run(scene_dir: &Path, cases: u64, seed: u64, limit: Duration) -> ImportFuzzReport {
    run_with(&ImportFuzzConfig {
        scene_dir: scene_dir.to_path_buf(),
        format: ImportFormat::All,
        first: 0,
        cases,
        seed,
        limit,
        save_findings: None,
    })
}

/// `run` as `cfg` says. Case i is the same for any `first` (reproduce one
/// with `snell fuzz --cases 0 --json-cases 0 --first i --import-cases 1`
/// and the run's `--import-format`); a run restricted to one format draws
/// its cases from that format's seeds only, so its case numbers differ
/// from a run over all.
pub fn run_with(cfg: &ImportFuzzConfig) -> ImportFuzzReport {
    let scene_dir = cfg.scene_dir.as_path();
    let mut rep = ImportFuzzReport::default();
    let seeds: Vec<Seed> = seeds(scene_dir)
        .into_iter()
        .filter(|s| cfg.format.admits(s))
        .collect();
    if seeds.is_empty() {
        return rep;
    }
    let tmp = std::env::temp_dir().join(format!("snell-import-fuzz-{}-{}", std::process::id(), cfg.seed));
    let _ = std::fs::create_dir_all(&tmp);
    // Images and buffers a glTF may refer to, beside the mutated copies.
    if let Ok(rd) = std::fs::read_dir(scene_dir) {
        for p in rd.filter_map(|e| e.ok()).map(|e| e.path()) {
            if p.extension().is_some_and(|x| x == "png" || x == "bin") {
                if let Some(n) = p.file_name() {
                    let _ = std::fs::copy(&p, tmp.join(n));
                }
            }
        }
    }
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let limit = cfg.limit.as_secs_f64();
    for i in cfg.first..cfg.first.saturating_add(cfg.cases) {
        let Some(case) = make_case(&seeds, cfg.seed, i) else {
            break;
        };
        let name = case.name.as_str();
        let label = format!("case {i} ({name})");
        let (outcome, mut el) = attempt(&case, scene_dir, &tmp);
        let mut slow = el > limit;
        if slow {
            // A case's work is a function of its document: a second attempt
            // under the limit says the machine, not the input, made the
            // first one slow (it is still reported, apart).
            let (_, again) = attempt(&case, scene_dir, &tmp);
            if again <= limit {
                rep.slow_once.push((label.clone(), el, again));
                slow = false;
            } else {
                rep.slow.push((label.clone(), el.min(again)));
            }
            el = el.min(again);
        }
        rep.cases += 1;
        if el > rep.slowest.0 {
            rep.slowest = (el, label.clone());
        }
        let finding = slow
            || !matches!(
                outcome,
                Ok(Ok(())) | Ok(Err(Error::Input { .. } | Error::Io { .. }))
            );
        if let (true, Some(dir)) = (finding, &cfg.save_findings) {
            let _ = std::fs::create_dir_all(dir);
            let _ = std::fs::write(dir.join(format!("c{i}_{name}")), &case.bytes);
        }
        match outcome {
            Ok(Ok(())) => rep.rendered += 1,
            Ok(Err(Error::Input { .. } | Error::Io { .. })) => rep.refused += 1,
            Ok(Err(e)) => rep.unlocated.push(format!("{label}: {e}")),
            Err(p) => {
                let msg = p
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                rep.panics.push(format!("{label}: {msg}"));
            }
        }
    }
    std::panic::set_hook(prev);
    let _ = std::fs::remove_dir_all(&tmp);
    rep
}

/// One attempt at `case`: imported, built and rendered (a glTF document
/// written to `tmp` first, beside the seeds' textures), with the process's
/// CPU seconds it took (wall seconds where the CPU clock fails).
fn attempt(
    case: &Case,
    scene_dir: &Path,
    tmp: &Path,
) -> (std::thread::Result<crate::error::Result<()>>, f64) {
    let name = case.name.as_str();
    let t = Instant::now();
    let cpu0 = crate::timing::process_cpu_s();
    let built = if case.xml {
        let m = String::from_utf8_lossy(&case.bytes);
        catch_unwind(AssertUnwindSafe(|| {
            let imp = mitsuba::import_str(name, &m, scene_dir, &ImportOptions::default())?;
            let toml = to_toml(&imp.desc)?;
            load_scene_str(
                &format!("{name} (imported)"),
                &toml,
                scene_dir,
                &BuildOptions::default(),
            )
        }))
    } else {
        let path = tmp.join(name);
        let _ = std::fs::write(&path, &case.bytes);
        catch_unwind(AssertUnwindSafe(|| load_scene(&path, &BuildOptions::default())))
    };
    let outcome = match built {
        Ok(Ok(scene)) => catch_unwind(AssertUnwindSafe(|| {
            let (w, h) = (4.min(scene.width), 3.min(scene.height));
            let set = RenderSettings::from_scene(&scene)
                .with_resolution(w, h)?
                .with_spp(1);
            let opts = RenderOptions {
                threads: Some(1),
                want_aovs: false,
                ..Default::default()
            };
            render(&scene, &set, &opts).map(|_| ())
        })),
        Ok(Err(e)) => Ok(Err(e)),
        Err(p) => Err(p),
    };
    let el = match (cpu0, crate::timing::process_cpu_s()) {
        (Some(a), Some(b)) => b - a,
        _ => t.elapsed().as_secs_f64(),
    };
    (outcome, el)
}
