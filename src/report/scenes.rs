//! Scenes of the repository's `scenes/` loaded and rendered at a report's
//! sizes, quietly.
use crate::error::Result;
use crate::render::{render, RenderOptions, RenderSettings, Rendered};
use crate::scene::{load_scene, BuildOptions, RenderScene};
use std::path::Path;

/// No progress bar, every core.
fn quiet() -> RenderOptions {
    RenderOptions {
        threads: None,
        want_aovs: false,
        ..Default::default()
    }
}

/// Scene `name` of `dir` and its settings at `w`×`h`, `spp`, `seed`.
pub(crate) fn scene_at(
    dir: &Path,
    name: &str,
    w: u32,
    h: u32,
    spp: u32,
    seed: u64,
) -> Result<(RenderScene, RenderSettings)> {
    let s = load_scene(&dir.join(format!("{name}.toml")), &BuildOptions::default())?;
    let set = RenderSettings::from_scene(&s)
        .with_resolution(w, h)?
        .with_spp(spp)
        .with_seed(seed);
    Ok((s, set))
}

/// Render scene `name` of `dir` at `w`×`h`, `spp`, `seed`.
pub(crate) fn render_at(dir: &Path, name: &str, w: u32, h: u32, spp: u32, seed: u64) -> Result<Rendered> {
    let (s, set) = scene_at(dir, name, w, h, spp, seed)?;
    render(&s, &set, &quiet())
}
