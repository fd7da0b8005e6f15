//! glTF 2.0 scenes (docs/import-gltf.md): the default scene's node tree
//! (transforms composed, a node reached twice refused), its first
//! perspective camera, `KHR_lights_punctual` point, spot and directional
//! lights (photometric units over 683 lm/W), and one object per triangle
//! primitive whose mesh the description names by file, mesh and primitive
//! index. An emissive black quad becomes a rect light; `snell:environment`
//! in the scene's extras is a constant sky.
use super::{ImportOptions, Imported, Location, Warning};
use crate::error::{Error, Result};
use crate::scene::desc::*;
use crate::scene::shapes::Mesh;
use glam::{DMat4, DVec3};
use std::collections::HashSet;
use std::path::Path;

mod data;
pub mod material;

pub use material::PRIORITY_KEY;

/// The scene extras key of a constant environment radiance `[r, g, b]`.
pub const ENVIRONMENT_KEY: &str = "snell:environment";

/// Luminous efficacy dividing glTF's photometric light units into snell's
/// radiometric ones (the 555 nm maximum; Blender's exporter multiplies watts by it).
pub const LUMENS_PER_WATT: f64 = 683.0;

/// Deepest node hierarchy followed.
const MAX_NODE_DEPTH: usize = 1024;

/// One primitive of a glTF mesh file, for the `mesh` shape.
pub fn load_primitive(
    path: &Path,
    mesh: u64,
    prim: u64,
    smooth: bool,
) -> Result<Mesh, (&'static str, String)> {
    let d = data::load(path).map_err(|(p, e)| ("file", format!("{p}: {e}")))?;
    let (m, p) = (
        usize::try_from(mesh).map_err(|_| ("mesh", "out of range".to_string()))?,
        usize::try_from(prim).map_err(|_| ("primitive", "out of range".to_string()))?,
    );
    if m >= d.doc.meshes().len() {
        return Err((
            "mesh",
            format!("no mesh {m}: the file has {}", d.doc.meshes().len()),
        ));
    }
    d.primitive(m, p, smooth).map_err(|(ptr, e)| {
        let key = if ptr == format!("/meshes/{m}/primitives") {
            "primitive"
        } else {
            "file"
        };
        (key, format!("{ptr}: {e}"))
    })
}

/// Import the glTF (`.gltf`) or GLB (`.glb`) scene at `path`.
///
/// # Errors
///
/// As [`super::import_scene`]: located by JSON pointer.
pub fn import(path: &Path, opts: &ImportOptions) -> Result<Imported> {
    let file = path.display().to_string();
    let at = |p: String| Location {
        file: file.clone(),
        line: 1,
        column: 1,
        element: p,
    };
    let d = data::load(path).map_err(|(p, e)| at(p).error(e))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    scene(&d, &file, &name, opts)
}

/// Import glTF or GLB bytes (the fuzzer's entry); `name` is the file name
/// the description's meshes refer to, in `dir`.
///
/// # Errors
///
/// As [`import`].
pub fn import_bytes(
    file: &str,
    bytes: &[u8],
    dir: &Path,
    name: &str,
    opts: &ImportOptions,
) -> Result<Imported> {
    let d = data::parse(bytes, dir).map_err(|(p, e)| {
        Location {
            file: file.to_string(),
            line: 1,
            column: 1,
            element: p,
        }
        .error(e)
    })?;
    scene(&d, file, name, opts)
}

struct Walk<'a> {
    d: &'a data::GltfData,
    file: &'a str,
    mesh_file: &'a str,
    camera: Option<(CameraDesc, FilmDesc, Location)>,
    lights: Vec<(LightDesc, Location)>,
    objects: Vec<(ObjectDesc, Location)>,
    warnings: Vec<Warning>,
    warned_materials: HashSet<Option<usize>>,
    names: HashSet<String>,
}

impl Walk<'_> {
    fn at(&self, p: impl Into<String>) -> Location {
        Location {
            file: self.file.to_string(),
            line: 1,
            column: 1,
            element: p.into(),
        }
    }

    fn err(&self, p: impl Into<String>, m: impl Into<String>) -> Error {
        self.at(p).error(m)
    }

    fn unique(&mut self, base: String) -> String {
        let mut n = base.clone();
        let mut k = 2;
        while !self.names.insert(n.clone()) {
            n = format!("{base}#{k}");
            k += 1;
        }
        n
    }

    fn node(&mut self, node: gltf::Node<'_>, m: DMat4) -> Result<()> {
        let ptr = format!("/nodes/{}", node.index());
        if let Some(c) = node.camera() {
            if self.camera.is_none() {
                self.camera = Some(self.camera_of(&c, &m, &ptr)?);
            }
        }
        if let Some(l) = node.light() {
            self.light(&l, &m, &ptr, node.name())?;
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                self.primitive(&node, &mesh, &prim, &m)?;
            }
        }
        Ok(())
    }

    fn camera_of(
        &self,
        c: &gltf::Camera<'_>,
        m: &DMat4,
        ptr: &str,
    ) -> Result<(CameraDesc, FilmDesc, Location)> {
        let cp = format!("/cameras/{}", c.index());
        let pos = m.transform_point3(DVec3::ZERO);
        let f = m.transform_vector3(-DVec3::Z);
        let up = m.transform_vector3(DVec3::Y);
        if !(pos.is_finite()
            && f.length() > 1e-9
            && up.length() > 1e-9
            && f.normalize().dot(up.normalize()).abs() < 1e-4)
        {
            return Err(self.err(
                ptr,
                "the camera's node transform must be a rotation and translation",
            ));
        }
        // The node's scale along each axis (an orthographic view scales
        // with it; a perspective camera's angles do not).
        let scale = DVec3::new(m.transform_vector3(DVec3::X).length(), up.length(), f.length());
        let (f, up) = (f.normalize(), up.normalize());
        let p = match c.projection() {
            gltf::camera::Projection::Perspective(p) => p,
            gltf::camera::Projection::Orthographic(o) => {
                return self.orthographic(&o, &cp, ptr, (pos, f, up), scale)
            }
        };
        let fov = material::short(p.yfov()).to_degrees();
        if !(fov > 0.0 && fov < 180.0) {
            return Err(self.err(
                format!("{cp}/perspective/yfov"),
                format!("expected (0, π), got {}", p.yfov()),
            ));
        }
        let mut film = FilmDesc::default();
        if let Some(a) = p.aspect_ratio() {
            if !(a > 0.0 && a.is_finite()) {
                return Err(self.err(
                    format!("{cp}/perspective/aspectRatio"),
                    format!("expected > 0, got {a}"),
                ));
            }
            film.height = ((film.width as f64 / a as f64).round() as u64).clamp(1, 1 << 16);
        }
        Ok((
            CameraDesc {
                kind: "perspective".into(),
                position: pos.to_array(),
                target: (pos + f).to_array(),
                up: up.to_array(),
                fov: Some(fov),
                size: None,
                aperture_radius: 0.0,
                focus_distance: None,
                inside: None,
            },
            film,
            self.at(ptr),
        ))
    }

    /// glTF 2.0's orthographic camera (§3.10.3): it sees x in [−xmag, xmag]
    /// and y in [−ymag, ymag] of its node's frame, looking along −z, between
    /// the planes z = −znear and −zfar (the view matrix is the inverse of
    /// the node's transform, so a node's `scale` scales all three). snell's
    /// rays start on the near plane (parallel rays make that exactly the
    /// near clip); the far clip is not applied. The film keeps the default
    /// width, its height the view's aspect (square pixels), as a perspective
    /// camera's takes aspectRatio.
    fn orthographic(
        &self,
        o: &gltf::camera::Orthographic<'_>,
        cp: &str,
        ptr: &str,
        (pos, f, up): (DVec3, DVec3, DVec3),
        scale: DVec3,
    ) -> Result<(CameraDesc, FilmDesc, Location)> {
        // The spec: xmag and ymag MUST NOT be zero and SHOULD NOT be
        // negative; a negative one would mirror the image, which snell's
        // cameras never do.
        let mag = |k: &str, v: f32| -> Result<f64> {
            let v = material::short(v);
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(self.err(
                    format!("{cp}/orthographic/{k}"),
                    format!("expected a finite number > 0, got {v}"),
                ))
            }
        };
        let (xmag, ymag) = (mag("xmag", o.xmag())? * scale.x, mag("ymag", o.ymag())? * scale.y);
        let (near, far) = (material::short(o.znear()), material::short(o.zfar()));
        if !(near.is_finite() && near >= 0.0) {
            return Err(self.err(
                format!("{cp}/orthographic/znear"),
                format!("expected a finite number >= 0, got {near}"),
            ));
        }
        if !(far.is_finite() && far > near) {
            return Err(self.err(
                format!("{cp}/orthographic/zfar"),
                format!("expected a finite number > znear ({near}), got {far}"),
            ));
        }
        let mut film = FilmDesc::default();
        film.height = ((film.width as f64 * ymag / xmag).round() as u64).clamp(1, 1 << 16);
        let position = pos + f * (near * scale.z);
        Ok((
            CameraDesc {
                kind: "orthographic".into(),
                position: position.to_array(),
                target: (position + f).to_array(),
                up: up.to_array(),
                fov: None,
                size: Some([2.0 * xmag, 2.0 * ymag]),
                aperture_radius: 0.0,
                focus_distance: None,
                inside: None,
            },
            film,
            self.at(ptr),
        ))
    }

    fn light(
        &mut self,
        l: &gltf::khr_lights_punctual::Light<'_>,
        m: &DMat4,
        ptr: &str,
        name: Option<&str>,
    ) -> Result<()> {
        // KHR_lights_punctual is photometric (candela for point and spot
        // lights, lux for directional ones); snell's W/sr and W/m² are
        // those at the 683 lm/W exporters such as Blender's assume.
        let power = l
            .color()
            .map(|c| material::short(c) * material::short(l.intensity()) / LUMENS_PER_WATT);
        let name = name
            .map(|n| n.to_string())
            .or_else(|| l.name().map(str::to_string));
        let name = name.map(|n| self.unique(n));
        let at = self.at(ptr);
        match l.kind() {
            gltf::khr_lights_punctual::Kind::Point => self.lights.push((
                LightDesc::Point(PointLightDesc {
                    name,
                    position: m.transform_point3(DVec3::ZERO).to_array(),
                    intensity: power,
                }),
                at,
            )),
            gltf::khr_lights_punctual::Kind::Directional => self.lights.push((
                LightDesc::Directional(DirectionalLightDesc {
                    name,
                    direction: m.transform_vector3(-DVec3::Z).to_array(),
                    irradiance: power,
                }),
                at,
            )),
            // The cone's angles as snell's (Mitsuba's) spot: full intensity
            // out to the inner angle, a linear ramp in the angle to the outer.
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => self.lights.push((
                LightDesc::Spot(SpotLightDesc {
                    name,
                    position: m.transform_point3(DVec3::ZERO).to_array(),
                    direction: Some(m.transform_vector3(-DVec3::Z).to_array()),
                    target: None,
                    intensity: power,
                    cutoff_angle: material::short(outer_cone_angle).to_degrees(),
                    beam_width: Some(material::short(inner_cone_angle).to_degrees()),
                }),
                at,
            )),
        }
        Ok(())
    }

    fn primitive(
        &mut self,
        node: &gltf::Node<'_>,
        mesh: &gltf::Mesh<'_>,
        prim: &gltf::Primitive<'_>,
        m: &DMat4,
    ) -> Result<()> {
        let ptr = format!("/meshes/{}/primitives/{}", mesh.index(), prim.index());
        let tri = self
            .d
            .primitive(mesh.index(), prim.index(), true)
            .map_err(|(p, e)| self.err(p, e))?;
        let closed = tri.check_closed().is_ok();
        let mat = prim.material();
        let dir = self.d.dir.clone();
        let image_file = |t: &gltf::Texture<'_>| -> Option<String> {
            match t.source().source() {
                gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") && !uri.contains("://") => {
                    let f = data::percent_decode(uri);
                    dir.join(&f).is_file().then_some(f)
                }
                _ => None,
            }
        };
        let mapped = material::map(&mat, closed, &image_file).map_err(|(p, e)| self.err(p, e))?;
        if !mapped.lost.is_empty() && self.warned_materials.insert(mat.index()) {
            let what = mat
                .name()
                .map(|n| format!("material \"{n}\""))
                .unwrap_or_else(|| "the material".into());
            let p = mat
                .index()
                .map(|i| format!("/materials/{i}"))
                .unwrap_or_else(|| ptr.clone());
            let w = self
                .at(p)
                .warning(format!("{what}: not mapped: {}", mapped.lost.join(", ")));
            self.warnings.push(w);
        }
        let base = node
            .name()
            .or(mesh.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("nodes[{}]", node.index()));
        let base = if mesh.primitives().len() > 1 {
            format!("{base}.{}", prim.index())
        } else {
            base
        };
        let name = self.unique(base);
        // An emissive black quad is a light snell samples directly.
        if let (
            Some(EmissionDesc {
                radiance: TextureDesc::Constant(r),
                two_sided: false,
            }),
            true,
            false,
        ) = (&mapped.emission, mapped.black, mat.double_sided())
        {
            if let Some(rect) = world_rect(&tri, m) {
                self.lights.push((
                    LightDesc::Rect(RectLightDesc {
                        name: Some(name),
                        center: rect.center,
                        normal: rect.normal,
                        u_axis: rect.u_axis,
                        size: rect.size,
                        radiance: *r,
                    }),
                    self.at(ptr),
                ));
                return Ok(());
            }
        }
        self.objects.push((
            ObjectDesc {
                name: Some(name),
                shape: ShapeDesc::Mesh(MeshDesc {
                    file: self.mesh_file.to_string(),
                    smooth: prim.get(&gltf::Semantic::Normals).is_some(),
                    shape_index: None,
                    mesh: Some(mesh.index() as u64),
                    primitive: Some(prim.index() as u64),
                }),
                material: mapped.material,
                emission: mapped.emission,
                transform: steps(m),
                flip_inside_out: false,
            },
            self.at(ptr),
        ));
        Ok(())
    }
}

/// The scene of `d`. (Nothing a glTF file holds is refused or skipped, so
/// `--lenient` changes nothing here; `--strict` applies to the warnings,
/// by the caller.)
fn scene(d: &data::GltfData, file: &str, mesh_file: &str, _opts: &ImportOptions) -> Result<Imported> {
    let mut w = Walk {
        d,
        file,
        mesh_file,
        camera: None,
        lights: Vec::new(),
        objects: Vec::new(),
        warnings: Vec::new(),
        warned_materials: HashSet::new(),
        names: HashSet::new(),
    };
    let sc = d
        .doc
        .default_scene()
        .or_else(|| d.doc.scenes().next())
        .ok_or_else(|| w.err("/scenes", "the file has no scene"))?;
    let sp = format!("/scenes/{}", sc.index());
    // Depth first, each node once: a node reached again is a cycle or a
    // shared child, which glTF forbids.
    let mut seen = vec![false; d.doc.nodes().len()];
    let mut stack: Vec<(gltf::Node<'_>, DMat4, usize)> =
        sc.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect::<Vec<_>>();
    stack.reverse();
    while let Some((n, parent, depth)) = stack.pop() {
        let ptr = format!("/nodes/{}", n.index());
        if std::mem::replace(&mut seen[n.index()], true) {
            return Err(w.err(
                ptr,
                "the node is reached twice (a cycle, or a child of two parents)",
            ));
        }
        if depth > MAX_NODE_DEPTH {
            return Err(w.err(ptr, format!("the node hierarchy is deeper than {MAX_NODE_DEPTH}")));
        }
        let local = DMat4::from_cols_array_2d(&n.transform().matrix().map(|c| c.map(f64::from)));
        let m = parent * local;
        if !m.is_finite() {
            return Err(w.err(ptr, "the node's transform is not finite"));
        }
        w.node(n.clone(), m)?;
        let mut kids: Vec<_> = n.children().map(|c| (c, m, depth + 1)).collect();
        kids.reverse();
        stack.extend(kids);
    }
    let Some((camera, film, cam_at)) = w.camera.take() else {
        return Err(w.err(
            sp,
            "the scene has no camera (snell renders from the scene's camera)",
        ));
    };
    let environment = match material::extras(sc.extras()).and_then(|x| x.get(ENVIRONMENT_KEY).cloned()) {
        None => None,
        Some(v) => {
            let c: Option<Vec<f64>> = v
                .as_array()
                .map(|a| a.iter().filter_map(|x| x.as_f64()).collect());
            match c.as_deref() {
                Some([r, g, b]) => Some(EnvironmentDesc::Constant(ConstantEnv {
                    radiance: [*r, *g, *b],
                })),
                _ => {
                    return Err(w.err(
                        format!("{sp}/extras/{ENVIRONMENT_KEY}"),
                        format!("expected [r, g, b], got {v}"),
                    ))
                }
            }
        }
    };
    let mut origins = vec![
        ("camera".to_string(), cam_at.clone()),
        ("film".to_string(), cam_at),
        ("(document)".to_string(), w.at(sp.clone())),
        ("environment".to_string(), w.at(format!("{sp}/extras"))),
        ("objects".to_string(), w.at(sp.clone())),
        ("integrator".to_string(), w.at("/")),
    ];
    let lights = w
        .lights
        .into_iter()
        .enumerate()
        .map(|(i, (l, at))| {
            origins.push((format!("lights[{i}]"), at));
            l
        })
        .collect();
    let objects = w
        .objects
        .into_iter()
        .enumerate()
        .map(|(i, (o, at))| {
            origins.push((format!("objects[{i}]"), at));
            o
        })
        .collect();
    Ok(Imported {
        desc: SceneDesc {
            camera,
            film,
            integrator: IntegratorDesc::default(),
            // glTF's world is air without a medium: indices are relative to it.
            ambient_ior: 1.0,
            environment,
            lights,
            objects,
            medium: None,
            warp: None,
        },
        warnings: w.warnings,
        origins,
    })
}

/// `m` as snell transform steps (none for the identity, else a matrix).
fn steps(m: &DMat4) -> Vec<TransformDesc> {
    if *m == DMat4::IDENTITY {
        return Vec::new();
    }
    vec![TransformDesc {
        translate: None,
        rotate: None,
        scale: None,
        matrix: Some(m.transpose().to_cols_array_2d()),
    }]
}

struct Rect {
    center: Vec3,
    normal: Vec3,
    u_axis: Vec3,
    size: [f64; 2],
}

/// A two-triangle planar rectangle, in world space.
fn world_rect(mesh: &Mesh, m: &DMat4) -> Option<Rect> {
    if mesh.indices.len() != 2 {
        return None;
    }
    let p = |i: u32| m.transform_point3(DVec3::from_array(mesh.positions[i as usize].map(f64::from)));
    let mut corners: Vec<DVec3> = Vec::new();
    for t in &mesh.indices {
        for &i in t {
            let q = p(i);
            if !corners.iter().any(|c| c.distance(q) < 1e-9 * (1.0 + q.length())) {
                corners.push(q);
            }
        }
    }
    if corners.len() != 4 {
        return None;
    }
    let t = mesh.indices[0].map(p);
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let t2 = mesh.indices[1].map(p);
    let n2 = (t2[1] - t2[0]).cross(t2[2] - t2[0]);
    if n.length() == 0.0 || n.dot(n2) <= 0.0 {
        return None;
    }
    let n = n.normalize();
    let c0 = corners[0];
    let far = (1..4).max_by(|&a, &b| c0.distance(corners[a]).total_cmp(&c0.distance(corners[b])))?;
    let others: Vec<DVec3> = (1..4).filter(|&k| k != far).map(|k| corners[k]).collect();
    let (a, b) = (others[0] - c0, others[1] - c0);
    let tol = 1e-6 * (a.length() * b.length());
    if a.dot(b).abs() > tol || (c0 + a + b).distance(corners[far]) > 1e-6 * (1.0 + a.length() + b.length()) {
        return None;
    }
    if a.dot(n).abs() > tol || b.dot(n).abs() > tol {
        return None;
    }
    let center = c0 + 0.5 * (a + b);
    Some(Rect {
        center: center.to_array(),
        normal: n.to_array(),
        u_axis: a.normalize().to_array(),
        size: [a.length(), b.length()],
    })
}
