//! The inverse table's plans against the full scan, through the warper
//! that builds them.
use super::plan::*;
use super::table::BIN;
use super::test_rng::Lcg;
use super::warper::CylinderWarper;
use super::HollowCylinder;
use glam::DVec3;

/// The inverse table's plans find exactly the full scan's candidates
/// (every table entry, `scan_candidates`), hence the same image count
/// and first guesses, on random targets around the tube (beside it,
/// behind it, in the hollow, near its outer wall) for every family, with
/// the tolerances the warper uses. A known-wrong plan, built as if
/// the cell were its centre point (no spread of g over the cell), loses
/// or invents candidates for some of the same targets.
#[test]
fn plans_give_the_full_scans_candidates() {
    let mut rng = Lcg(0x1b5);
    let eye = DVec3::new(0.3, 0.25, 4.0);
    for inner in [0.8, 0.5] {
        let c = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, inner, 1.5).unwrap();
        let targets: Vec<DVec3> = (0..3000)
            .map(|i| match i % 3 {
                0 => DVec3::new(
                    -5.0 + 10.0 * rng.next(),
                    -3.0 + 6.0 * rng.next(),
                    -3.0 - 2.0 * rng.next(),
                ),
                1 => DVec3::new(
                    -4.0 + 8.0 * rng.next(),
                    -2.0 + 4.0 * rng.next(),
                    -3.0 + 6.0 * rng.next(),
                ),
                _ => {
                    let (a, r) = (std::f64::consts::TAU * rng.next(), 1.3 * rng.next());
                    DVec3::new(r * a.cos(), -1.0 + 2.0 * rng.next(), r * a.sin())
                }
            })
            .collect();
        // And some almost straight above and below the eye (|β0| near 1,
        // where `dist_range` gives up its upper bound).
        let mut targets = targets;
        targets.extend((0..40).map(|i| {
            let s = if i % 2 == 0 { 1.0 } else { -1.0 };
            eye + DVec3::new(
                0.01 * (i / 2) as f64,
                s * (6.0 + 0.05 * i as f64),
                -0.02 * (i / 2) as f64,
            )
        }));
        let mut w = CylinderWarper::for_targets(c, eye, &targets).unwrap();
        // A plan for every target's cell, however few it holds.
        w.build_plans(&targets, 1);
        let plans = w.plans.as_ref().expect("plans for these targets");
        let (mut compared, mut planned, mut wrong_differs) = (0usize, 0usize, 0usize);
        let (mut evaluated, mut entries) = (0usize, 0usize);
        for &target in &targets {
            let (located, bin) = w.locate(target);
            let (p, dist) = (located.p, located.dist);
            let rp = p.length();
            if rp > inner && rp < 1.0 || (target - eye).length() < 0.2 {
                continue;
            }
            let Some(bin) = bin else { continue };
            let Some((pl, spans)) = plans.find(bin, p) else {
                continue;
            };
            planned += 1;
            let (tol, along_min) = (0.5 * BIN * dist, -0.02 * dist);
            let key = plans.slot_of(bin, p).unwrap();
            let (ix, iy) = (key % plans.nx, (key / plans.nx) % plans.ny);
            let cell = plans.cell_box(ix, iy);
            let (dmin, dmax) = dist_range(&w.tables, w.eye.e, bin, cell);
            assert!(
                dist >= dmin && dist <= dmax,
                "{target}: {dist} not in {dmin}..{dmax}"
            );
            for (fi, t) in w.tables.bins[bin].iter().enumerate() {
                if t.b.is_empty() {
                    continue;
                }
                let full = t.full_candidates(p, tol, along_min);
                let (a, b) = spans[fi];
                let segs = &pl.segs[a as usize..b as usize];
                let mut fast = Vec::new();
                t.candidates_plan(p, tol, along_min, segs, &mut fast);
                assert_eq!(full, fast, "r={inner} {target} family {fi}: {segs:?}");
                compared += 1;
                entries += t.b.len();
                evaluated += segs
                    .iter()
                    .map(|s| match *s {
                        Seg::Eval { lo, hi } => (hi - lo) as usize,
                        Seg::Ends { .. } => 2,
                        _ => 0,
                    })
                    .sum::<usize>();
                // The known-wrong variant: the cell taken as its centre.
                let mid = (cell[0] + cell[1]) * 0.5;
                let mut wrong_segs = Vec::new();
                t.plan([mid, mid], dist, dist, &mut wrong_segs);
                let mut wrong = Vec::new();
                t.candidates_plan(p, tol, along_min, &wrong_segs, &mut wrong);
                wrong_differs += usize::from(wrong != full);
            }
        }
        eprintln!(
            "r={inner}: {planned} targets with plans, {compared} family scans equal; entries evaluated {evaluated} of {entries}; the wrong plan differs in {wrong_differs}"
        );
        assert!(planned > 2500 && compared > 4000, "{planned} {compared}");
        assert!(evaluated * 5 < entries, "{evaluated} of {entries}");
        assert!(wrong_differs > 0, "the wrong plan was never caught");
    }
}
