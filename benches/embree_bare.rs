//! `cargo bench --bench embree_bare`: bare Embree rays/s (one thread) with no
//! filter, an accept-all filter and a recording filter, as ratios from one run.
fn main() -> snell::Result<()> {
    println!("{}", snell::bench_header());
    let f = snell::bench::embree_bare(1_000_000, 5)?;
    println!(
        "bare Embree, 1 thread, {} incoherent rays, {} triangles (two overlapping meshes), median of 5",
        f.rays, f.triangles
    );
    println!("  no filter          {:8.3} Mrays/s  ratio 1.000", f.no_filter);
    println!(
        "  accept-all filter  {:8.3} Mrays/s  ratio {:.3}",
        f.accept_all,
        f.accept_all / f.no_filter
    );
    println!(
        "  recording filter   {:8.3} Mrays/s  ratio {:.3}",
        f.recording,
        f.recording / f.no_filter
    );
    Ok(())
}
