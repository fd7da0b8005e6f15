//! Scenes: the typed TOML description, validation with file/key/line errors,
//! and the built render scene (Embree geometry plus everything shading needs):
//! `model` is the scene a render sees, `build` turns a description into it.
pub mod build;
pub mod desc;
pub mod meshgen;
pub mod model;
pub mod shapes;
pub mod source;
pub mod texture;

pub use build::{load_scene, load_scene_source, load_scene_str, BuildOptions};
pub use model::{
    Environment, GeomRecord, IntegratorKind, Light, LightSample, Material, RenderScene, Shape, Solid,
    SurfacePoint, MAX_PIXELS,
};
