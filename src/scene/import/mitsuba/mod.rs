//! Mitsuba 3 XML scenes (docs/import-mitsuba.md): `xml` reads the files
//! (includes, `$param` substitution, search paths), `props` reads a
//! plugin's parameters, and one file per kind of plugin maps it to snell's
//! description: `sensor` (camera, film, sampler, integrator), `shapes`,
//! `bsdf` (with `ior` and `textures`), `emitters`; `spectra` and
//! `transform` convert values.
use super::{ImportOptions, Imported, Location};
use crate::error::Result;
use crate::scene::desc::*;
use std::path::Path;

mod bsdf;
mod emitters;
mod ior;
mod numbers;
mod props;
mod sensor;
mod shapes;
mod spectra;
mod textures;
mod transform;
pub mod xml;

use props::Ctx;

/// What the plugins add to the scene, each with the element it came from.
#[derive(Default)]
struct Out {
    lights: Vec<(LightDesc, Location)>,
    objects: Vec<(ObjectDesc, Location)>,
    environment: Option<(EnvironmentDesc, Location)>,
}

/// Import the Mitsuba scene file at `path`.
///
/// # Errors
///
/// As [`super::import_scene`].
pub fn import(path: &Path, opts: &ImportOptions) -> Result<Imported> {
    let doc = xml::read(path, opts)?;
    from_document(&doc, opts)
}

/// Import Mitsuba XML text; `file` names it in errors and `dir` resolves
/// its files.
///
/// # Errors
///
/// As [`super::import_scene`] (without `--strict`: warnings are returned).
pub fn import_str(file: &str, text: &str, dir: &Path, opts: &ImportOptions) -> Result<Imported> {
    let doc = xml::read_str(file, text, dir, opts)?;
    from_document(&doc, opts)
}

fn from_document(doc: &xml::Document, opts: &ImportOptions) -> Result<Imported> {
    let ctx = Ctx::new(doc, opts.lenient)?;
    let root = &doc.root;
    let mut out = Out::default();
    let mut sensor_desc = None;
    let mut integrator = None;
    for c in &root.children {
        match c.tag.as_str() {
            "sensor" => {
                if let Some((_, at)) = &sensor_desc {
                    let at: &Location = at;
                    return Err(c.at.error(format!(
                        "a second sensor (the first is at line {}): snell renders one camera",
                        at.line
                    )));
                }
                sensor_desc = Some((sensor::sensor(&ctx, c)?, c.at.clone()));
            }
            "integrator" => {
                if integrator.is_some() {
                    return Err(c.at.error("a second integrator: expected one"));
                }
                integrator = Some((sensor::integrator(&ctx, c)?, c.at.clone()));
            }
            "shape" => shapes::shape(&ctx, c, &mut out)?,
            "emitter" => emitters::top_level(&ctx, c, &mut out)?,
            // Declarations for `<ref>`: read where they are used.
            "bsdf" | "texture" => {}
            "medium" | "phase" | "volume" => {
                return Err(c.at.error(
                    "participating media are not supported (snell's media are its gradient-index [medium] and Beer–Lambert absorption of nested solids)",
                ))
            }
            other => ctx.unknown(&c.at, format!("unknown element <{other}> in <scene>"))?,
        }
    }
    let ((camera, film), sensor_at) = sensor_desc.ok_or_else(|| root.at.error("expected a <sensor>"))?;
    let (integrator, integrator_at) = match integrator {
        Some(i) => i,
        // Mitsuba's default: the path tracer, unlimited depth.
        None => (
            IntegratorDesc {
                kind: "path".into(),
                max_depth: sensor::MAX_DEPTH,
                rr_depth: 5,
            },
            root.at.clone(),
        ),
    };
    let mut origins = vec![
        ("camera".to_string(), sensor_at.clone()),
        ("film".to_string(), sensor_at),
        ("integrator".to_string(), integrator_at),
        ("(document)".to_string(), root.at.clone()),
        ("ambient_ior".to_string(), root.at.clone()),
        ("objects".to_string(), root.at.clone()),
    ];
    let environment = out.environment.map(|(e, at)| {
        origins.push(("environment".into(), at));
        e
    });
    let lights = out
        .lights
        .into_iter()
        .enumerate()
        .map(|(i, (l, at))| {
            origins.push((format!("lights[{i}]"), at));
            l
        })
        .collect();
    let objects = out
        .objects
        .into_iter()
        .enumerate()
        .map(|(i, (o, at))| {
            origins.push((format!("objects[{i}]"), at));
            o
        })
        .collect();
    let warnings = ctx.warnings.into_inner();
    Ok(Imported {
        desc: SceneDesc {
            camera,
            film,
            integrator,
            // Mitsuba's scenes sit in vacuum: every interface names its indices.
            ambient_ior: 1.0,
            environment,
            lights,
            objects,
            medium: None,
            warp: None,
        },
        warnings,
        origins,
    })
}
