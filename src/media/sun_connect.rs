//! Connecting a point inside a stratified medium to a direction at infinity
//! (the sun's disk): the launch direction whose curved ray leaves the box's
//! top face travelling along a given exit direction, and the Jacobian that
//! turns a density over exit directions into one over launch directions.
//!
//! With θ the elevation and n·cos θ = b invariant (`stratified`), a ray that
//! climbs from height h₀ (index n₀) to the top face h_t (index n_t) without
//! turning leaves it with cos θ_e = n₀ cos θ₀ / n_t and its azimuth unchanged.
//! So for a target exit direction the launch is in closed form:
//!
//! ```text
//! cos θ₀ = n_t cos θ_e / n₀,   n₀² sin²θ₀ = (n₀ − n_t)(n₀ + n_t) + n_t² sin²θ_e
//! ```
//!
//! (the second without the cancellation of 1 − cos²θ₀ near grazing; n₀ − n_t
//! from the field's cancellation-free `n_diff`). No iteration is needed: a
//! Newton solve on θ₀ would converge to this in one step, so we depart from
//! the Newton iteration one might write for a general field and say so here.
//! A turn before the top (n(h) < b somewhere below it) or an exit through a
//! side face has no such launch: `None` (left to BSDF sampling).
//!
//! Jacobian. dΩ = cos θ dθ dφ with φ kept, and differentiating the invariant,
//! n_t sin θ_e dθ_e = n₀ sin θ₀ dθ₀, so
//!
//! ```text
//! |dΩ_e/dΩ₀| = (cos θ_e/cos θ₀)(n₀ sin θ₀ / (n_t sin θ_e)) = n₀² sin θ₀ / (n_t² sin θ_e)
//! ```
//!
//! using cos θ_e/cos θ₀ = n₀/n_t: the conservation of étendue n² cos(zenith)
//! dA dΩ across horizontal layers. A sample uniform over the disk of exit
//! directions (density p_e) is a launch direction of density p₀ = p_e·|dΩ_e/dΩ₀|.
use glam::DVec3;

use super::field::{Aabb, IndexField};
use super::invariant_cast::up_axis;
use super::stratified::{Options, StratifiedRay};

/// The launch towards an exit direction ([`launch_for_exit`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunLaunch {
    /// Unit launch direction at the point.
    pub dir: DVec3,
    /// |dΩ_exit/dΩ_launch| at it.
    pub jacobian: f64,
    /// Where the curved ray leaves the box's top face.
    pub exit: DVec3,
}

/// How [`launch_for_exit`] solves (the straight launch is known wrong, for
/// tests' power).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LaunchSolve {
    /// From the invariant n·cos θ.
    Invariant,
    /// The exit direction itself, Jacobian 1 (as if the medium were uniform).
    Straight,
}

/// The launch direction at `p` (inside `bounds`) whose ray through the
/// stratified `field` leaves the top face of `bounds` along unit `exit_dir`;
/// `None` when the field is not stratified along a box axis, the exit
/// points below the horizon, or the ray would turn before the top or leave
/// through a side face.
pub fn launch_for_exit(
    field: &IndexField,
    bounds: &Aabb,
    p: DVec3,
    exit_dir: DVec3,
    solve: LaunchSolve,
) -> Option<SunLaunch> {
    let s = field.strata()?;
    let (axis, sign) = up_axis(s.up)?;
    let up = s.up;
    let (lo, hi) = if sign > 0.0 {
        (bounds.min[axis] - s.base, bounds.max[axis] - s.base)
    } else {
        (-bounds.max[axis] - s.base, -bounds.min[axis] - s.base)
    };
    let h0 = p.dot(up) - s.base;
    let mu_e = exit_dir.dot(up);
    if !(mu_e > 0.0 && h0 < hi && bounds.contains(p)) {
        return None;
    }
    let n0 = field.n_h(h0).map(|v| v.0).or_else(|| Some(field.n(p)))?;
    let n_t = field
        .n_h(hi)
        .map(|v| v.0)
        .or_else(|| Some(field.n(p + up * (hi - h0))))?;
    let horiz = exit_dir - up * mu_e;
    let c_e = horiz.length();
    let e = if c_e > 0.0 { horiz / c_e } else { DVec3::ZERO };
    let (dir, jacobian) = match solve {
        LaunchSolve::Straight => (exit_dir, 1.0),
        LaunchSolve::Invariant => {
            let s2 = (field.n_diff(h0, hi) * (n0 + n_t) + n_t * n_t * mu_e * mu_e) / (n0 * n0);
            if s2 <= 0.0 {
                return None;
            }
            let mu0 = s2.sqrt();
            let c0 = n_t * c_e / n0;
            let dir = (e * c0 + up * mu0).normalize();
            (dir, n0 * n0 * mu0 / (n_t * n_t * mu_e))
        }
    };
    // It must climb to the top before any turn, and leave through it.
    let mut ray = StratifiedRay::new(field, lo, hi, p, dir, Options::default()).ok()?;
    let turn = ray.next_turn(field, 0.0);
    let tau = ray.first_height(field, hi - h0, 0.0, turn)?;
    let pt = ray.point(field, tau);
    let exit = ray.position(&pt);
    let slack = 1e-9 * (1.0 + bounds.diagonal());
    let inside = (0..3)
        .filter(|&k| k != axis)
        .all(|k| exit[k] >= bounds.min[k] - slack && exit[k] <= bounds.max[k] + slack);
    inside.then_some(SunLaunch { dir, jacobian, exit })
}

/// The converse of [`launch_for_exit`]: the exit direction of the ray
/// launched from `p` along `launch` (unit), with that launch as
/// [`launch_for_exit`] gives it for this exit, `None` where it gives none or
/// another launch. So a launch has a next-event density exactly when
/// [`launch_for_exit`] can produce it: only upward launches (the other
/// branch, down then turned up, is never produced), none past a turn or
/// through a side. By the invariant, cos θ_e = n₀ cos θ₀ / n_t with the
/// azimuth kept, and n_t² sin²θ_e = (n_t − n₀)(n_t + n₀) + n₀² sin²θ₀.
pub fn exit_for_launch(
    field: &IndexField,
    bounds: &Aabb,
    p: DVec3,
    launch: DVec3,
    solve: LaunchSolve,
) -> Option<(DVec3, SunLaunch)> {
    let s = field.strata()?;
    let d0 = launch.normalize();
    let exit = match solve {
        LaunchSolve::Straight => d0,
        LaunchSolve::Invariant => {
            let up = s.up;
            let (axis, sign) = up_axis(up)?;
            let hi = if sign > 0.0 {
                bounds.max[axis] - s.base
            } else {
                -bounds.min[axis] - s.base
            };
            let h0 = p.dot(up) - s.base;
            let mu0 = d0.dot(up);
            if !(mu0 > 0.0 && h0 < hi) {
                return None;
            }
            let n0 = field.n_h(h0).map(|v| v.0).or_else(|| Some(field.n(p)))?;
            let n_t = field
                .n_h(hi)
                .map(|v| v.0)
                .or_else(|| Some(field.n(p + up * (hi - h0))))?;
            let s2 = (field.n_diff(hi, h0) * (n0 + n_t) + n0 * n0 * mu0 * mu0) / (n_t * n_t);
            if s2 <= 0.0 {
                return None;
            }
            let horiz = d0 - up * mu0;
            (horiz * (n0 / n_t) + up * s2.sqrt()).normalize()
        }
    };
    let l = launch_for_exit(field, bounds, p, exit, solve)?;
    // The other launch for this exit (downward) differs by 2 sin θ₀.
    ((l.dir - d0).length() < 1e-6).then_some((exit, l))
}

#[cfg(test)]
mod tests {
    use super::super::stepper::{State, Stepper};
    use super::super::Method;
    use super::*;

    fn fields() -> Vec<(&'static str, IndexField)> {
        vec![
            (
                "linear",
                IndexField::Linear {
                    n0: 1.1,
                    m: -0.01,
                    up: DVec3::Y,
                    base: 0.0,
                },
            ),
            (
                "exponential",
                IndexField::Exponential {
                    n0: 1.05,
                    scale_height: 4.0,
                    up: DVec3::Y,
                    base: 0.0,
                },
            ),
            (
                "hot ground",
                IndexField::HotGround {
                    n_inf: 1.000_293,
                    dn: 2e-3,
                    h0: 0.5,
                    up: DVec3::Y,
                    base: 0.0,
                },
            ),
        ]
    }

    fn bounds() -> Aabb {
        Aabb::new(DVec3::new(-60.0, 0.0, -60.0), DVec3::new(60.0, 10.0, 60.0))
    }

    /// The exit direction at the top face (y = 10) of the ray launched from
    /// `p` along `d`, by rk45 (tolerance 1e-12 m): Newton on the arc length
    /// until the height is the top's to 1e-12 m (within the bounds' layers
    /// the direction depends on the height alone).
    fn shoot(field: &IndexField, p: DVec3, d: DVec3) -> DVec3 {
        let mut ev = 0;
        let start = State::new(field, p, d, &mut ev).unwrap();
        let mut s = (10.0 - p.y) / d.y.max(0.05) * 0.9;
        let mut st = start;
        for _ in 0..20 {
            let mut stepper = Stepper::new(field, Method::Rk45, 1e-12, 1.0);
            let mut h = f64::INFINITY;
            st = stepper.advance(&start, s, &mut h, &mut Vec::new()).unwrap();
            let dh = 10.0 - st.r.y;
            if dh.abs() < 1e-12 {
                break;
            }
            s += dh / st.t.y;
        }
        assert!((st.r.y - 10.0).abs() < 1e-10, "shooting reached {}", st.r.y);
        st.t.normalize()
    }

    fn elevation_dir(deg: f64, az: f64) -> DVec3 {
        let (a, z) = (deg.to_radians(), az.to_radians());
        DVec3::new(a.cos() * z.cos(), a.sin(), a.cos() * z.sin())
    }

    #[test]
    fn launched_rays_leave_the_top_along_the_target_and_the_straight_launch_does_not() {
        let p = DVec3::new(1.0, 1.0, -2.0);
        let mut worst: f64 = 0.0;
        let mut straight_best = f64::INFINITY;
        let mut solved = 0;
        for (name, f) in fields() {
            for (deg, az) in [
                (10.0, 0.0),
                (30.0, 40.0),
                (60.0, -120.0),
                (85.0, 200.0),
                (89.9, 10.0),
            ] {
                let target = elevation_dir(deg, az);
                let Some(l) = launch_for_exit(&f, &bounds(), p, target, LaunchSolve::Invariant) else {
                    continue;
                };
                solved += 1;
                let got = shoot(&f, p, l.dir);
                let err = got.cross(target).length().asin();
                worst = worst.max(err);
                assert!(err < 1e-9, "{name} {deg}° {az}°: exit off by {err:e} rad");
                assert!((l.exit.y - 10.0).abs() < 1e-9, "{name}: exit {}", l.exit);
                // The straight launch may not even reach the top (a turn).
                if let Some(s) = launch_for_exit(&f, &bounds(), p, target, LaunchSolve::Straight) {
                    let serr = shoot(&f, p, s.dir).cross(target).length().asin();
                    straight_best = straight_best.min(serr);
                }
            }
        }
        eprintln!("worst exit error {worst:e} rad; straight launch's smallest {straight_best:e} rad");
        assert!(solved >= 13, "{solved} launches solved");
        assert!(
            straight_best > 1e-7,
            "no power: a straight launch lands within {straight_best:e}"
        );
    }

    #[test]
    fn the_jacobian_is_the_ratio_of_solid_angles_measured_by_shooting() {
        // Azimuth is kept, so dΩ_e/dΩ₀ = cos θ_e dθ_e / (cos θ₀ dθ₀), with
        // dθ_e measured from rk45 exits of launches θ₀ ± δ.
        let p = DVec3::new(0.0, 2.0, 0.0);
        for (name, f) in fields() {
            for deg in [15.0, 45.0, 75.0] {
                let target = elevation_dir(deg, 0.0);
                let Some(l) = launch_for_exit(&f, &bounds(), p, target, LaunchSolve::Invariant) else {
                    continue;
                };
                let th0 = l.dir.y.asin();
                let d = 1e-5;
                let el = |t: f64| shoot(&f, p, DVec3::new(t.cos(), t.sin(), 0.0)).y.asin();
                let dthe = (el(th0 + d) - el(th0 - d)) / (2.0 * d);
                let j = deg.to_radians().cos() * dthe / th0.cos();
                eprintln!("{name} {deg}°: shot {j}, formula {}", l.jacobian);
                assert!(
                    (j / l.jacobian - 1.0).abs() < 1e-6,
                    "{name} {deg}°: {j} vs {}",
                    l.jacobian
                );
                // Power: the uniform medium's Jacobian 1 is not it.
                assert!((j - 1.0).abs() > 1e-5, "{name} {deg}°: J = {j}");
            }
        }
    }

    #[test]
    fn exit_for_launch_inverts_launch_for_exit_and_refuses_what_it_cannot_produce() {
        let p = DVec3::new(1.0, 0.3, -2.0);
        let mut solved = 0;
        for (name, f) in fields() {
            for (deg, az) in [(2.0, 0.0), (10.0, 70.0), (45.0, -30.0), (80.0, 160.0)] {
                let target = elevation_dir(deg, az);
                let Some(l) = launch_for_exit(&f, &bounds(), p, target, LaunchSolve::Invariant) else {
                    continue;
                };
                solved += 1;
                let (e, back) = exit_for_launch(&f, &bounds(), p, l.dir, LaunchSolve::Invariant)
                    .unwrap_or_else(|| panic!("{name} {deg}°: no exit for its own launch"));
                assert!(
                    (e - target).length() < 1e-12,
                    "{name} {deg}°: exit {e} vs {target}"
                );
                assert!((back.jacobian / l.jacobian - 1.0).abs() < 1e-12);
                // The exit by rk45 too.
                assert!(shoot(&f, p, l.dir).cross(e).length() < 1e-9, "{name} {deg}°");
                // The mirrored, downward launch is never produced.
                let down = l.dir - DVec3::Y * (2.0 * l.dir.y);
                assert!(exit_for_launch(&f, &bounds(), p, down, LaunchSolve::Invariant).is_none());
            }
        }
        assert!(solved >= 10, "{solved} solved");
        // Past a turn: the linear field falls with height (m < 0), so a 1°
        // launch turns down after climbing 1.7 cm (n₀(1 − cos 1°)/|m|).
        let lin = &fields()[0].1;
        assert!(
            exit_for_launch(lin, &bounds(), p, elevation_dir(1.0, 0.0), LaunchSolve::Invariant).is_none()
        );
    }

    #[test]
    fn no_launch_below_the_horizon_past_a_turn_or_through_a_side() {
        let f = &fields()[0].1;
        let p = DVec3::new(0.0, 1.0, 0.0);
        assert!(launch_for_exit(f, &bounds(), p, elevation_dir(-5.0, 0.0), LaunchSolve::Invariant).is_none());
        // Hot ground: index rises with height, a grazing exit needs b > n₀.
        let hot = &fields()[2].1;
        let low = DVec3::new(0.0, 0.05, 0.0);
        assert!(launch_for_exit(
            hot,
            &bounds(),
            low,
            elevation_dir(0.5, 0.0),
            LaunchSolve::Invariant
        )
        .is_none());
        // A 1° exit from near the +x side leaves through that side.
        let side = DVec3::new(59.0, 0.5, 0.0);
        assert!(launch_for_exit(
            f,
            &bounds(),
            side,
            elevation_dir(1.0, 0.0),
            LaunchSolve::Invariant
        )
        .is_none());
    }
}
