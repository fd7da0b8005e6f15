//! The tube, its coordinate frame, and how the solvers describe an eye and
//! a target in it.
use glam::{DVec2, DVec3};

/// A thick glass tube, infinitely tall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HollowCylinder {
    /// A point on the axis (metres).
    pub axis_point: DVec3,
    /// Unit axis direction.
    pub axis_direction: DVec3,
    /// Outer radius R (metres).
    pub outer_radius: f64,
    /// Inner radius r < R (metres).
    pub inner_radius: f64,
    /// Index of the glass (the surroundings have index 1).
    pub ior: f64,
    /// Cached unit vector across the axis (the frame's u; w = axis × u).
    across: DVec3,
}

/// The tube's coordinate frame: u and w across the axis, a along it, with
/// its origin on the axis.
pub(crate) struct AxisFrame {
    pub(crate) u: DVec3,
    pub(crate) w: DVec3,
    pub(crate) a: DVec3,
    c: DVec3,
}

impl AxisFrame {
    /// 2-D coordinates across the axis and the height along it.
    pub(crate) fn to2(&self, p: DVec3) -> (DVec2, f64) {
        let q = p - self.c;
        (DVec2::new(q.dot(self.u), q.dot(self.w)), q.dot(self.a))
    }
}

/// The eye as the solvers use it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Eye {
    /// In the world.
    pub(crate) at: DVec3,
    /// Across the axis (the plane of the 2-D reduction).
    pub(crate) e: DVec2,
    /// Height along the axis.
    pub(crate) height: f64,
}

/// A target as the solvers use it, seen from one eye.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Target {
    /// Across the axis.
    pub(crate) p: DVec2,
    /// Height above the eye along the axis.
    pub(crate) dv: f64,
    /// Distance from the eye.
    pub(crate) dist: f64,
    /// In the hollow (reached by hollow2 only) rather than outside the tube.
    pub(crate) in_hollow: bool,
}

impl Target {
    /// The straight elevation β0 (sine of the angle above the plane across
    /// the axis): the first guess of every solver's β.
    #[inline]
    pub(crate) fn beta0(&self) -> f64 {
        self.dv / self.dist
    }
}

/// Roots s of |x + s·h| = c (h unit), ascending.
pub(crate) fn circle(x: DVec2, h: DVec2, c: f64) -> Option<(f64, f64)> {
    let b = x.dot(h);
    let q = x.length_squared() - c * c;
    let disc = b * b - q;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t0 = if b > 0.0 { -(b + s) } else { -b + s };
    // Stable pair: t0 and q/t0.
    let (a0, a1) = if t0 == 0.0 { (-b, -b) } else { (t0, q / t0) };
    Some((a0.min(a1), a0.max(a1)))
}

impl HollowCylinder {
    /// A tube from its axis, radii and index.
    ///
    /// # Errors
    /// A non-finite point or a zero axis direction (it is normalised), radii
    /// out of order (0 < r < R), or an index below 1.
    pub fn try_new(
        axis_point: DVec3,
        axis_direction: DVec3,
        outer: f64,
        inner: f64,
        ior: f64,
    ) -> Result<Self, String> {
        if !axis_point.is_finite() || !axis_direction.is_finite() || axis_direction.length() < 1e-300 {
            return Err("axis: expected a finite point and a non-zero direction".into());
        }
        if !(outer.is_finite() && inner.is_finite() && inner > 0.0 && inner < outer) {
            return Err(format!(
                "radii: expected 0 < inner_radius < outer_radius, got {inner}, {outer}"
            ));
        }
        if !(ior.is_finite() && ior >= 1.0) {
            return Err(format!("ior: expected a finite value >= 1, got {ior}"));
        }
        let a = axis_direction.normalize();
        Ok(HollowCylinder {
            axis_point,
            across: Self::across_for(a),
            axis_direction: a,
            outer_radius: outer,
            inner_radius: inner,
            ior,
        })
    }

    fn across_for(a: DVec3) -> DVec3 {
        let (u, _) = crate::sampling::basis(glam::Vec3A::new(a.x as f32, a.y as f32, a.z as f32));
        // Re-orthonormalise in f64.
        let u = DVec3::new(u.x as f64, u.y as f64, u.z as f64);
        (u - a * a.dot(u)).normalize()
    }

    #[inline]
    pub(crate) fn frame(&self) -> AxisFrame {
        let a = self.axis_direction;
        AxisFrame {
            u: self.across,
            w: a.cross(self.across),
            a,
            c: self.axis_point,
        }
    }

    /// The frame's unit axes (u, w across the axis, a along it).
    pub fn frame_axes(&self) -> (DVec3, DVec3, DVec3) {
        let f = self.frame();
        (f.u, f.w, f.a)
    }

    /// Signed impact parameter `b` and axial direction component `β` of the
    /// ray from `eye` along unit `d`, in the frame `images` uses.
    pub fn impact_of(&self, eye: DVec3, d: DVec3) -> (f64, f64) {
        let f = self.frame();
        let (e, _) = f.to2(eye);
        let h = DVec2::new(d.dot(f.u), d.dot(f.w));
        let hl = h.length();
        if hl == 0.0 {
            return (0.0, d.dot(f.a));
        }
        (e.perp_dot(h / hl), d.dot(f.a))
    }

    /// 2-D coordinates across the axis and the height along it.
    pub(crate) fn to2(&self, p: DVec3) -> (DVec2, f64) {
        self.frame().to2(p)
    }

    /// `eye` in the tube's frame.
    pub(crate) fn eye(&self, at: DVec3) -> Eye {
        let (e, height) = self.to2(at);
        Eye { at, e, height }
    }

    /// `target` seen from `eye`.
    pub(crate) fn target(&self, eye: &Eye, target: DVec3) -> Target {
        let (p, pv) = self.to2(target);
        Target {
            p,
            dv: pv - eye.height,
            dist: (target - eye.at).length(),
            in_hollow: p.length() <= self.inner_radius,
        }
    }
}
