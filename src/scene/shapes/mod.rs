//! Analytic shapes (Embree user geometry) and triangle meshes, with what the
//! integrator needs at a hit (shading normal, texture coordinates) and what
//! the nested rule needs of a solid (point in solid, distance tests).
//!
//! Normal conventions: a sphere's and a cylinder's normal point away from the
//! centre/axis (cylinder `normal = "in"` flips it); a disk's and a rect's normal
//! is the given one (an analytic rect's is its mesh twin's); for meshes the geometric normal is (v1−v0)×(v2−v0), i.e.
//! the side from which the winding is counter-clockwise.
//!
//! One file per shape ([`Sphere`], [`Cylinder`], [`Tube`], [`Disk`], [`Rect`]), each with
//! its intersection, normal, projection, point-in-solid and proximity tests;
//! the cylinder's and tube's walls share `wall`; [`Analytic`] dispatches to
//! them, and `callbacks` hands them to Embree.
//! `meshgen` makes the triangle meshes of the scene format's generated
//! shapes and loads OBJ files.
mod axis;
mod bounds;
mod callbacks;
mod contains_grid;
mod cylinder;
mod disk;
mod mesh;
pub mod meshgen;
mod normalize;
mod rect;
mod segment;
mod set;
mod sphere;
mod tube;
mod wall;

pub use contains_grid::ContainsGrid;
pub use cylinder::Cylinder;
pub use disk::Disk;
pub use mesh::Mesh;
pub(crate) use normalize::normalize_or;
pub use rect::Rect;
pub use set::{AnalyticSet, SetScratch, SurfaceLanes, MAX_SET_PRIMITIVES};
#[cfg(test)]
pub(super) use set::{Quadric, ERROR_SAFETY};
pub use sphere::Sphere;
pub use tube::Tube;

use crate::embree::UserShape;
use glam::DVec3;

/// A box as (low corner, high corner).
type Box3 = (DVec3, DVec3);

/// An analytic primitive set. Closed sets of primitives share one geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Analytic {
    /// A sphere.
    Sphere(Sphere),
    /// A cylinder's wall, open or closed by two caps.
    Cylinder(Cylinder),
    /// A closed thick tube.
    Tube(Tube),
    /// A disk or annulus.
    Disk(Disk),
    /// A rectangle or parallelogram (a rect mesh's twin).
    Rect(Rect),
}

impl Analytic {
    /// Primitives (Embree's prim ids `0..prims()`).
    pub(crate) fn prims(&self) -> u32 {
        match self {
            Analytic::Sphere(_) | Analytic::Disk(_) | Analytic::Rect(_) => 1,
            Analytic::Cylinder(c) => c.prims(),
            Analytic::Tube(_) => 4,
        }
    }

    /// Might a surface of this solid pass within `tol` of `p`? A distance
    /// test for spheres, closed cylinders and tubes (never false when the
    /// distance is at most `tol`); `None` for other shapes.
    pub fn surface_near(&self, p: DVec3, tol: f64) -> Option<bool> {
        match self {
            Analytic::Sphere(s) => Some(s.surface_near(p, tol)),
            Analytic::Cylinder(c) => c.surface_near(p, tol),
            Analytic::Tube(t) => Some(t.surface_near(p, tol)),
            Analytic::Disk(_) | Analytic::Rect(_) => None,
        }
    }

    /// Is `p` strictly inside the solid this shape bounds (spheres, closed
    /// cylinders, tubes)? `None` for shapes that bound no volume.
    pub fn contains(&self, p: DVec3) -> Option<bool> {
        match self {
            Analytic::Sphere(s) => Some(s.contains(p)),
            Analytic::Cylinder(c) => c.contains(p),
            Analytic::Tube(t) => Some(t.contains(p)),
            Analytic::Disk(_) | Analytic::Rect(_) => None,
        }
    }

    /// Axis-aligned bounds of the whole shape (f64).
    pub fn aabb(&self) -> Box3 {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in 0..self.prims() {
            let b = self.bounds(p);
            lo = lo.min(DVec3::new(
                b.lower[0] as f64,
                b.lower[1] as f64,
                b.lower[2] as f64,
            ));
            hi = hi.max(DVec3::new(
                b.upper[0] as f64,
                b.upper[1] as f64,
                b.upper[2] as f64,
            ));
        }
        (lo, hi)
    }

    /// Unit outward (per convention) normal at a point `p` on primitive `prim`.
    #[inline]
    pub fn normal(&self, prim: u32, p: DVec3) -> DVec3 {
        match self {
            Analytic::Sphere(s) => s.normal(p),
            Analytic::Cylinder(c) => c.normal(prim, p),
            Analytic::Tube(t) => t.normal(prim, p),
            Analytic::Disk(k) => k.normal,
            Analytic::Rect(r) => r.normal,
        }
    }

    /// Snap a point near primitive `prim` onto it exactly (f64).
    #[inline]
    pub fn project(&self, prim: u32, p: DVec3) -> DVec3 {
        match self {
            Analytic::Sphere(s) => s.project(p),
            Analytic::Cylinder(c) => c.project(prim, p),
            Analytic::Tube(t) => t.project(prim, p),
            Analytic::Disk(k) => k.project(p),
            Analytic::Rect(r) => r.project(p),
        }
    }

    /// Texture coordinates in [0, 1]² at `p` (sphere: longitude/latitude
    /// around y; rect: along its edges, as its mesh twin has them; zero on
    /// the other shapes).
    pub fn uv(&self, p: DVec3) -> [f32; 2] {
        match self {
            Analytic::Sphere(s) => s.uv(p),
            Analytic::Rect(r) => r.uv(p),
            _ => [0.0, 0.0],
        }
    }

    /// May the surface come within `tol` of some point of the box `bx`?
    /// `true` when unsure (an exact test for spheres).
    pub(crate) fn surface_may_come_within_box(&self, bx: Box3, tol: f64) -> bool {
        match self {
            Analytic::Sphere(s) => s.surface_may_come_within_box(bx, tol),
            _ => true,
        }
    }

    /// May the surfaces of `self` and `other` come within `tol` of each
    /// other? `None` where no exact test is known (any pair but two spheres).
    pub(crate) fn surfaces_may_come_within(&self, other: &Analytic, tol: f64) -> Option<bool> {
        match (self, other) {
            (Analytic::Sphere(a), Analytic::Sphere(b)) => Some(a.surface_may_come_within_sphere(b, tol)),
            _ => None,
        }
    }

    /// The box `b` cut down to a box still holding every point of `b` within
    /// `tol` of the surface (a sphere's ball widened by `tol`; `b` itself for
    /// the other shapes); `None` when no such point can exist.
    pub(crate) fn clip_to_near_surface(&self, tol: f64, b: Box3) -> Option<Box3> {
        match self {
            Analytic::Sphere(s) => s.clip_to_ball(tol, b),
            _ => Some(b),
        }
    }

    /// The box `b` cut down to a box still holding every point of `b` on
    /// this surface within `tol` of the surface of `other` (the band of a
    /// sphere around the circle where it meets another; `b` itself for the
    /// other pairs); `None` when no such point can exist.
    pub(crate) fn clip_to_band(&self, other: &Analytic, tol: f64, b: Box3) -> Option<Box3> {
        match (self, other) {
            (Analytic::Sphere(g), Analytic::Sphere(s)) => g.clip_to_band(s, tol, b),
            _ => Some(b),
        }
    }
}
