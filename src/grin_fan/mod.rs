//! A fan of rays from a scene's camera through its gradient-index medium,
//! as height against distance: where the rays bend, where they land, and
//! what they see, so that a camera and objects can be placed where a
//! mirage appears (`snell grin-fan SCENE -o fan.svg`).
//!
//! The rays leave the eye in the vertical plane of the view direction
//! ("vertical" is the field's `up` for a stratified field, else +y), at
//! elevations spread evenly over the camera's vertical field of view unless
//! given. Each is traced by rk45 at a metre tolerance of its own (not the
//! render's method: the fan is the reference the render's chords
//! approximate) and meets the scene's geometry through the same nested
//! rule as a render, so it lands where a camera ray does. Beneath the rays
//! lies the scene's profile in the plane: the first surface met by a
//! straight ray dropped from above at each distance.
mod svg;

use crate::camera::Camera;
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList, NestedStrategy};
use crate::error::{Error, Result};
use crate::media::{Aabb, Medium, Method};
use crate::ray::Ray;
use crate::scene::RenderScene;
use glam::DVec3;
use serde::Serialize;

pub use svg::fan_svg;

/// The longest a fan ray may be, in chords: a ray trapped in a duct stops
/// here and says so.
const MAX_CHORDS: usize = 1_000_000;

/// What the fan is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct FanOptions {
    /// Rays in the fan (≥ 2).
    pub rays: u32,
    /// Lowest and highest elevation, degrees above the horizontal (None:
    /// the camera's vertical field of view about its view direction).
    pub elevations: Option<(f64, f64)>,
    /// How far to draw, metres along the ground (None: a tenth beyond the
    /// farthest hit).
    pub max_distance: Option<f64>,
    /// rk45 error tolerance of the rays, metres (None: the medium's
    /// `tolerance`, at most a millimetre).
    pub tolerance: Option<f64>,
    /// Distances at which the scene's profile is sampled (≥ 2).
    pub columns: u32,
    /// A world point the fan's plane passes through (None: the plane of
    /// the view direction), e.g. an object beside the view's centre.
    pub toward: Option<DVec3>,
}

impl Default for FanOptions {
    fn default() -> Self {
        FanOptions {
            rays: 41,
            elevations: None,
            max_distance: None,
            tolerance: None,
            columns: 600,
            toward: None,
        }
    }
}

/// Where a fan ray ended on a surface.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FanHit {
    /// The object's name in the scene.
    pub object: String,
    /// (distance, height) of the hit, metres.
    pub at: [f64; 2],
}

/// One ray of the fan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FanRay {
    /// Its launch elevation, degrees above the horizontal.
    pub elevation_deg: f64,
    /// Its path as (distance, height) points, metres, from the eye; a ray
    /// that meets nothing ends at the fan's far edge.
    pub points: Vec<[f64; 2]>,
    /// The surface it ends on, if any.
    pub hit: Option<FanHit>,
    /// Why it was cut short (the integrator failed or the chord budget ran out).
    pub failure: Option<String>,
}

/// The scene's profile at one distance: the height and object of the
/// highest surface across the camera's view there, if any.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProfileColumn {
    /// Distance along the ground from the eye, metres.
    pub distance: f64,
    /// Height of the surface there, metres (None: nothing below).
    pub height: Option<f64>,
    /// Index of the object in [`Fan::objects`].
    pub object: Option<usize>,
}

/// A traced fan, in the vertical plane through the eye.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Fan {
    /// The eye's height (its distance is 0), metres.
    pub eye_height: f64,
    /// World direction heights are measured along (unit).
    pub up: [f64; 3],
    /// World direction distances are measured along (unit, horizontal).
    pub horizontal: [f64; 3],
    /// The rays, lowest elevation first.
    pub rays: Vec<FanRay>,
    /// The scene's profile, nearest first.
    pub profile: Vec<ProfileColumn>,
    /// Names of the objects met by rays or the profile.
    pub objects: Vec<String>,
    /// Distance range drawn, metres.
    pub distance_range: [f64; 2],
    /// Height range drawn, metres.
    pub height_range: [f64; 2],
    /// The index over the drawn area (None without a medium).
    pub index: Option<IndexSlice>,
    /// rk45 tolerance the rays were traced at, metres (None: no medium,
    /// straight rays).
    pub tolerance: Option<f64>,
}

/// The medium's index sampled over the drawn area, for shading.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IndexSlice {
    /// Cells along the distance axis.
    pub columns: usize,
    /// Cells along the height axis.
    pub rows: usize,
    /// n at cell centres, row-major from the lowest row; None outside the
    /// medium's bounds.
    pub n: Vec<Option<f64>>,
}

/// The plane of the fan: the eye, `up` and the horizontal view direction.
#[derive(Debug, Clone, Copy)]
struct Plane {
    eye: DVec3,
    up: DVec3,
    horizontal: DVec3,
}

impl Plane {
    fn of(camera: &Camera, medium: Option<&Medium>, toward: Option<DVec3>) -> Result<Plane> {
        let up = medium
            .and_then(|m| m.field().strata())
            .map_or(DVec3::Y, |s| s.up)
            .normalize();
        let f = match toward {
            Some(p) => p - camera.position.as_dvec3(),
            None => camera.forward().as_dvec3(),
        };
        let h = f - f.dot(up) * up;
        if h.length() < 1e-9 * (1.0 + f.length()) || h.is_nan() {
            return Err(Error::Invalid(match toward {
                Some(p) => format!(
                    "grin-fan --toward {},{},{}: the point is straight above or below the eye; the fan's plane is undefined",
                    p.x, p.y, p.z
                ),
                None => "grin-fan: the camera looks straight up or down; the fan's plane (the view direction and up) is undefined"
                    .into(),
            }));
        }
        Ok(Plane {
            eye: camera.position.as_dvec3(),
            up,
            horizontal: h.normalize(),
        })
    }

    /// (distance, height) of a world point.
    fn coords(&self, p: DVec3) -> [f64; 2] {
        [(p - self.eye).dot(self.horizontal), p.dot(self.up)]
    }

    /// The world point at (distance, height).
    fn point(&self, d: f64, h: f64) -> DVec3 {
        let base = self.eye - self.eye.dot(self.up) * self.up;
        base + d * self.horizontal + h * self.up
    }

    fn direction(&self, elevation_deg: f64) -> DVec3 {
        let e = elevation_deg.to_radians();
        e.cos() * self.horizontal + e.sin() * self.up
    }
}

/// A fan ray before the far edge is known: its points, its end.
struct Traced {
    points: Vec<DVec3>,
    hit: Option<(u32, DVec3)>,
    /// Where a ray that met nothing leaves, and its direction then.
    escape: Option<(DVec3, DVec3)>,
    failure: Option<String>,
}

/// Trace the fan of `scene`'s camera.
///
/// # Errors
///
/// [`Error::Invalid`] when an option is out of range (fewer than 2 rays or
/// columns, elevations not increasing within (−90°, 90°), a distance or
/// tolerance not finite and > 0) or the camera looks straight up or down;
/// errors of the scene's queries.
pub fn trace_fan(scene: &RenderScene, opts: &FanOptions) -> Result<Fan> {
    check(opts)?;
    // A fan is the rays from one eye over the elevations the image spans;
    // an orthographic camera has no eye and spans no angle.
    if scene.camera.orthographic_view().is_some() {
        return Err(Error::Invalid(
            "grin-fan draws the rays from a perspective camera's eye; this scene's camera is orthographic"
                .into(),
        ));
    }
    let plane = Plane::of(&scene.camera, scene.medium.as_ref(), opts.toward)?;
    let (lo, hi) = match opts.elevations {
        Some(e) => e,
        None => {
            let fwd = opts
                .toward
                .map_or(scene.camera.forward().as_dvec3(), |p| (p - plane.eye).normalize());
            let centre = fwd.dot(plane.up).clamp(-1.0, 1.0).asin().to_degrees();
            let half = 0.5 * f64::from(scene.camera.pixel_angle()) * f64::from(scene.camera.size().1);
            let half = half.to_degrees();
            ((centre - half).max(-89.9), (centre + half).min(89.9))
        }
    };
    let tolerance = match (&scene.medium, opts.tolerance) {
        (None, _) => None,
        (Some(_), Some(t)) => Some(t),
        (Some(m), None) => Some(m.tolerance().min(1e-3)),
    };
    let fine = match (&scene.medium, tolerance) {
        (Some(m), Some(t)) => Some(
            Medium::try_new(m.field().clone(), m.bounds(), Method::Rk45, t, m.step())
                .map_err(|e| Error::Invalid(format!("grin-fan --tolerance: {e}")))?,
        ),
        _ => None,
    };
    let elevations: Vec<f64> = (0..opts.rays)
        .map(|i| lo + (hi - lo) * f64::from(i) / f64::from(opts.rays - 1))
        .collect();
    let traced = elevations
        .iter()
        .map(|&e| trace_one(scene, fine.as_ref(), plane.eye, plane.direction(e)))
        .collect::<Result<Vec<_>>>()?;

    let far = opts.max_distance.unwrap_or_else(|| {
        let farthest = traced
            .iter()
            .filter_map(|t| t.hit.map(|(_, p)| plane.coords(p)[0]))
            .chain(objects_in_view(scene, &plane))
            .fold(0.0f64, f64::max);
        if farthest > 0.0 {
            1.1 * farthest
        } else {
            fine.as_ref().map_or(100.0, |m| far_edge(&plane, &m.bounds()))
        }
    });

    let mut objects: Vec<String> = Vec::new();
    let mut rays = Vec::with_capacity(traced.len());
    for (t, &e) in traced.into_iter().zip(&elevations) {
        let mut points: Vec<[f64; 2]> = t.points.iter().map(|&p| plane.coords(p)).collect();
        if let Some((p, d)) = t.escape {
            points.push(plane.coords(extend_to(&plane, p, d, far)));
        }
        let hit = t.hit.map(|(g, p)| {
            let k = object_slot(scene, &mut objects, g);
            FanHit {
                object: objects[k].clone(),
                at: plane.coords(p),
            }
        });
        rays.push(FanRay {
            elevation_deg: e,
            points,
            hit,
            failure: t.failure,
        });
    }
    let mut profile_top = plane.eye.dot(plane.up);
    for r in &rays {
        for p in &r.points {
            if p[0] <= far {
                profile_top = profile_top.max(p[1]);
            }
        }
    }
    let top = profile_top + 1.0 + 0.1 * profile_top.abs();
    let profile = profile(scene, &plane, far, top, opts.columns, &mut objects)?;
    let (h_lo, h_hi) = height_range(&plane, &rays, &profile, far);
    let index = fine
        .as_ref()
        .map(|m| index_slice(m, &plane, [0.0, far], [h_lo, h_hi]));
    Ok(Fan {
        eye_height: plane.eye.dot(plane.up),
        up: plane.up.to_array(),
        horizontal: plane.horizontal.to_array(),
        rays,
        profile,
        objects,
        distance_range: [0.0, far],
        height_range: [h_lo, h_hi],
        index,
        tolerance,
    })
}

fn check(opts: &FanOptions) -> Result<()> {
    if opts.rays < 2 {
        return Err(Error::Invalid(format!(
            "grin-fan --rays: expected at least 2, got {}",
            opts.rays
        )));
    }
    if opts.columns < 2 {
        return Err(Error::Invalid(format!(
            "grin-fan --columns: expected at least 2, got {}",
            opts.columns
        )));
    }
    if let Some((lo, hi)) = opts.elevations {
        if !(lo.is_finite() && hi.is_finite() && -90.0 < lo && lo < hi && hi < 90.0) {
            return Err(Error::Invalid(format!(
                "grin-fan --from/--to: expected elevations in degrees with -90 < from < to < 90, got {lo} and {hi}"
            )));
        }
    }
    if let Some(p) = opts.toward {
        if !p.is_finite() {
            return Err(Error::Invalid(format!(
                "grin-fan --toward: expected a finite point X,Y,Z, got {p}"
            )));
        }
    }
    for (flag, v) in [
        ("--max-distance", opts.max_distance),
        ("--tolerance", opts.tolerance),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::Invalid(format!(
                    "grin-fan {flag}: expected a finite number of metres > 0, got {v}"
                )));
            }
        }
    }
    Ok(())
}

/// One fan ray: rk45 chords through the medium (straight outside it), each
/// asked of the scene through the nested rule, until a surface is met.
fn trace_one(scene: &RenderScene, fine: Option<&Medium>, eye: DVec3, dir: DVec3) -> Result<Traced> {
    let mut list = InteriorList::from_solids(&scene.solids, &scene.camera_interior);
    let mut counters = Counters::default();
    let mut out = Traced {
        points: vec![eye],
        hit: None,
        escape: None,
        failure: None,
    };
    let Some(med) = fine else {
        let r = Ray::new(eye.as_vec3a(), dir.as_vec3a());
        match dielectric::trace(scene, NestedStrategy::Filter, &r, &mut list, &mut counters)? {
            Some(th) => {
                let p = eye + dir * f64::from(th.hit.t);
                out.points.push(p);
                out.hit = Some((th.hit.geom_id, p));
            }
            None => out.escape = Some((eye, dir)),
        }
        return Ok(out);
    };
    let mut curved = med.start_ray(eye, dir);
    for _ in 0..MAX_CHORDS {
        let chord = curved.next_chord(med);
        if let Some(why) = curved.failure() {
            out.failure = Some(why.to_string());
            return Ok(out);
        }
        if chord.length == 0.0 {
            continue;
        }
        if chord.length < 0.0 || chord.length.is_nan() {
            out.failure = Some(format!("a chord of length {}", chord.length));
            return Ok(out);
        }
        let mut r = Ray::new(chord.origin.as_vec3a(), chord.dir.as_vec3a());
        if chord.length.is_finite() {
            r.tfar = chord.length as f32;
        }
        if let Some(th) = dielectric::trace(scene, NestedStrategy::Filter, &r, &mut list, &mut counters)? {
            let p = chord.origin + chord.dir * f64::from(th.hit.t);
            out.points.push(p);
            out.hit = Some((th.hit.geom_id, p));
            return Ok(out);
        }
        if !chord.length.is_finite() {
            out.escape = Some((chord.origin, chord.dir));
            return Ok(out);
        }
        out.points.push(chord.origin + chord.dir * chord.length);
    }
    out.failure = Some(format!("still in the medium after {MAX_CHORDS} chords (a duct?)"));
    Ok(out)
}

/// The distance ranges (nearest and farthest box corner) of the objects
/// whose box centre the camera sees: what a user placed in view, whether
/// or not a fan ray meets it.
fn object_extents_in_view<'a>(
    scene: &'a RenderScene,
    plane: &'a Plane,
) -> impl Iterator<Item = (f64, f64)> + 'a {
    let (w, h) = scene.camera.size();
    scene.geoms.iter().filter_map(move |g| {
        let (lo, hi) = match &g.shape {
            crate::scene::Shape::Mesh(m) => m.aabb(),
            crate::scene::Shape::Analytic(a) => a.aabb(),
        };
        let c = 0.5 * (lo + hi);
        let (x, y) = scene.camera.project(c.as_vec3a())?;
        if !(c.is_finite() && (0.0..w as f32).contains(&x) && (0.0..h as f32).contains(&y)) {
            return None;
        }
        let d = Aabb::new(lo, hi).corners().map(|p| plane.coords(p)[0]);
        Some(d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        }))
    })
}

/// The distances of the objects' box centres in view.
fn objects_in_view<'a>(scene: &'a RenderScene, plane: &'a Plane) -> impl Iterator<Item = f64> + 'a {
    object_extents_in_view(scene, plane).map(|(lo, hi)| 0.5 * (lo + hi))
}

/// The distance of the medium's farthest corner along the view.
fn far_edge(plane: &Plane, bounds: &Aabb) -> f64 {
    let d = bounds
        .corners()
        .iter()
        .map(|&c| plane.coords(c)[0])
        .fold(0.0f64, f64::max);
    if d > 0.0 {
        d
    } else {
        100.0
    }
}

/// A straight ray from `p` along `d`, continued to distance `far` (or by
/// `far` metres when it does not move away from the eye).
fn extend_to(plane: &Plane, p: DVec3, d: DVec3, far: f64) -> DVec3 {
    let along = d.dot(plane.horizontal);
    let now = plane.coords(p)[0];
    let t = if along > 1e-12 && now < far {
        (far - now) / along
    } else {
        far
    };
    p + d * t
}

/// Lateral offsets sampled across the view's width for the profile.
const PROFILE_LANES: u32 = 15;

/// At `columns` distances in [0, `far`], the highest surface below `top`
/// across the camera's width there (straight rays dropped from above at
/// [`PROFILE_LANES`] lateral offsets): the silhouette of what the camera
/// sees, objects beside the fan's plane included.
fn profile(
    scene: &RenderScene,
    plane: &Plane,
    far: f64,
    top: f64,
    columns: u32,
    objects: &mut Vec<String>,
) -> Result<Vec<ProfileColumn>> {
    let mut counters = Counters::default();
    let down = -plane.up;
    let side = plane.up.cross(plane.horizontal).normalize();
    // Half the view's width per metre of distance: tan(half the fov) × aspect.
    let half_width = 0.5 * f64::from(scene.camera.pixel_angle()) * f64::from(scene.camera.size().0);
    // Evenly spaced columns, and a few across every object in view, which
    // a coarse spacing could step over (a ship at 5 km).
    let mut distances: Vec<f64> = (0..columns)
        .map(|i| far * f64::from(i) / f64::from(columns - 1))
        .collect();
    for (lo, hi) in object_extents_in_view(scene, plane) {
        let (lo, hi) = (lo.max(0.0), hi.min(far));
        distances.extend(
            (0..=8)
                .map(|k| lo + (hi - lo) * f64::from(k) / 8.0)
                .filter(|d| *d <= far),
        );
    }
    distances.sort_by(f64::total_cmp);
    distances.dedup();
    distances
        .into_iter()
        .map(|distance| {
            let mut best: Option<(f64, u32)> = None;
            for k in 0..PROFILE_LANES {
                let lateral =
                    distance * half_width * (2.0 * f64::from(k) / f64::from(PROFILE_LANES - 1) - 1.0);
                let org = plane.point(distance, top) + lateral * side;
                // Dropped from above everything drawn: outside every solid.
                let mut list = InteriorList::from_solids(&scene.solids, &[]);
                let r = Ray::new(org.as_vec3a(), down.as_vec3a());
                if let Some(th) =
                    dielectric::trace(scene, NestedStrategy::Filter, &r, &mut list, &mut counters)?
                {
                    let height = top - f64::from(th.hit.t);
                    if best.is_none_or(|(b, _)| height > b) {
                        best = Some((height, th.hit.geom_id));
                    }
                }
            }
            Ok(ProfileColumn {
                distance,
                height: best.map(|b| b.0),
                object: best.map(|b| object_slot(scene, objects, b.1)),
            })
        })
        .collect()
}

/// The index of geometry `geom`'s name in `objects` (added if new).
fn object_slot(scene: &RenderScene, objects: &mut Vec<String>, geom: u32) -> usize {
    let name = scene
        .geoms
        .get(geom as usize)
        .map_or_else(|| format!("geometry {geom}"), |g| g.name.clone());
    objects.iter().position(|o| *o == name).unwrap_or_else(|| {
        objects.push(name);
        objects.len() - 1
    })
}

/// Heights to draw: the eye, the hits and the profile within `far`, with a
/// margin; rays that climb beyond are clipped.
fn height_range(plane: &Plane, rays: &[FanRay], profile: &[ProfileColumn], far: f64) -> (f64, f64) {
    let eye = plane.eye.dot(plane.up);
    let (mut lo, mut hi) = (eye, eye);
    for h in rays
        .iter()
        .filter_map(|r| r.hit.as_ref())
        .filter(|h| h.at[0] <= far)
    {
        lo = lo.min(h.at[1]);
        hi = hi.max(h.at[1]);
    }
    for h in profile.iter().filter_map(|c| c.height) {
        lo = lo.min(h);
        hi = hi.max(h);
    }
    let pad = 0.08 * (hi - lo).max(1e-3 * (1.0 + eye.abs()));
    (lo - pad, hi + pad)
}

/// n sampled over the drawn area: at most 240 × 120 cells, fewer rows
/// when the field depends on height alone (every column is then alike).
fn index_slice(m: &Medium, plane: &Plane, d: [f64; 2], h: [f64; 2]) -> IndexSlice {
    let (columns, rows) = (240usize, 120usize);
    let bounds = m.bounds();
    let n = (0..rows)
        .flat_map(|j| (0..columns).map(move |i| (i, j)))
        .map(|(i, j)| {
            let dd = d[0] + (d[1] - d[0]) * (i as f64 + 0.5) / columns as f64;
            let hh = h[0] + (h[1] - h[0]) * (j as f64 + 0.5) / rows as f64;
            let p = plane.point(dd, hh);
            bounds.contains(p).then(|| m.ior_at(p))
        })
        .collect();
    IndexSlice { columns, rows, n }
}
