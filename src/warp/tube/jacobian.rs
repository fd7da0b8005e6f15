//! The residuals of a tube image in (b, β) with their Jacobian in closed
//! form: one evaluation per Newton step of the fast solver's polish.
use super::family::Family;
use super::geometry::HollowCylinder;
use glam::DVec2;

impl HollowCylinder {
    /// The residuals of `newton_image` in (b, β) directly, with their
    /// Jacobian in closed form: `([g, climb − dv], [[∂g/∂b, ∂g/∂β],
    /// [∂climb/∂b, ∂climb/∂β]])`, or `None` where the family does not apply
    /// or the target is behind the final ray.
    ///
    /// One evaluation replaces the three of a finite-difference Jacobian.
    /// The final direction's angle is ψ = ψ0(b) + sg·T, T the family's sum of
    /// the angles θ1..θ4 of `path` (dθ = d(sin θ)/cos θ); the origin
    /// o = −b·h⊥ ± hc·h with hc = √(ρ_f² − b²); then
    /// dg = −along·dψ − h × do and d along = g·dψ − h·do. Singular at the
    /// family edges (a cos θ → 0): the fast solver uses it away from them
    /// only. Checked against finite differences in the tests.
    ///
    /// The fast solver evaluates it eight (AVX-512) or four (AVX2) at a
    /// time (`lanes::newton_rows`, every level tested equal to this one bit
    /// for bit), and row by row with this one elsewhere.
    ///
    /// The target is in the hollow for hollow2 and outside it for the other
    /// families, as the fast solver's polishes are.
    pub(crate) fn resid_jac(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        dv: f64,
        b: f64,
        beta: f64,
    ) -> Option<([f64; 2], [[f64; 2]; 2])> {
        let (big, small) = (self.outer_radius, self.inner_radius);
        // Divisions and square roots are most of an evaluation's time in
        // vector lanes: radii divide as products with their reciprocals,
        // and the reciprocals of m_a, m_g, cx, c1 and c2 come from two
        // divisions (1/(x·y) times the other factors).
        let (inv_big, inv_small) = (1.0 / big, 1.0 / small);
        let ab = b.abs();
        let rho = e.length();
        if ab >= big || ab >= rho {
            return None;
        }
        let bb = beta * beta;
        let ma = (1.0 - bb).sqrt();
        let mg = (self.ior * self.ior - bb).sqrt();
        let r_m = 1.0 / (ma * mg);
        let (ima, img) = (mg * r_m, ma * r_m);
        let k = ma * img;
        // dk/dβ = k·β·(1/m_g² − 1/m_a²).
        let k_beta = k * beta * (img * img - ima * ima);
        let al = ab * k;
        let sg = if b < 0.0 { -1.0 } else { 1.0 };
        // |L| = |b|·k: derivatives with respect to b and β.
        let (al_b, al_beta) = (sg * k, ab * k_beta);
        // h0 (as `dir_for`) and its derivative in b.
        let inward = -e / rho;
        let perp_i = DVec2::new(-inward.y, inward.x);
        let x = b * (-1.0 / rho);
        let cx = (1.0 - x * x).sqrt();
        let h0 = inward * cx + perp_i * x;
        let s1 = ab * inv_big;
        let c1 = (1.0 - s1 * s1).sqrt();
        let s2 = al * inv_big;
        let c2 = (1.0 - s2 * s2).sqrt();
        let cx_c1 = cx * c1;
        let r_c = 1.0 / (cx_c1 * c2);
        let (icx, ic1, ic2) = (c1 * c2 * r_c, cx * c2 * r_c, cx_c1 * r_c);
        let h0_b = (inward * (-x * icx) + perp_i) * (-1.0 / rho);
        // ψ0' = h0' · h0⊥ (h0 is unit).
        let psi0_b = h0_b.dot(DVec2::new(-h0.y, h0.x));
        let rot12 = DVec2::new(c1 * c2 + s1 * s2, s1 * c2 - c1 * s2);
        let air0 = -e.dot(h0) - big * c1;
        if air0 <= 0.0 {
            return None;
        }
        // d(air0)/db = −e·h0' + sg·s1/c1.
        let air0_b = -e.dot(h0_b) + sg * s1 * ic1;
        // dθ1/d|b|, dθ2/d|L|.
        let t1 = inv_big * ic1;
        let t2 = inv_big * ic2;
        let mul = |a: DVec2, b: DVec2| DVec2::new(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
        // (turn, final radius and 1/(its cosine·radius), first, air,
        //  ∂air/∂b, glass, ∂glass/∂|L|, ∂T/∂|b| at fixed |L|, ∂T/∂|L|)
        let (turn, hc, ihc, first, air, air_b, glass, glass_al, tb, tl) = match fam {
            Family::Wall2 => {
                if al < small {
                    return None;
                }
                (
                    mul(rot12, rot12),
                    big * c1,
                    t1,
                    false,
                    air0,
                    air0_b,
                    2.0 * big * c2,
                    -2.0 * s2 * ic2,
                    2.0 * t1,
                    -2.0 * t2,
                )
            }
            Family::Tir2 => {
                if ab <= small || al >= small {
                    return None;
                }
                let s3 = al * inv_small;
                let c3 = (1.0 - s3 * s3).sqrt();
                let ic3 = 1.0 / c3;
                let refl = DVec2::new(-(1.0 - 2.0 * s3 * s3), -2.0 * s3 * c3);
                let t3 = inv_small * ic3;
                (
                    mul(mul(rot12, rot12), refl),
                    big * c1,
                    t1,
                    false,
                    air0,
                    air0_b,
                    2.0 * (big * c2 - small * c3),
                    2.0 * (-(s2 * ic2) + s3 * ic3),
                    2.0 * t1,
                    -2.0 * t2 + 2.0 * t3,
                )
            }
            Family::Through4 | Family::Hollow2 => {
                if ab >= small {
                    return None;
                }
                let s3 = al * inv_small;
                let c3 = (1.0 - s3 * s3).sqrt();
                let ic3 = 1.0 / c3;
                let s4 = ab * inv_small;
                let c4 = (1.0 - s4 * s4).sqrt();
                let ic4 = 1.0 / c4;
                let rot43 = DVec2::new(c4 * c3 + s4 * s3, -(s4 * c3 - c4 * s3));
                let half = mul(rot12, rot43);
                let g1 = big * c2 - small * c3;
                let g1_al = -(s2 * ic2) + s3 * ic3;
                let (t3, t4) = (inv_small * ic3, inv_small * ic4);
                if fam == Family::Hollow2 {
                    (
                        half,
                        small * c4,
                        t4,
                        true,
                        air0,
                        air0_b,
                        g1,
                        g1_al,
                        t1 - t4,
                        -t2 + t3,
                    )
                } else {
                    (
                        mul(half, half),
                        big * c1,
                        t1,
                        false,
                        air0 + 2.0 * small * c4,
                        air0_b - 2.0 * sg * s4 * ic4,
                        2.0 * g1,
                        2.0 * g1_al,
                        2.0 * (t1 - t4),
                        2.0 * (-t2 + t3),
                    )
                }
            }
            Family::Direct => return None,
        };
        let turn = DVec2::new(turn.x, sg * turn.y);
        let hf = mul(h0, turn);
        let perp = DVec2::new(-hf.y, hf.x);
        // ψ = ψ0 + sg·T(|b|, |L|): d/db = ψ0' + T_|b| + T_|L|·k, d/dβ = sg·T_|L|·|b|·k'.
        let psi_b = psi0_b + tb + tl * k;
        let psi_beta = sg * tl * al_beta;
        // hc = √(ρ_f² − b²) = ρ_f·cos θ of the final circle.
        let sigma = if first { -1.0 } else { 1.0 };
        let origin = -perp * b + hf * (sigma * hc);
        // do/db = hf·b·ψ_b − h⊥ + h⊥·ψ_b·σ·hc − hf·σ·b/hc; do/dβ = (hf·b + h⊥·σ·hc)·ψ_β.
        let swing = hf * b + perp * (sigma * hc);
        let o_b = swing * psi_b - perp - hf * (sigma * b * ihc);
        let o_beta = swing * psi_beta;
        let rel = p - origin;
        let along = rel.dot(hf);
        if along <= 0.0 {
            return None;
        }
        let g = hf.perp_dot(rel);
        let g_b = -along * psi_b - hf.perp_dot(o_b);
        let g_beta = -along * psi_beta - hf.perp_dot(o_beta);
        let along_b = g * psi_b - hf.dot(o_b);
        let along_beta = g * psi_beta - hf.dot(o_beta);
        let glass_b = glass_al * al_b;
        let glass_beta = glass_al * al_beta;
        // climb = β·((air + along)/m_a + glass/m_g); dm/dβ = −β/m.
        let aa = air + along;
        let run = aa * ima + glass * img;
        let climb = beta * run;
        let climb_b = beta * ((air_b + along_b) * ima + glass_b * img);
        let climb_beta = run
            + beta
                * (along_beta * ima
                    + aa * beta * (ima * ima * ima)
                    + glass_beta * img
                    + glass * beta * (img * img * img));
        Some(([g, climb - dv], [[g_b, g_beta], [climb_b, climb_beta]]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn tube(inner: f64) -> HollowCylinder {
        HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, inner, 1.5).unwrap()
    }

    /// `resid_jac`'s residuals are those of the traced path, and its
    /// closed-form Jacobian matches central differences (away from the family
    /// edges, where it is singular), for every family, both signs of b, both
    /// eyes and several β and targets.
    #[test]
    fn closed_form_jacobian_matches_differences() {
        let mut checked = 0;
        for inner in [0.8, 0.5] {
            let c = tube(inner);
            for e in [DVec2::new(0.0, 4.0), DVec2::new(1.3, -2.5)] {
                for fam in [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2] {
                    let hollow = fam == Family::Hollow2;
                    for beta in [0.0, 0.3, -0.6] {
                        for i in 0..=200 {
                            let b = -0.999 + 1.998 * i as f64 / 200.0;
                            let Some(t) = c.path_traced(fam, e, b, beta, hollow) else {
                                continue;
                            };
                            // Stay 1e-3 away from every edge of the family.
                            let (lo, hi) = c.domain(fam, beta, b);
                            if b - lo < 1e-3 || hi - b < 1e-3 {
                                continue;
                            }
                            // A target 1.7 along the final ray, off it by 0.05.
                            let perp = DVec2::new(-t.dir.y, t.dir.x);
                            let p = t.origin + t.dir * 1.7 + perp * 0.05;
                            let dv = 0.4;
                            let (r, j) = c.resid_jac(fam, e, p, dv, b, beta).unwrap();
                            let along = (p - t.origin).dot(t.dir);
                            let g = t.dir.perp_dot(p - t.origin);
                            let climb = beta * ((t.air + along) / t.ma + t.glass / t.mg) - dv;
                            assert!(
                                (r[0] - g).abs() < 1e-12 && (r[1] - climb).abs() < 1e-12,
                                "{fam:?} b={b}"
                            );
                            let h = 1e-6;
                            let f = |bb: f64, tt: f64| c.resid_jac(fam, e, p, dv, bb, tt).unwrap().0;
                            let (bp, bm) = (f(b + h, beta), f(b - h, beta));
                            let (tp, tm) = (f(b, beta + h), f(b, beta - h));
                            for row in 0..2 {
                                let db = (bp[row] - bm[row]) / (2.0 * h);
                                let dt = (tp[row] - tm[row]) / (2.0 * h);
                                let scale = 1.0 + db.abs().max(dt.abs());
                                assert!(
                                    (j[row][0] - db).abs() < 1e-5 * scale && (j[row][1] - dt).abs() < 1e-5 * scale,
                                    "{fam:?} r={inner} e={e} b={b} beta={beta} row {row}: {:?} vs [{db}, {dt}]",
                                    j[row]
                                );
                            }
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 1500, "{checked}");
    }
}
