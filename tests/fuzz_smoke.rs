//! A smoke run of the scene fuzzer (the full run is `make fuzz`, 100,000 cases):
//! every mutated shipped scene ends in a render or a located error, never a
//! panic, an unlocated error or a case slower than one second.
use snell::fuzz;
use std::path::Path;
use std::time::Duration;

#[test]
fn mutated_scenes_never_panic() {
    let seeds = fuzz::shipped_scenes(Path::new("scenes"));
    assert!(seeds.len() >= 8, "shipped scenes found: {}", seeds.len());
    let rep = fuzz::run(&seeds, Path::new("scenes"), 3000, 2026, Duration::from_secs(1));
    eprintln!(
        "{} cases: {} rendered, {} errors, {} panics, slowest {:.3} s ({})",
        rep.cases,
        rep.rendered,
        rep.errors,
        rep.panics.len(),
        rep.slowest.0,
        rep.slowest.1
    );
    assert!(rep.panics.is_empty(), "panics:\n{}", rep.panics.join("\n\n"));
    assert!(
        rep.unlocated_errors.is_empty(),
        "errors without file/key/line:\n{}",
        rep.unlocated_errors.join("\n")
    );
    assert!(
        rep.rendered > 0 && rep.errors > 0,
        "the mutations must reach both outcomes"
    );
}

/// The JSON batch tools (`grin-trace`, `warp-points`) on mutated documents:
/// never a panic, every refusal located, no case over one second.
#[test]
fn mutated_json_queries_never_panic_or_hang() {
    let seeds = fuzz::json_seeds(Path::new("tests/data/fuzz"));
    assert!(seeds.len() >= 3, "json seeds: {}", seeds.len());
    let rep = fuzz::run_json(&seeds, 2000, 2026, Duration::from_secs(1));
    eprintln!(
        "{} json cases: {} answered ({} item errors), {} refused, {} panics, slowest {:.3} s ({})",
        rep.cases,
        rep.answered,
        rep.item_errors,
        rep.refused,
        rep.panics.len(),
        rep.slowest.0,
        rep.slowest.1
    );
    assert!(rep.panics.is_empty(), "panics:\n{}", rep.panics.join("\n\n"));
    assert!(
        rep.unlocated.is_empty(),
        "unlocated:\n{}",
        rep.unlocated.join("\n")
    );
    assert!(
        rep.slow.is_empty(),
        "cases over 1 s:\n{}",
        rep.slow
            .iter()
            .map(|(d, s)| format!("{s:.2} s: {d}"))
            .collect::<Vec<_>>()
            .join("\n\n")
    );
    assert!(rep.answered > 0 && rep.refused > 0);
}
