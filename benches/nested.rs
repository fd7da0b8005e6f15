//! `cargo bench --bench nested`: filter vs re-cast vs toggle vs no nesting on
//! every nested scene and the no-overlap references; trace-only and render.
//! The full version with JSON output is `snell bench nested --json FILE`.
fn main() -> snell::Result<()> {
    println!("{}", snell::bench_header());
    let opts = snell::bench::NestedBenchOptions {
        reps: 3,
        ..Default::default()
    };
    let runs = snell::bench::nested(&opts, |m| eprintln!("{m}"))?;
    print!("{}", snell::bench::nested_ratios(&runs));
    Ok(())
}
