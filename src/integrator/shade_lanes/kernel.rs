//! Phase 2 of [`ShadeLanes`]: the kernel over the staged lanes in f32
//! vectors at pulp's widest level (light weights, bounces, Fresnel
//! choices, microfacet lobes, next rays).
use super::conductor::ConductorLanes;
use super::ggx::Frame;
use super::lane_math::{normalize, reflect, refract, sincos_turns};
use super::plastic::{PlasticLanes, WIDEST};
use super::rough::RoughLanes;
use super::ShadeLanes;
use crate::bsdf::RoughPlastic;
use crate::ray::OFFSET_ULPS;
use crate::simd3::{add, dot, mul, scale, select, splat, sub, Vec3s};
use std::f32::consts::FRAC_1_PI;

/// Next-event estimation's answers so far, per lane: where the connection
/// counts, f·cos per channel and the BSDF's density.
struct Connection<S: pulp::Simd> {
    ok: S::m32s,
    fc: Vec3s<S>,
    pdf: S::f32s,
}

impl<S: pulp::Simd> Connection<S> {
    /// The lanes `of` take a model's f·|cos| per channel and density at the
    /// light's direction; the connection counts where f is positive in a
    /// channel.
    #[inline(always)]
    fn take(&mut self, simd: S, of: S::m32s, (f, pdf): (Vec3s<S>, S::f32s)) {
        let zero = simd.splat_f32s(0.0);
        let lit = simd.or_m32s(
            simd.or_m32s(
                simd.greater_than_f32s(f[0], zero),
                simd.greater_than_f32s(f[1], zero),
            ),
            simd.greater_than_f32s(f[2], zero),
        );
        self.ok = simd.or_m32s(simd.and_m32s(of, lit), simd.and_m32s(simd.not_m32s(of), self.ok));
        self.fc = select(simd, of, f, self.fc);
        self.pdf = simd.select_f32s(of, pdf, self.pdf);
    }
}

/// Phase 2's vector code: the staged lanes of `s`, the first `lanes`.
pub(super) struct Kernel<'a> {
    pub(super) s: &'a mut ShadeLanes,
    pub(super) lanes: usize,
}

impl pulp::WithSimd for Kernel<'_> {
    type Output = usize;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> usize {
        let s = self.s;
        let w = S::F32_LANES;
        let chunks = self.lanes.div_ceil(w);
        let light = s.light;
        let (wrong_mis, wrong_fresnel, wrong_cosine, wrong_scale) = s.wrong();
        let rough_variant = s.rough_variant();
        let metal_variant = s.metal_variant();
        let plastic_variant = s.plastic_variant();
        for j in 0..chunks {
            let r = j * w..(j + 1) * w;
            macro_rules! ld {
                ($a:expr) => {
                    S::as_simd_f32s(&$a[r.clone()]).0[0]
                };
            }
            macro_rules! ld3 {
                ($a:expr) => {
                    [ld!($a[0]), ld!($a[1]), ld!($a[2])]
                };
            }
            macro_rules! st {
                ($a:expr, $v:expr) => {
                    S::as_mut_simd_f32s(&mut $a[r.clone()]).0[0] = $v
                };
            }
            macro_rules! st3 {
                ($a:expr, $v:expr) => {{
                    let v = $v;
                    st!($a[0], v[0]);
                    st!($a[1], v[1]);
                    st!($a[2], v[2]);
                }};
            }
            let zero = simd.splat_f32s(0.0);
            let one = simd.splat_f32s(1.0);
            let kind = ld!(s.diffuse);
            let diffuse = simd.equal_f32s(kind, one);
            let iface = simd.equal_f32s(kind, zero);
            let rough = simd.equal_f32s(kind, simd.splat_f32s(2.0));
            let rough_metal = simd.equal_f32s(kind, simd.splat_f32s(3.0));
            let smooth_metal = simd.equal_f32s(kind, simd.splat_f32s(4.0));
            let metal = simd.or_m32s(rough_metal, smooth_metal);
            let mirror = simd.equal_f32s(kind, simd.splat_f32s(5.0));
            let smooth_plastic = simd.equal_f32s(kind, simd.splat_f32s(6.0));
            let rough_plastic = simd.equal_f32s(kind, simd.splat_f32s(7.0));
            let plastic = simd.or_m32s(smooth_plastic, rough_plastic);
            // Lanes that sample a light.
            let scatter = simd.or_m32s(simd.or_m32s(simd.or_m32s(diffuse, rough), rough_metal), plastic);
            // A chunk of one kind (a pixel's camera rays on one surface)
            // skips the other's arithmetic.
            macro_rules! any {
                ($m:expr) => {
                    simd.first_true_m32s($m) < w
                };
            }
            let d = ld3!(s.dir);
            let p = ld3!(s.p);
            let side = ld3!(s.side);
            let n = ld3!(s.n);
            let beta = ld3!(s.beta);
            // `offset_size(p)`: the spawn offset.
            let big = simd.max_f32s(
                simd.max_f32s(simd.abs_f32s(p[0]), simd.abs_f32s(p[1])),
                simd.abs_f32s(p[2]),
            );
            let off = simd.mul_f32s(
                simd.splat_f32s(OFFSET_ULPS * f32::EPSILON),
                simd.add_f32s(big, simd.splat_f32s(0.5)),
            );
            let above = add(simd, p, scale(simd, side, off));
            let beneath = sub(simd, p, scale(simd, side, off));

            // Lambertian lanes: the light's point and the bounce.
            let mut next_dir = d;
            let mut next_org = above;
            let mut next_beta = beta;
            // The step's answers besides the next ray, merged across kinds.
            let mut below_v = zero;
            let mut prev_pdf_v = zero;
            let mut transmit_v = zero;
            let mut delta_v = zero;
            let mut eta_scale = ld!(s.eta_scale);
            // Rough glass lanes' model (its frame and the index pair).
            let rough_model = any!(rough).then(|| {
                RoughLanes::new(
                    simd,
                    d,
                    n,
                    side,
                    ld!(s.n1),
                    ld!(s.n2),
                    ld!(s.alpha[0]),
                    ld!(s.alpha[1]),
                )
            });
            // Metal lanes' model (their frame, index and roughness).
            let metal_model = any!(metal).then(|| {
                ConductorLanes::new(
                    simd,
                    d,
                    n,
                    side,
                    ld3!(s.eta),
                    ld3!(s.kappa),
                    ld3!(s.spec),
                    ld!(s.alpha[0]),
                    ld!(s.alpha[1]),
                    smooth_metal,
                )
            });
            let albedo = ld3!(s.albedo);
            // Plastic lanes' model (their frame, coating and base); a rough
            // lane's coating for its transmittance table.
            let mut coats: [Option<&RoughPlastic>; WIDEST] = [None; WIDEST];
            if any!(rough_plastic) {
                for (l, c) in coats[..w].iter_mut().enumerate() {
                    let i = j * w + l;
                    if s.diffuse[i] == 7.0 {
                        *c = Some(&s.coatings[s.coat[i] as usize]);
                    }
                }
            }
            let plastic_model = any!(plastic).then(|| {
                PlasticLanes::new(
                    simd,
                    d,
                    n,
                    side,
                    ld!(s.eta[0]),
                    albedo,
                    ld3!(s.spec),
                    ld!(s.lobe_weight),
                    ld!(s.alpha[0]),
                    smooth_plastic,
                    &coats[..w],
                    plastic_variant,
                )
            });
            if any!(scatter) {
                // The light's direction, distance, radiance and density, and
                // where the sample holds anything (point and directional
                // lights: no MIS).
                let (wi, dist, li, pdf, delta, valid) = if let Some(l) = light {
                    let (u1, u2) = (ld!(s.u[0]), ld!(s.u[1]));
                    let q = add(
                        simd,
                        add(
                            simd,
                            splat(simd, l.corner),
                            scale(simd, splat(simd, l.edge_u), u1),
                        ),
                        scale(simd, splat(simd, l.edge_v), u2),
                    );
                    let to = sub(simd, q, p);
                    let dist2 = dot(simd, to, to);
                    let dist = simd.sqrt_f32s(dist2);
                    let wi = scale(simd, to, simd.div_f32s(one, dist));
                    let cos_l = simd.neg_f32s(dot(simd, splat(simd, l.normal), wi));
                    let pdf = simd.div_f32s(
                        simd.mul_f32s(dist, dist),
                        simd.mul_f32s(simd.splat_f32s(l.area), cos_l),
                    );
                    let valid = simd.and_m32s(
                        simd.greater_than_f32s(cos_l, zero),
                        simd.greater_than_f32s(dist, zero),
                    );
                    let delta = simd.less_than_f32s(one, zero);
                    (wi, dist, splat(simd, l.radiance), pdf, delta, valid)
                } else {
                    let delta = simd.not_m32s(simd.equal_f32s(ld!(s.ls_delta), zero));
                    let valid = simd.equal_f32s(one, one);
                    (
                        ld3!(s.ls_wi),
                        ld!(s.ls_dist),
                        ld3!(s.ls_li),
                        ld!(s.ls_pdf),
                        delta,
                        valid,
                    )
                };
                // Per kind: f·cos at the light's direction, the BSDF's
                // density there, and whether the connection counts. A
                // Lambertian lane's: above both normals, cos/π.
                let cos = dot(simd, n, wi);
                let toward = simd.greater_than_f32s(dot(simd, side, wi), zero);
                let f = scale(simd, albedo, simd.splat_f32s(FRAC_1_PI));
                let mut c = Connection::<S> {
                    ok: simd.and_m32s(simd.greater_than_f32s(cos, zero), toward),
                    fc: if wrong_cosine { f } else { scale(simd, f, cos) },
                    pdf: simd.mul_f32s(cos, simd.splat_f32s(FRAC_1_PI)),
                };
                if let Some(m) = &rough_model {
                    // Rough glass: its f·|cos| (grey) and density, where nonzero.
                    let (fr, pr) = m.eval_variant(simd, wi, rough_variant);
                    let fr = if wrong_scale {
                        let eta = simd.div_f32s(ld!(s.n1), ld!(s.n2));
                        let through = simd.not_m32s(toward);
                        simd.select_f32s(through, simd.mul_f32s(fr, simd.mul_f32s(eta, eta)), fr)
                    } else {
                        fr
                    };
                    c.take(simd, rough, ([fr, fr, fr], pr));
                }
                if let Some(m) = &metal_model {
                    // A rough metal: its f·|cos| per channel and density.
                    c.take(simd, rough_metal, m.eval_variant(simd, wi, metal_variant));
                }
                if let Some(m) = &plastic_model {
                    // A plastic's diffuse lobe and rough coating (a smooth
                    // coating's delta lobe has no density to meet).
                    c.take(simd, plastic, m.eval(simd, wi));
                }
                let Connection {
                    ok,
                    fc,
                    pdf: mut bsdf_pdf,
                } = c;
                let seen = simd.and_m32s(valid, ok);
                let seen = simd.and_m32s(
                    seen,
                    simd.and_m32s(scatter, simd.not_m32s(simd.equal_f32s(ld!(s.nee), zero))),
                );
                // The power heuristic against the BSDF's density.
                if wrong_mis {
                    bsdf_pdf = simd.add_f32s(bsdf_pdf, bsdf_pdf);
                }
                let (a, b) = (simd.mul_f32s(pdf, pdf), simd.mul_f32s(bsdf_pdf, bsdf_pdf));
                let sum = simd.add_f32s(a, b);
                let mis = simd.select_f32s(simd.equal_f32s(sum, zero), zero, simd.div_f32s(a, sum));
                let mis = simd.select_f32s(delta, one, mis);
                let k = simd.div_f32s(mis, pdf);
                let contrib = scale(simd, mul(simd, mul(simd, beta, fc), li), k);
                let tfar = simd.sub_f32s(
                    simd.mul_f32s(dist, simd.splat_f32s(1.0 - 1e-4)),
                    simd.mul_f32s(simd.splat_f32s(2.0), off),
                );
                let short = simd.less_than_or_equal_f32s(tfar, zero);
                let kind = simd.select_f32s(short, simd.splat_f32s(2.0), one);
                st!(s.shadow, simd.select_f32s(seen, kind, zero));
                // A rough lane's transmitted connection leaves from the far side.
                let far_side = simd.and_m32s(rough, simd.not_m32s(toward));
                st3!(s.shadow_org, select(simd, far_side, beneath, above));
                st3!(s.shadow_dir, wi);
                st!(s.shadow_tfar, tfar);
                st3!(s.contrib, contrib);
            }
            if any!(diffuse) {
                let (r2, phi) = (ld!(s.u[2]), ld!(s.u[3]));
                let r = simd.sqrt_f32s(r2);
                let (sin, cos) = sincos_turns(simd, phi);
                // `sampling::basis(n)`.
                let Frame { s: t, t: bt, .. } = Frame::new(simd, n);
                let z = simd.sqrt_f32s(simd.max_f32s(simd.sub_f32s(one, r2), zero));
                let bounce = normalize(
                    simd,
                    add(
                        simd,
                        add(
                            simd,
                            scale(simd, t, simd.mul_f32s(r, cos)),
                            scale(simd, bt, simd.mul_f32s(r, sin)),
                        ),
                        scale(simd, n, z),
                    ),
                );
                let below = simd.less_than_or_equal_f32s(dot(simd, side, bounce), zero);
                below_v = simd.select_f32s(simd.and_m32s(diffuse, below), one, below_v);
                prev_pdf_v = simd.select_f32s(
                    diffuse,
                    simd.mul_f32s(dot(simd, n, bounce), simd.splat_f32s(FRAC_1_PI)),
                    prev_pdf_v,
                );
                next_dir = select(simd, diffuse, bounce, next_dir);
                next_beta = select(simd, diffuse, mul(simd, beta, albedo), next_beta);
            }
            if let Some(m) = &rough_model {
                // Rough glass lanes: the lobe and the facet; no sample ends the path.
                let smp = m.sample_variant(simd, ld!(s.u[2]), ld!(s.u[3]), ld!(s.u[4]), rough_variant);
                below_v = simd.select_f32s(simd.and_m32s(rough, simd.not_m32s(smp.valid)), one, below_v);
                prev_pdf_v = simd.select_f32s(rough, smp.pdf, prev_pdf_v);
                let through = simd.and_m32s(rough, smp.transmission);
                transmit_v = simd.select_f32s(through, one, transmit_v);
                // The weight carries (n1/n2)² already; Russian roulette looks
                // through it as for the smooth boundary.
                let eta = simd.div_f32s(ld!(s.n1), ld!(s.n2));
                eta_scale = simd.select_f32s(
                    through,
                    simd.div_f32s(eta_scale, simd.mul_f32s(eta, eta)),
                    eta_scale,
                );
                next_dir = select(simd, rough, smp.wi, next_dir);
                next_org = select(simd, rough, select(simd, through, beneath, above), next_org);
                next_beta = select(simd, rough, scale(simd, beta, smp.weight), next_beta);
            }
            if any!(mirror) {
                // Mirror lanes: about the shading normal, the reflectance
                // (`albedo`) as weight.
                next_dir = select(simd, mirror, normalize(simd, reflect(simd, d, n)), next_dir);
                next_org = select(simd, mirror, above, next_org);
                next_beta = select(simd, mirror, mul(simd, beta, albedo), next_beta);
            }
            if let Some(m) = &metal_model {
                // Metal lanes: the mirror or a facet's reflection; no
                // sample ends the path.
                let smp = m.sample_variant(simd, ld!(s.u[3]), ld!(s.u[4]), metal_variant);
                below_v = simd.select_f32s(simd.and_m32s(metal, simd.not_m32s(smp.valid)), one, below_v);
                prev_pdf_v = simd.select_f32s(metal, smp.pdf, prev_pdf_v);
                next_dir = select(simd, metal, smp.wi, next_dir);
                next_org = select(simd, metal, above, next_org);
                next_beta = select(simd, metal, mul(simd, beta, smp.weight), next_beta);
            }
            if let Some(m) = &plastic_model {
                // Plastic lanes: the coating's reflection or the base's
                // diffuse bounce; no sample ends the path.
                let smp = m.sample(simd, ld!(s.u[2]), ld!(s.u[3]), ld!(s.u[4]));
                below_v = simd.select_f32s(simd.and_m32s(plastic, simd.not_m32s(smp.valid)), one, below_v);
                prev_pdf_v = simd.select_f32s(plastic, smp.pdf, prev_pdf_v);
                delta_v = simd.select_f32s(simd.and_m32s(plastic, smp.delta), one, delta_v);
                next_dir = select(simd, plastic, smp.wi, next_dir);
                next_org = select(simd, plastic, above, next_org);
                next_beta = select(simd, plastic, mul(simd, beta, smp.weight), next_beta);
            }
            if any!(iface) {
                // Interface lanes: Fresnel's choice between the mirror and the
                // refracted direction, each about the shading normal unless that
                // puts it on the wrong side of the surface.
                let (n1, n2) = (ld!(s.n1), ld!(s.n2));
                let eta = simd.div_f32s(n1, n2);
                let cos_i = simd.min_f32s(simd.abs_f32s(dot(simd, d, n)), one);
                let sin2 = simd.mul_f32s(
                    simd.mul_f32s(eta, eta),
                    simd.max_f32s(simd.sub_f32s(one, simd.mul_f32s(cos_i, cos_i)), zero),
                );
                let cos_t = simd.sqrt_f32s(simd.max_f32s(simd.sub_f32s(one, sin2), zero));
                let (a1, a2) = (simd.mul_f32s(n1, cos_i), simd.mul_f32s(n2, cos_t));
                let rs = simd.div_f32s(simd.sub_f32s(a1, a2), simd.add_f32s(a1, a2));
                let (b1, b2) = (simd.mul_f32s(n2, cos_i), simd.mul_f32s(n1, cos_t));
                let rp = simd.div_f32s(simd.sub_f32s(b1, b2), simd.add_f32s(b1, b2));
                let fresnel = simd.min_f32s(
                    simd.max_f32s(
                        simd.mul_f32s(
                            simd.splat_f32s(0.5),
                            simd.add_f32s(simd.mul_f32s(rs, rs), simd.mul_f32s(rp, rp)),
                        ),
                        zero,
                    ),
                    one,
                );
                let fresnel = if wrong_fresnel {
                    simd.mul_f32s(fresnel, simd.splat_f32s(0.5))
                } else {
                    fresnel
                };
                let tir = simd.not_m32s(simd.equal_f32s(ld!(s.tir), zero));
                let mirror = simd.or_m32s(tir, simd.less_than_f32s(ld!(s.u[0]), fresnel));
                let wr = normalize(simd, reflect(simd, d, n));
                let wr_wrong = simd.less_than_or_equal_f32s(dot(simd, wr, side), zero);
                let wr = if any!(wr_wrong) {
                    select(simd, wr_wrong, normalize(simd, reflect(simd, d, side)), wr)
                } else {
                    wr
                };
                let wt = normalize(simd, refract(simd, d, n, eta));
                let wt_wrong = simd.greater_than_or_equal_f32s(dot(simd, wt, side), zero);
                let wt = if any!(wt_wrong) {
                    // (Through the geometric normal too far for refraction: on along `d`.)
                    let wg = refract(simd, d, side, eta);
                    let cg = simd.abs_f32s(dot(simd, d, side));
                    let tir_g = simd.greater_than_f32s(
                        simd.mul_f32s(
                            simd.mul_f32s(eta, eta),
                            simd.max_f32s(simd.sub_f32s(one, simd.mul_f32s(cg, cg)), zero),
                        ),
                        one,
                    );
                    select(simd, wt_wrong, normalize(simd, select(simd, tir_g, d, wg)), wt)
                } else {
                    wt
                };
                let k2 = simd.mul_f32s(eta, eta);
                let transmit = simd.not_m32s(mirror);
                let beta_i = select(simd, transmit, scale(simd, beta, k2), beta);
                // (Only at interface lanes: `transmit` means nothing at the others.)
                let through = simd.and_m32s(iface, transmit);
                eta_scale = simd.select_f32s(through, simd.div_f32s(eta_scale, k2), eta_scale);
                transmit_v = simd.select_f32s(through, one, transmit_v);
                next_dir = select(simd, iface, select(simd, mirror, wr, wt), next_dir);
                next_org = select(simd, iface, select(simd, mirror, above, beneath), next_org);
                next_beta = select(simd, iface, beta_i, next_beta);
            }
            // (Lanes past the staged ones compute nothing anyone reads.)
            st!(s.below, below_v);
            st!(s.prev_pdf, prev_pdf_v);
            st!(s.transmit, transmit_v);
            st!(s.delta, delta_v);
            st!(s.eta_scale, eta_scale);
            st3!(s.dir, next_dir);
            st3!(s.org, next_org);
            st3!(s.beta, next_beta);
        }
        chunks * w
    }
}
