//! `snell bench render` as an example until the CLI has it:
//! `cargo run --release --example bench_render -- [W H SPP THREADS REPS]`
fn main() -> snell::Result<()> {
    let a: Vec<u32> = std::env::args().skip(1).filter_map(|x| x.parse().ok()).collect();
    let mut o = snell::ceiling::CeilingOptions::default();
    if a.len() >= 3 {
        o.render = (a[0], a[1], a[2]);
    }
    if let Some(&t) = a.get(3) {
        o.threads = t as usize;
    }
    if let Some(&r) = a.get(4) {
        o.reps = r as usize;
    }
    println!("{}", snell::bench_header());
    let runs = snell::ceiling::ceiling(&o, |m| eprintln!("{m}"))?;
    print!("{}", snell::ceiling::table(&runs, &o));
    Ok(())
}
