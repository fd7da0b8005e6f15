//! Nested dielectrics (Schmidt & Budge 2002): priorities, the per-ray
//! [`InteriorList`], and the three ways of finding the first *true* hit:
//!
//! - [`NestedStrategy::Filter`] (default): false hits are skipped inside an
//!   Embree context filter ([`FalseHitFilter`]). The rule (docs/design.md): with P0
//!   the highest rank in the list at the ray origin, the first true hit is the
//!   nearest hit on any object of rank ≥ P0, so the filter is stateless and
//!   traversal order does not matter. Rejected hits are recorded and applied to
//!   the list after the query, in t order, de-duplicated. Analytic solids
//!   ranked below P0 are left out of the query by Embree ray masks and
//!   settled by point-in-solid past the true hit instead.
//! - [`NestedStrategy::Recast`]: the paper's method. Nearest hit; if false,
//!   update the list and cast again from just past it.
//! - [`NestedStrategy::Toggle`]: `Recast` with the paper's toggle in place of
//!   the geometric normal for deciding entering vs leaving.
//!
//! Priorities: the higher priority wins, as in the paper, Arnold and RenderMan.
//! Ties are broken by declaration order: of two solids with equal priority the
//! one declared later in the scene file wins, as if its priority were higher by
//! an infinitesimal (`Solid::rank`). This makes true/false a total order.
//!
//! Files: `list.rs` (the list, with ranks), `filter.rs` (the filter and the
//! application of its records), `trace.rs` (the first true hit, every
//! strategy), `boundary.rs` (the boundary event at a true hit: the one place
//! that decides the indices, entering vs leaving and the list after),
//! `settle.rs` (other solids' surfaces within the spawn offset of a true hit,
//! which no query crosses: settled by point-in-solid).
mod boundary;
mod filter;
mod list;
mod settle;
mod trace;

pub use boundary::{boundary, keeps_line, medium_of, Boundary, Nesting};
pub use filter::{
    apply_rejected, Coincident, FalseHitFilter, FilterRecords, NearSolids, Rejected, TrueHit, EDGE_EPS,
    NEAR_CAPACITY, REJECT_CAPACITY,
};
pub use list::InteriorList;
pub use settle::settle_child;
pub use trace::{
    masked_hit_is_true, packet_query, plain_hit_is_true, plain_query_suffices, settle_masked_after, trace,
    trace_timing_list_updates, ListUpdateTimer, PacketQuery,
};

/// A test scene: water (priority 1, the unit box at the origin) whose right
/// half lies inside a glass box (priority 2, x from -0.2 to 0.8), then the
/// `[[objects]]` of `more`. A ray inside both crosses the water's face at
/// x = 0.5 as a false hit.
#[cfg(test)]
pub(crate) fn water_in_glass(more: &str) -> crate::scene::RenderScene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, 9.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[[objects]]
name = "water"
shape = {{ type = "box", center = [0.0, 0.0, 0.0], size = [1.0, 1.0, 1.0] }}
material = {{ type = "dielectric", ior = 1.33, priority = 1 }}
[[objects]]
name = "glass"
shape = {{ type = "box", center = [0.3, 0.0, 0.0], size = [1.0, 2.0, 2.0] }}
material = {{ type = "dielectric", ior = 1.5, priority = 2 }}
{more}"#
    );
    test_scene(&text)
}

/// A test scene: sphere "a" (priority 1, the unit sphere at the origin)
/// and sphere "b" (priority 2) of centre and radius `b`, then the
/// `[[objects]]` of `more`.
#[cfg(test)]
pub(crate) fn two_spheres(b: ([f64; 3], f64), more: &str) -> crate::scene::RenderScene {
    let ([x, y, z], r) = b;
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[[objects]]
name = "a"
shape = {{ type = "sphere", center = [0.0, 0.0, 0.0], radius = 1.0 }}
material = {{ type = "dielectric", ior = 1.33, priority = 1 }}
[[objects]]
name = "b"
shape = {{ type = "sphere", center = [{x:?}, {y:?}, {z:?}], radius = {r:?} }}
material = {{ type = "dielectric", ior = 1.5, priority = 2 }}
{more}"#
    );
    test_scene(&text)
}

/// The scene of the TOML `text` (a test's own; it must load).
#[cfg(test)]
fn test_scene(text: &str) -> crate::scene::RenderScene {
    let build = crate::scene::BuildOptions::default();
    crate::scene::load_scene_str("t.toml", text, std::path::Path::new("."), &build)
        .expect("a valid test scene")
}

/// How false hits are found and skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NestedStrategy {
    /// False hits are skipped inside an Embree context filter (default).
    Filter,
    /// The paper's method: nearest hit, and cast again past each false one.
    Recast,
    /// `Recast` with the paper's toggle deciding entering vs leaving.
    Toggle,
    /// No nesting at all: every hit is true, lists are ignored. Wrong for
    /// overlapping solids; the "unmodified ray tracer" speed reference.
    Off,
}

impl std::str::FromStr for NestedStrategy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "filter" => Ok(NestedStrategy::Filter),
            "recast" => Ok(NestedStrategy::Recast),
            "toggle" => Ok(NestedStrategy::Toggle),
            "off" => Ok(NestedStrategy::Off),
            o => Err(format!("expected filter, recast, toggle or off, got \"{o}\"")),
        }
    }
}

impl NestedStrategy {
    /// The strategy's name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            NestedStrategy::Filter => "filter",
            NestedStrategy::Recast => "recast",
            NestedStrategy::Toggle => "toggle",
            NestedStrategy::Off => "off",
        }
    }
}
