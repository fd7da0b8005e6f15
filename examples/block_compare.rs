//! Judges EXR renders against a reference the way the image tests do
//! (docs/design.md, "Comparing images honestly"): the RMS difference of k×k
//! block means against REF, divided by the same between REF and REF2 (the
//! reference with another seed: pure noise). About 1 means noise only.
//!
//!   cargo run --release --example block_compare -- REF.exr REF2.exr CAND.exr... [--k 16]
use std::path::Path;

fn main() -> snell::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut k = 16;
    if let Some(i) = args.iter().position(|a| a == "--k") {
        k = args.get(i + 1).and_then(|v| v.parse().ok()).unwrap_or(16);
        args.drain(i..(i + 2).min(args.len()));
    }
    if args.len() < 3 {
        eprintln!("usage: block_compare REF.exr REF2.exr CAND.exr... [--k 16]");
        std::process::exit(2);
    }
    let read = |p: &str| snell::image_io::read_exr_rgb(Path::new(p));
    let (w, h, r1) = read(&args[0])?;
    let (_, _, r2) = read(&args[1])?;
    let noise = snell::report::image_errors(&r1, &r2, w, h, k).1;
    println!(
        "{w}x{h}, {k}x{k} block means; seed-to-seed block RMS {noise:.4e} ({} vs {})",
        args[0], args[1]
    );
    for c in &args[2..] {
        let (cw, ch, px) = read(c)?;
        if (cw, ch) != (w, h) {
            println!("{c}: {cw}x{ch}, not {w}x{h}");
            continue;
        }
        let (e_px, e_blk) = snell::report::image_errors(&r1, &px, w, h, k);
        println!(
            "{c}: block RMS {e_blk:.4e} = {:.2}x seed-to-seed (per-pixel RMSE {e_px:.4e})",
            e_blk / noise
        );
    }
    Ok(())
}
