//! `snell fuzz`: mutation fuzzing of the scene loader and renderer, and of
//! the grin-trace / warp-points documents, and of the Mitsuba / glTF
//! importers; the findings on stdout.
use crate::args::FuzzArgs;
use snell::{Error, Result};
use std::time::{Duration, Instant};

pub fn fuzz(a: FuzzArgs) -> Result<()> {
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
    // Imported scenes get 3 s of CPU by default: the glTF glass of water
    // (two overlapping mesh solids) takes about 0.8 s to build and start.
    if !(a.import_limit > 0.0 && a.import_limit.is_finite()) {
        return Err(Error::Invalid(format!(
            "--import-limit: expected seconds > 0, got {}",
            a.import_limit
        )));
    }
    let limit = Duration::from_secs_f64(a.import_limit);
    let t = Instant::now();
    let format = a.import_format.into();
    let ir = snell::fuzz_import::run_with(&snell::fuzz_import::ImportFuzzConfig {
        scene_dir: a.scenes_dir.clone(),
        format,
        first: a.first,
        cases: a.import_cases.unwrap_or(a.cases),
        seed: a.seed,
        limit,
        save_findings: a.save_findings.clone(),
    });
    say!("{}", import_fuzz_line(&ir, t.elapsed(), format, limit));
    print_findings(&ir.panics, &ir.unlocated, &ir.slow);
    for (d, first, again) in ir.slow_once.iter().take(5) {
        say!("over the limit once: {first:.2} s, then {again:.2} s: {d}");
    }
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

/// The importers' fuzzer's totals.
fn import_fuzz_line(
    ir: &snell::fuzz_import::ImportFuzzReport,
    elapsed: Duration,
    format: snell::fuzz_import::ImportFormat,
    limit: Duration,
) -> String {
    let formats = match format {
        snell::fuzz_import::ImportFormat::All => "Mitsuba XML, glTF",
        snell::fuzz_import::ImportFormat::Xml => "Mitsuba XML",
        snell::fuzz_import::ImportFormat::Gltf => "glTF",
    };
    format!(
        "{} imported scenes ({formats}) in {:.1} s: {} rendered, {} refused with a located error, {} unlocated, {} panics, {} over {} s of CPU twice ({} once only); costliest {:.3} s ({})",
        ir.cases,
        elapsed.as_secs_f64(),
        ir.rendered,
        ir.refused,
        ir.unlocated.len(),
        ir.panics.len(),
        ir.slow.len(),
        limit.as_secs_f64(),
        ir.slow_once.len(),
        ir.slowest.0,
        ir.slowest.1
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
