//! A bounded gradient-index region with its integration settings: its
//! validation and configuration.
use super::field::{Aabb, FeatureScale, IndexField};
use super::footprint::{ChordTolerance, Footprint};
use super::invariant_cast::InvariantSetup;
use super::method::{check_method, Method};
use super::obstacles::Obstacles;
use super::stepper::Stepper;
use super::MediumError;
use glam::DVec3;

/// The fraction of a pixel's footprint an invariant chord may deviate from its
/// arc when the scene does not say (`medium.pixel_tolerance`). mirage_road at
/// 480×160×4: 0.25 px leaves block means within the seed-to-seed noise of an
/// rk45 render at a tenth of its metre tolerance (docs/grin.md).
pub const DEFAULT_PIXEL_TOLERANCE: f64 = 0.1;

/// The fraction of a pixel each step of a flight may err by (in position at
/// its distance from the eye, and in direction) when the scene does not say
/// (`medium.pixel_tolerance`). Steps are mostly capped by the field's
/// `flight_step`, which is what holds the error (docs/grin.md, "Flights").
pub const DEFAULT_FLIGHT_PIXEL_TOLERANCE: f64 = 1.0;

/// What the image tolerances of flights and invariant chords are multiplied
/// by for a ray after a diffuse or glossy bounce when the scene does not say
/// (`medium.indirect_tolerance_scale`). Such a ray's error moves what it
/// brings back within the bounce's lobe, which the image sees averaged, not
/// a point seen through one pixel. Measured against a fine render in
/// docs/grin.md ("Rays after a diffuse bounce").
pub const DEFAULT_INDIRECT_TOLERANCE_SCALE: f64 = 16.0;

/// Below this a chord tolerance means nothing to Embree's f32 chords (a
/// micrometre; the footprint goes to 0 at the eye).
pub(super) const MIN_CHORD_TOLERANCE: f64 = 1e-6;
/// A bounded gradient-index region with its integration settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Medium {
    pub(super) field: IndexField,
    /// The field's chord limit, computed once.
    pub(super) feature: FeatureScale,
    pub(super) bounds: Aabb,
    /// The bounds shrunk by twice the tolerance: a ray from a point in it
    /// starts inside and runs longer than the tolerance in the bounds, as
    /// their slab test would find (without its divisions).
    pub(super) deep_inside: Aabb,
    pub(super) method: Method,
    pub(super) tolerance: f64,
    pub(super) step: f64,
    /// Chord tolerance as a fraction of the pixel footprint (None: `tolerance`
    /// metres everywhere).
    pub(super) pixel_tolerance: Option<f64>,
    /// The tolerances' multiple for rays after a diffuse bounce.
    pub(super) indirect_scale: f64,
    /// The eye and the pixel angle of the scene's camera.
    pub(super) view: Option<(DVec3, f64)>,
    /// The scene's geometry as boxes.
    pub(super) obstacles: Obstacles,
    /// Those of them a ray just out through a face of the bounds may meet:
    /// the ones not well inside the bounds.
    pub(super) obstacles_outside: Obstacles,
    /// What method `invariant`'s rays share (None for other methods).
    pub(super) invariant: Option<InvariantSetup>,
    /// A lower bound on n in the bounds (curvature bounds divide by it).
    pub(super) n_floor: f64,
    /// Scales the gradient bound of a flight's straight stretches (1; tests
    /// shrink it to show what a bound too small does).
    pub(super) straight_scale: f64,
    /// The longest step of a flight, metres.
    pub(super) flight_step: f64,
}

/// The largest index a medium may reach (real media are below ~4).
pub const MAX_INDEX: f64 = 10.0;

impl Medium {
    /// Validates: tolerance > 0, step > 0 (both finite), bounds finite and non-empty,
    /// n > 0 everywhere in the bounds (exact minimum for stratified fields, a guaranteed
    /// lower bound for a plume), the method fits the field.
    ///
    /// `bounds` are world metres, `tolerance` is the chord–arc deviation and rk45's
    /// error target in metres, `step` the fixed step of rk4 and the paper's methods in
    /// metres. The stored field has `up` normalised.
    ///
    /// # Errors
    ///
    /// [`MediumError::Invalid`] with a `medium.*` key (`medium.tolerance`,
    /// `medium.step`, `medium.bounds`, `medium.field…`, `medium.method`) when one of
    /// the checks above fails, when n exceeds [`MAX_INDEX`] in the bounds, or when
    /// the field's feature length or a paper method's step would need more than 1e6
    /// chords across the box.
    pub fn try_new(
        field: IndexField,
        bounds: Aabb,
        method: Method,
        tolerance: f64,
        step: f64,
    ) -> Result<Medium, MediumError> {
        if !(tolerance.is_finite() && tolerance > 0.0) {
            return Err(MediumError::invalid(
                "medium.tolerance",
                format!("expected a finite tolerance > 0 (metres), got {tolerance}"),
            ));
        }
        if !(step.is_finite() && step > 0.0) {
            return Err(MediumError::invalid(
                "medium.step",
                format!("expected a finite step > 0 (metres), got {step}"),
            ));
        }
        if !(bounds.min.is_finite() && bounds.max.is_finite()) {
            return Err(MediumError::invalid(
                "medium.bounds",
                format!(
                    "expected finite bounds (gradient-index fields must be bounded), got min {:?} max {:?}",
                    bounds.min, bounds.max
                ),
            ));
        }
        if !bounds.min.cmplt(bounds.max).all() {
            return Err(MediumError::invalid(
                "medium.bounds",
                format!(
                    "expected min < max on every axis (a non-empty box), got min {:?} max {:?}",
                    bounds.min, bounds.max
                ),
            ));
        }
        let field = field.validated("medium.field")?;
        check_method(&field, method, "medium.method")?;
        // Indices of real media are below ~4; an index of 1e300 is a typo, and
        // it makes the integrators crawl (found by the proptest strategies).
        let n_max = field.max_n_in(&bounds);
        if !(n_max.is_finite() && n_max <= MAX_INDEX) {
            return Err(MediumError::invalid(
                "medium.field",
                format!("expected n <= {MAX_INDEX} everywhere in the bounds, but it reaches {n_max:e}"),
            ));
        }
        // Absurd sizes are refused before any ray runs: a feature length (the
        // longest chord the field allows) that would need more than 1e6 chords
        // across the box.
        let diag = (bounds.max - bounds.min).length();
        let feature = field.feature_length();
        if feature.is_finite() && diag / feature > 1e6 {
            return Err(MediumError::invalid(
                "medium.field",
                format!(
                    "its feature length {feature:.3e} m (plume: min(radius, height)/2 and wavelength/8; inversion: thickness) \
                     would need ~{:.1e} chords across the {diag:.3e} m box (limit 1e6)",
                    diag / feature
                ),
            ));
        }
        if method.is_paper() && diag / step > 1e6 {
            return Err(MediumError::invalid(
                "medium.step",
                format!(
                    "a step of {step:.3e} m would need ~{:.1e} steps across the {diag:.3e} m box (limit 1e6)",
                    diag / step
                ),
            ));
        }
        let (n_min, at) = field.min_n_in(&bounds);
        if !(n_min.is_finite() && n_min > 0.0) {
            let what = if field.strata().is_some() {
                format!("n = {n_min} at ({:.6}, {:.6}, {:.6})", at.x, at.y, at.z)
            } else {
                format!("its lower bound n_amb − |dn|(1 + |amplitude|) = {n_min}")
            };
            return Err(MediumError::invalid(
                "medium.field",
                format!("expected n > 0 everywhere in the bounds, but {what}"),
            ));
        }
        let flight_step = field.flight_step();
        let invariant = if method == Method::Invariant {
            InvariantSetup::new(&field, &bounds, None)
        } else {
            None
        };
        Ok(Medium {
            feature: field.feature_scale(),
            field,
            bounds,
            deep_inside: Aabb::new(bounds.min + 2.0 * tolerance, bounds.max - 2.0 * tolerance),
            method,
            tolerance,
            step,
            pixel_tolerance: None,
            indirect_scale: DEFAULT_INDIRECT_TOLERANCE_SCALE,
            view: None,
            invariant,
            obstacles: Obstacles::unknown(),
            obstacles_outside: Obstacles::unknown(),
            n_floor: n_min,
            straight_scale: 1.0,
            flight_step,
        })
    }

    /// Bounds method `invariant`'s chords in the image: `fraction` of the
    /// pixel footprint at the distance from the eye ([`Medium::with_view`]).
    /// None: [`DEFAULT_PIXEL_TOLERANCE`]. Without a view (no camera:
    /// grin-trace, tests) `tolerance` metres apply; the other methods always
    /// use `tolerance` metres.
    ///
    /// # Errors
    ///
    /// [`MediumError::Invalid`] at `medium.pixel_tolerance` unless the
    /// fraction is finite and in (0, 100].
    pub fn with_pixel_tolerance(mut self, fraction: Option<f64>) -> Result<Medium, MediumError> {
        if let Some(f) = fraction {
            if !(f.is_finite() && f > 0.0 && f <= 100.0) {
                return Err(MediumError::invalid(
                    "medium.pixel_tolerance",
                    format!("expected a fraction of a pixel in (0, 100], got {f}"),
                ));
            }
        }
        self.pixel_tolerance = fraction;
        Ok(self)
    }

    /// Holds rays after a diffuse or glossy bounce to `scale` times the
    /// image tolerances of camera rays (flights and invariant chords;
    /// [`CurvedRay::after_diffuse`](super::CurvedRay::after_diffuse)). None:
    /// [`DEFAULT_INDIRECT_TOLERANCE_SCALE`]; 1 holds them as camera rays.
    ///
    /// # Errors
    ///
    /// [`MediumError::Invalid`] at `medium.indirect_tolerance_scale` unless
    /// the scale is finite and in [1, 1000].
    pub fn with_indirect_tolerance_scale(mut self, scale: Option<f64>) -> Result<Medium, MediumError> {
        let s = scale.unwrap_or(DEFAULT_INDIRECT_TOLERANCE_SCALE);
        if !(s.is_finite() && (1.0..=1000.0).contains(&s)) {
            return Err(MediumError::invalid(
                "medium.indirect_tolerance_scale",
                format!("expected a multiple in [1, 1000], got {s}"),
            ));
        }
        self.indirect_scale = s;
        Ok(self)
    }

    /// The multiple of the image tolerances for rays after a diffuse bounce.
    pub fn indirect_tolerance_scale(&self) -> f64 {
        self.indirect_scale
    }

    /// The camera's eye and the angle one of its pixels subtends (radians):
    /// what `pixel_tolerance` is a fraction of.
    pub fn with_view(mut self, eye: DVec3, pixel_angle: f64) -> Medium {
        self.view =
            (eye.is_finite() && pixel_angle.is_finite() && pixel_angle > 0.0).then_some((eye, pixel_angle));
        self
    }

    /// The scene's geometry as boxes (world min, max): stretches of a curved
    /// ray that meet none need no chords, chords that meet none no query.
    pub fn with_obstacles(self, boxes: impl IntoIterator<Item = Aabb>) -> Medium {
        self.with_obstacle_set(Obstacles::new(boxes))
    }

    pub(super) fn with_obstacle_set(mut self, obstacles: Obstacles) -> Medium {
        // A ray leaves through a face when it is within `tolerance` of it
        // (`Aabb::leaves_within`): boxes that far inside cannot be met.
        self.obstacles_outside = obstacles.not_inside(&self.bounds, 2.0 * self.tolerance);
        self.obstacles = obstacles;
        if self.method == Method::Invariant {
            let known = (!self.obstacles.is_unknown()).then(|| self.obstacles.boxes());
            self.invariant = InvariantSetup::new(&self.field, &self.bounds, known);
        }
        self
    }

    /// Flights with steps of at most `step` metres (tests compare caps).
    #[cfg(test)]
    pub(crate) fn with_flight_step(mut self, step: f64) -> Medium {
        self.flight_step = step;
        self
    }

    /// The same medium with the gradient bound of flights' straight
    /// stretches multiplied by `scale` (< 1: too small, drops the field
    /// where it matters; for tests).
    #[cfg(test)]
    pub(crate) fn with_straight_scale(mut self, scale: f64) -> Medium {
        self.straight_scale = scale;
        self
    }

    /// The fraction of a pixel chords may deviate, as given (None: the
    /// default).
    pub fn pixel_tolerance(&self) -> Option<f64> {
        self.pixel_tolerance
    }

    /// The same medium traced by `method` at the metre `tolerance` (pixel
    /// tolerance, view and geometry kept).
    ///
    /// # Errors
    ///
    /// As [`Medium::try_new`].
    pub fn retuned(&self, method: Method, tolerance: f64) -> Result<Medium, MediumError> {
        let mut m = Medium::try_new(self.field.clone(), self.bounds, method, tolerance, self.step)?
            .with_pixel_tolerance(self.pixel_tolerance)?
            .with_indirect_tolerance_scale(Some(self.indirect_scale))?;
        if let Some((eye, angle)) = self.view {
            m = m.with_view(eye, angle);
        }
        Ok(m.with_obstacle_set(self.obstacles.clone()))
    }

    /// The footprint tolerance of method `invariant` once a view is set.
    pub fn footprint(&self) -> Option<Footprint> {
        let (eye, pixel_angle) = self.view?;
        (self.method == Method::Invariant).then(|| Footprint {
            eye,
            pixel_angle,
            fraction: self.pixel_tolerance.unwrap_or(DEFAULT_PIXEL_TOLERANCE),
        })
    }

    /// The chord tolerance at `p`, metres: the footprint's (method
    /// `invariant` with a view), else `tolerance`.
    pub fn tolerance_at(&self, p: DVec3) -> f64 {
        self.chord_tolerance().at(p)
    }

    /// The chord tolerance everywhere (see [`Medium::tolerance_at`]).
    pub fn chord_tolerance(&self) -> ChordTolerance {
        self.footprint()
            .map_or(ChordTolerance::Fixed(self.tolerance), |f| {
                ChordTolerance::Footprint(f, MIN_CHORD_TOLERANCE)
            })
    }

    /// Does a ray inside the bounds fly (integrate without chords while no
    /// geometry is near, [`CurvedRay::next_chord`](super::CurvedRay::next_chord))? For rk45 through a 3-D
    /// field when the scene's geometry is known as boxes. (Stratified fields
    /// have method `invariant` for that.)
    pub fn flies(&self) -> bool {
        self.method == Method::Rk45 && self.field.strata().is_none() && !self.obstacles.is_unknown()
    }

    /// The error allowed per step of a flight: (metres, radians). With a view,
    /// `pixel_tolerance` (default [`DEFAULT_FLIGHT_PIXEL_TOLERANCE`]) of the
    /// pixel footprint at `p` and of the pixel angle, which bound what the
    /// error moves in the image (footprint.rs); without one `tolerance`
    /// metres, and `tolerance` radians (what moves a point a metre on by the
    /// tolerance).
    pub fn flight_tolerances(&self, p: DVec3) -> (f64, f64) {
        match self.view {
            Some((eye, pixel_angle)) => {
                let f = Footprint {
                    eye,
                    pixel_angle,
                    fraction: self.pixel_tolerance.unwrap_or(DEFAULT_FLIGHT_PIXEL_TOLERANCE),
                };
                (f.at(p, MIN_CHORD_TOLERANCE), f.angle())
            }
            None => (self.tolerance, self.tolerance),
        }
    }

    /// The world-space box the field fills, metres.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }
    /// The validated field (`up` normalised).
    pub fn field(&self) -> &IndexField {
        &self.field
    }
    /// How rays are integrated inside the bounds.
    pub fn method(&self) -> Method {
        self.method
    }
    /// Chord–arc deviation bound and rk45's error target, metres.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }
    /// Step of the fixed-step methods (rk4 and the paper's), metres.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// The field's n (meaningful inside the bounds).
    pub fn ior_at(&self, p: DVec3) -> f64 {
        self.field.n(p)
    }

    pub(super) fn stepper(&self) -> Stepper<'_> {
        Stepper::new(&self.field, self.method, self.tolerance, self.step)
    }
}
