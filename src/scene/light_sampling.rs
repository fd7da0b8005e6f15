//! Light sampling on the scene model: next-event estimation's choice of a
//! light (the lights, then the environment's sun disk or map when it is
//! sampled) and a point on it, the density of that choice for a path that
//! found the light by BSDF sampling, and the radiance an escaping ray adds
//! weighed against it. The sample is [`LightSample`].
use super::emitter::{sample_sphere_cone, sphere_cone_pdf, Emitter, EmitterShape};
use super::model::{Environment, Light, LightSample, RenderScene};
use crate::sampling::{power_heuristic, uniform_sphere, Rng};
use glam::Vec3A as V3;

/// `x / nf` (`nf` = `n` as f32, the number of lights): `x` itself for one
/// light (exact: x / 1 = x), without the division's latency per sample.
#[inline(always)]
fn per_light(x: f32, n: usize, nf: f32) -> f32 {
    if n == 1 {
        x
    } else {
        x / nf
    }
}

impl RenderScene {
    /// The light-sampling density (solid angle, including the choice of light)
    /// of reaching light `li` from `from` in direction `wi` to the point `q`
    /// whose geometric normal is `ng`: what [`Self::sample_light`] gives
    /// that connection, for weighing a path that found the light by BSDF
    /// sampling.
    pub fn light_pdf(&self, li: u32, from: V3, q: V3, ng: V3, wi: V3) -> f32 {
        let scene = self;
        let n = scene.nee_count() as f32;
        match &scene.lights[li as usize] {
            Light::Rect { normal, area, .. } => {
                let d2 = (q - from).length_squared();
                let cos_l = -normal.dot(wi);
                if cos_l <= 0.0 {
                    0.0
                } else {
                    d2 / (area * cos_l) / n
                }
            }
            Light::Sphere { center, radius, .. } => sphere_cone_pdf(*center, *radius, from) / n,
            Light::Emitter(e) if !e.weighs_hits() => 0.0,
            Light::Emitter(e) => match &e.shape {
                EmitterShape::Sphere { center, radius, .. } => {
                    let cone = sphere_cone_pdf(*center, *radius, from);
                    if cone > 0.0 || !e.two_sided {
                        cone / n
                    } else {
                        // From inside a two-sided sphere: by area.
                        let area = 4.0 * std::f32::consts::PI * radius * radius;
                        e.area_density(area, (q - from).length_squared(), -ng.dot(wi)) / n
                    }
                }
                EmitterShape::Area(a) => {
                    e.area_density(a.area(), (q - from).length_squared(), -ng.dot(wi)) / n
                }
            },
            Light::Point { .. } | Light::Directional { .. } | Light::Spot(_) => 0.0,
        }
    }

    /// How many choices next-event estimation has: the lights, and the
    /// environment when it is sampled (a sky's sun disk or a map).
    #[inline(always)]
    pub fn nee_count(&self) -> usize {
        self.lights.len() + usize::from(self.environment.is_sampled())
    }

    /// A next-event sample of the environment map, chosen among `n` (= `nf`).
    #[inline(never)]
    fn sample_map(&self, rng: &mut Rng, n: usize, nf: f32) -> Option<LightSample> {
        let (sampler, to_local) = self.environment.map_sampler()?;
        let (u1, u2) = (rng.uniform_f64(), rng.uniform_f64());
        let (wi, pdf) = sampler.sample_world(to_local, u1, u2)?;
        let li = self.environment.eval(wi);
        (li.max_element() > 0.0).then(|| LightSample {
            wi,
            dist: f32::INFINITY,
            li,
            pdf: per_light(pdf, n, nf),
            delta: false,
        })
    }

    /// A next-event sample of the sun's disk, chosen among `n` (= `nf`).
    #[inline(never)]
    fn sample_sun(&self, rng: &mut Rng, n: usize, nf: f32) -> Option<LightSample> {
        let sky = self.environment.sun_nee()?;
        let (wi, pdf) = sky.sample_sun(rng);
        Some(LightSample {
            wi,
            dist: f32::INFINITY,
            li: sky.sun.radiance(),
            pdf: per_light(pdf as f32, n, nf),
            delta: false,
        })
    }

    /// Radiance that a ray escaping along unit `dir` adds: the
    /// environment's, with the sun's disk weighted against its next-event
    /// estimation (`mis`: the density the ray left its diffuse vertex with
    /// and the Jacobian from the disk's directions to that launch's, when
    /// next-event estimation could have made the same path; `None` for a
    /// specular path or one it cannot make, which counts with weight 1).
    #[inline]
    pub fn escaped_radiance(&self, dir: V3, mis: Option<(f32, f32)>) -> V3 {
        let choice = || 1.0 / self.nee_count().max(1) as f32;
        match &self.environment {
            Environment::Sky(sky) => sky.escaped(dir, mis, choice()),
            env => {
                let l = env.eval(dir);
                // A sampled map: next-event estimation's density of `dir` is
                // the map's × the choice × the Jacobian.
                match (env.map_sampler(), mis) {
                    (Some((sampler, to_local)), Some((p, jacobian))) => {
                        l * power_heuristic(p, sampler.pdf_world(to_local, dir) * choice() * jacobian)
                    }
                    _ => l,
                }
            }
        }
    }

    /// A light chosen uniformly (the sun's disk among them) and a point on it, seen from `p` (`None` when the sample cannot reach `p`).
    /// (Forced inline: once per diffuse hit, into the lane loop.)
    #[inline(always)]
    pub fn sample_light(&self, p: V3, rng: &mut Rng) -> Option<LightSample> {
        let scene = self;
        let n = scene.nee_count();
        if n == 0 {
            return None;
        }
        // One light (every shipped scene): the choice is light 0 whatever
        // the draw, which is still made (the path's later numbers stay put).
        let u0 = rng.uniform();
        let idx = if n == 1 {
            0
        } else {
            ((u0 * n as f32) as usize).min(n - 1)
        };
        let nf = n as f32;
        // The environment (a sun's disk or a map) is the last choice
        // (after every light).
        let Some(light) = scene.lights.get(idx) else {
            return match scene.environment {
                Environment::Map { .. } => scene.sample_map(rng, n, nf),
                _ => scene.sample_sun(rng, n, nf),
            };
        };
        let (u1, u2) = (rng.uniform(), rng.uniform());
        match light {
            Light::Point { position, intensity } => {
                let d = *position - p;
                let dist = d.length();
                (dist > 0.0).then(|| LightSample {
                    wi: d / dist,
                    dist,
                    li: *intensity / (dist * dist) * nf,
                    pdf: 1.0,
                    delta: true,
                })
            }
            Light::Directional {
                direction,
                irradiance,
            } => Some(LightSample {
                wi: -*direction,
                dist: f32::INFINITY,
                li: *irradiance * nf,
                pdf: 1.0,
                delta: true,
            }),
            Light::Rect {
                corner,
                edge_u,
                edge_v,
                normal,
                area,
                radiance,
            } => {
                let q = *corner + *edge_u * u1 + *edge_v * u2;
                let d = q - p;
                let dist = d.length();
                let wi = d / dist;
                let cos_l = -normal.dot(wi);
                (cos_l > 0.0 && dist > 0.0).then(|| LightSample {
                    wi,
                    dist,
                    li: *radiance,
                    pdf: per_light(dist * dist / (area * cos_l), n, nf),
                    delta: false,
                })
            }
            Light::Sphere {
                center,
                radius,
                radiance,
            } => {
                let (wi, dist, pdf) = sample_sphere_cone(*center, *radius, p, u1, u2)?;
                Some(LightSample {
                    wi,
                    dist,
                    li: *radiance,
                    pdf: per_light(pdf, n, nf),
                    delta: false,
                })
            }
            Light::Spot(s) => {
                let d = s.position - p;
                let dist = d.length();
                if dist.is_nan() || dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                // Outside the cone the sample is dark: no shadow ray.
                let f = s.falloff(-wi.dot(s.axis));
                (f > 0.0).then(|| LightSample {
                    wi,
                    dist,
                    li: s.intensity * (f / (dist * dist)) * nf,
                    pdf: 1.0,
                    delta: true,
                })
            }
            Light::Emitter(e) => self.sample_emitter(e, p, u1, u2, rng, n, nf),
        }
    }

    /// A next-event sample of the emitting object `e` seen from `p`
    /// (`u1`, `u2`: the point's numbers; a triangle or part is drawn from
    /// `rng`), chosen among `n` (= `nf`).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn sample_emitter(
        &self,
        e: &Emitter,
        p: V3,
        u1: f32,
        u2: f32,
        rng: &mut Rng,
        n: usize,
        nf: f32,
    ) -> Option<LightSample> {
        let uv = e.radiance.needs_uv();
        let (wi, dist, q, quv, pdf) = match &e.shape {
            EmitterShape::Sphere {
                sphere,
                center,
                radius,
            } => {
                let (wi, dist, q, pdf) = match sample_sphere_cone(*center, *radius, p, u1, u2) {
                    Some((wi, dist, pdf)) => (wi, dist, p + wi * dist, pdf),
                    // Inside, a two-sided sphere shows its inner face all
                    // round: a point uniform on it by area.
                    None if e.two_sided => {
                        let n = uniform_sphere(u1, u2);
                        let q = *center + n * *radius;
                        let d = q - p;
                        let dist = d.length();
                        if dist.is_nan() || dist <= 0.0 {
                            return None;
                        }
                        let wi = d / dist;
                        let area = 4.0 * std::f32::consts::PI * radius * radius;
                        (wi, dist, q, e.area_density(area, dist * dist, -n.dot(wi)))
                    }
                    None => return None,
                };
                if pdf.is_nan() || pdf <= 0.0 {
                    return None;
                }
                let quv = if uv {
                    sphere.uv(sphere.project(0, q.as_dvec3()))
                } else {
                    [0.0, 0.0]
                };
                (wi, dist, q, quv, pdf)
            }
            EmitterShape::Area(a) => {
                let s = a.sample(rng.uniform_f64(), u1, u2, uv);
                let d = s.p - p;
                let dist = d.length();
                if dist.is_nan() || dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                let pdf = e.area_density(a.area(), dist * dist, -s.n.dot(wi));
                if pdf.is_nan() || pdf <= 0.0 {
                    return None;
                }
                (wi, dist, s.p, s.uv, pdf)
            }
        };
        let li = e.radiance.eval(q, quv);
        (pdf.is_finite() && li.max_element() > 0.0).then(|| LightSample {
            wi,
            dist,
            li,
            pdf: per_light(pdf, n, nf),
            delta: false,
        })
    }
}
