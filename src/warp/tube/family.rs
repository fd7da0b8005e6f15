//! The path families: how an eye ray can reach a target through the tube.

/// How the eye ray reaches the target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// No refraction.
    Direct,
    /// Outer in, inner out, inner in, outer out.
    Through4,
    /// Outer in, total internal reflection at the inner wall, outer out.
    Tir2,
    /// Through the glass wall only.
    Wall2,
    /// Outer in, inner out: the target is in the hollow.
    Hollow2,
}

impl Family {
    /// Number of refractions along paths of this family.
    pub fn refractions(self) -> u32 {
        match self {
            Family::Direct => 0,
            Family::Through4 => 4,
            _ => 2,
        }
    }
}
