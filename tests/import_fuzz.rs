//! A smoke run of the import fuzzer (the full run is `snell fuzz --cases
//! 100000`): mutated Mitsuba XML and glTF scenes end in a render or an
//! error naming the file and place, never a panic, an unlocated error or a
//! case over three seconds of CPU (the glTF glass of water, two overlapping
//! mesh solids, takes about 0.8 s to build and start).
use snell::fuzz_import;
use std::path::Path;
use std::time::Duration;

#[test]
fn mutated_imported_scenes_never_panic() {
    let rep = fuzz_import::run(Path::new("scenes"), 800, 2026, Duration::from_secs(3));
    eprintln!(
        "{} cases: {} rendered, {} refused, {} panics, costliest {:.3} s of CPU ({})",
        rep.cases,
        rep.rendered,
        rep.refused,
        rep.panics.len(),
        rep.slowest.0,
        rep.slowest.1
    );
    assert_eq!(rep.cases, 800);
    assert!(rep.panics.is_empty(), "panics:\n{}", rep.panics.join("\n"));
    assert!(
        rep.unlocated.is_empty(),
        "unlocated:\n{}",
        rep.unlocated.join("\n")
    );
    assert!(rep.slow.is_empty(), "slow: {:?}", rep.slow);
    assert!(
        rep.rendered > 0 && rep.refused > 0,
        "the mutations must reach both outcomes"
    );
}
