//! Scenes: the typed TOML description, validation with file/key/line errors,
//! and the built render scene (Embree geometry plus everything shading needs):
//! `model` is the scene a render sees, `sun` the sky's sun disk and its sampling, `emitter` the
//! sampling of emitting objects and the spot light, `builder` turns a description into it,
//! `import` reads glTF and Mitsuba scenes into descriptions.
pub mod builder;
pub mod desc;
pub mod emitter;
pub mod envmap;
pub mod import;
mod light_sampling;
pub mod model;
pub mod shapes;
pub mod source;
pub mod sun;
pub mod texture;

#[cfg(test)]
mod set_tests;

pub use builder::{build_scene_text, load_scene, load_scene_source, load_scene_str, BuildOptions};
pub use import::{ImportOptions, SceneText};
pub use model::{
    Environment, GeomRecord, IntegratorKind, Light, LightSample, Material, RenderScene, Shape, Solid,
    SurfacePoint, MAX_PIXELS,
};
pub use shapes::meshgen;
