//! `cargo bench --bench embree_bare`: bare Embree rays/s (one thread) with no
//! filter, an accept-all filter and a recording filter, as ratios from one run
//! (the table is `BareFigures`' own, as `snell bench embree` prints it).
fn main() -> snell::Result<()> {
    println!("{}", snell::bench_header());
    println!("{}", snell::bench::embree_bare(1_000_000, 5)?);
    Ok(())
}
