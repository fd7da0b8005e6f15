//! Scenes: the typed TOML description, validation with file/key/line errors,
//! and the built render scene (Embree geometry plus everything shading needs).
pub mod build;
pub mod desc;
pub mod meshgen;
pub mod shapes;
pub mod source;
pub mod texture;

pub use build::{
    load_scene, load_scene_source, load_scene_str, BuildOptions, Environment, GeomRecord, Light, Material,
    RenderScene, Solid,
};
