//! A plugin's parameters (`<float name=…>`, `<rgb name=…>`, nested objects,
//! `<ref id=…>`), read by name and type. Every child a plugin does not read
//! is an unknown parameter: an error with its line, or with `--lenient` a
//! warning.
use super::numbers::{number, numbers, xyz};
use super::spectra;
use super::xml::{Document, Node};
use crate::error::Result;
use crate::scene::import::{Location, Warning};
use glam::{DMat4, DVec3};
use std::cell::{Cell, RefCell};
use std::collections::HashMap;

/// What every plugin reader shares: the document, objects by `id`, the
/// warnings and whether unknown things are errors.
pub struct Ctx<'d> {
    /// The parsed scene.
    pub doc: &'d Document,
    ids: HashMap<&'d str, &'d Node>,
    lenient: bool,
    /// Everything not mapped exactly, in document order.
    pub warnings: RefCell<Vec<Warning>>,
}

impl<'d> Ctx<'d> {
    /// Index the objects of `doc` by id (a repeated id is an error).
    pub fn new(doc: &'d Document, lenient: bool) -> Result<Ctx<'d>> {
        let mut ids = HashMap::new();
        fn walk<'a>(n: &'a Node, ids: &mut HashMap<&'a str, &'a Node>) -> Result<()> {
            if n.tag != "ref" {
                if let Some(id) = n.attr("id") {
                    if let Some(prev) = ids.insert(id, n) {
                        return Err(n
                            .at
                            .error(format!("id \"{id}\" is already used at line {}", prev.at.line)));
                    }
                }
            }
            n.children.iter().try_for_each(|c| walk(c, ids))
        }
        walk(&doc.root, &mut ids)?;
        Ok(Ctx {
            doc,
            ids,
            lenient,
            warnings: RefCell::new(Vec::new()),
        })
    }

    /// A warning at `at`.
    pub fn warn(&self, at: &Location, msg: impl std::fmt::Display) {
        self.warnings.borrow_mut().push(at.warning(msg));
    }

    /// Something unknown: an error, or with `--lenient` a warning.
    pub fn unknown(&self, at: &Location, msg: String) -> Result<()> {
        if self.lenient {
            self.warn(at, format!("{msg} (skipped: --lenient)"));
            Ok(())
        } else {
            Err(at.error(msg))
        }
    }

    /// The object a `<ref id=…>` names.
    pub fn deref(&self, r: &'d Node) -> Result<&'d Node> {
        if r.tag != "ref" {
            return Ok(r);
        }
        let id = r.need("id")?;
        self.ids
            .get(id)
            .copied()
            .ok_or_else(|| r.at.error(format!("no object with id \"{id}\"")))
    }
}

/// Tags that hold a parameter value rather than an object.
const VALUE_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];

/// One plugin (`<shape type="sphere">`) and which of its children were read.
pub struct Obj<'c, 'd> {
    /// The element.
    pub node: &'d Node,
    /// The reader's context.
    pub ctx: &'c Ctx<'d>,
    used: Vec<Cell<bool>>,
}

/// A colour parameter: a constant, or a texture plugin to map.
pub enum ColorParam<'d> {
    /// Linear RGB.
    Rgb([f64; 3]),
    /// A `<texture>` (after `ref`).
    Texture(&'d Node),
}

impl<'c, 'd> Obj<'c, 'd> {
    /// Read plugin `node` (a `<ref>` is followed).
    pub fn new(ctx: &'c Ctx<'d>, node: &'d Node) -> Result<Obj<'c, 'd>> {
        let node = ctx.deref(node)?;
        Ok(Obj {
            node,
            ctx,
            used: node.children.iter().map(|_| Cell::new(false)).collect(),
        })
    }

    /// The plugin's `type`.
    pub fn plugin(&self) -> Result<&'d str> {
        self.node.need("type")
    }

    /// Where the plugin is written.
    pub fn at(&self) -> &'d Location {
        &self.node.at
    }

    /// The value child called `name`, marked read.
    pub fn value(&self, name: &str) -> Option<&'d Node> {
        let k = self
            .node
            .children
            .iter()
            .position(|c| VALUE_TAGS.contains(&c.tag.as_str()) && c.attr("name") == Some(name))?;
        self.used[k].set(true);
        Some(&self.node.children[k])
    }

    /// Nested objects with tag `tag` (`bsdf`, `emitter`, `film`, …), and
    /// `<ref>`s to such objects, marked read.
    pub fn objects(&self, tag: &str) -> Result<Vec<&'d Node>> {
        let mut out = Vec::new();
        for (k, c) in self.node.children.iter().enumerate() {
            let target = if c.tag == "ref" { self.ctx.deref(c)? } else { c };
            if target.tag == tag && (c.tag != "texture" || c.attr("name").is_none()) {
                self.used[k].set(true);
                out.push(target);
            }
        }
        Ok(out)
    }

    /// At most one nested object `tag`.
    pub fn object(&self, tag: &str) -> Result<Option<&'d Node>> {
        let v = self.objects(tag)?;
        if v.len() > 1 {
            return Err(v[1]
                .at
                .error(format!("a second <{tag}> here: expected at most one")));
        }
        Ok(v.first().copied())
    }

    /// A texture given as a named child (`<texture name="reflectance">` or
    /// `<ref name="reflectance" id=…>`), marked read.
    pub fn named_texture(&self, name: &str) -> Result<Option<&'d Node>> {
        for (k, c) in self.node.children.iter().enumerate() {
            if (c.tag == "texture" || c.tag == "ref") && c.attr("name") == Some(name) {
                self.used[k].set(true);
                let t = self.ctx.deref(c)?;
                if t.tag != "texture" {
                    return Err(c.at.error(format!("expected a texture, found <{}>", t.tag)));
                }
                return Ok(Some(t));
            }
        }
        Ok(None)
    }

    /// A number (`<float>` or `<integer>`).
    pub fn float(&self, name: &str) -> Result<Option<f64>> {
        let Some(n) = self.value(name) else {
            return Ok(None);
        };
        if n.tag != "float" && n.tag != "integer" {
            return Err(n
                .at
                .error(format!("expected <float name=\"{name}\">, found <{}>", n.tag)));
        }
        Ok(Some(number(n, n.need("value")?)?))
    }

    /// A number with a default.
    pub fn float_or(&self, name: &str, default: f64) -> Result<f64> {
        Ok(self.float(name)?.unwrap_or(default))
    }

    /// An `<integer>`.
    pub fn int(&self, name: &str) -> Result<Option<i64>> {
        let Some(n) = self.value(name) else {
            return Ok(None);
        };
        if n.tag != "integer" {
            return Err(n
                .at
                .error(format!("expected <integer name=\"{name}\">, found <{}>", n.tag)));
        }
        let v = n.need("value")?;
        v.trim()
            .parse()
            .map(Some)
            .map_err(|_| n.at.error(format!("expected an integer, got \"{v}\"")))
    }

    /// A `<boolean>` with a default.
    pub fn bool_or(&self, name: &str, default: bool) -> Result<bool> {
        let Some(n) = self.value(name) else {
            return Ok(default);
        };
        if n.tag != "boolean" {
            return Err(n
                .at
                .error(format!("expected <boolean name=\"{name}\">, found <{}>", n.tag)));
        }
        match n.need("value")?.trim() {
            "true" | "1" => Ok(true),
            "false" | "0" => Ok(false),
            v => Err(n.at.error(format!("expected true or false, got \"{v}\""))),
        }
    }

    /// A `<string>`.
    pub fn string(&self, name: &str) -> Result<Option<(&'d str, &'d Location)>> {
        let Some(n) = self.value(name) else {
            return Ok(None);
        };
        if n.tag != "string" {
            return Err(n
                .at
                .error(format!("expected <string name=\"{name}\">, found <{}>", n.tag)));
        }
        Ok(Some((n.need("value")?, &n.at)))
    }

    /// A `<point>` or `<vector>`: `x`, `y`, `z` attributes (default 0) or `value`.
    pub fn point(&self, name: &str) -> Result<Option<DVec3>> {
        let Some(n) = self.value(name) else {
            return Ok(None);
        };
        if n.tag != "point" && n.tag != "vector" {
            return Err(n
                .at
                .error(format!("expected <point name=\"{name}\">, found <{}>", n.tag)));
        }
        Ok(Some(xyz(n, 0.0)?))
    }

    /// A `<transform>` (identity when absent).
    pub fn transform(&self, name: &str) -> Result<(DMat4, Option<&'d Node>)> {
        let Some(n) = self.value(name) else {
            return Ok((DMat4::IDENTITY, None));
        };
        if n.tag != "transform" {
            return Err(n
                .at
                .error(format!("expected <transform name=\"{name}\">, found <{}>", n.tag)));
        }
        Ok((super::transform::parse(n)?, Some(n)))
    }

    /// A colour: `<rgb>`, `<spectrum>`, `<float>` or a texture. `emitter`
    /// says whether an emitter reads it (Mitsuba converts spectra
    /// differently for emitters and for reflectances).
    pub fn color(&self, name: &str, emitter: bool) -> Result<Option<ColorParam<'d>>> {
        if let Some(t) = self.named_texture(name)? {
            return Ok(Some(ColorParam::Texture(t)));
        }
        let Some(n) = self.value(name) else {
            return Ok(None);
        };
        Ok(Some(ColorParam::Rgb(color_value(self.ctx, n, emitter)?)))
    }

    /// Every child not read: an unknown parameter or object.
    pub fn finish(self) -> Result<()> {
        let plugin = self.node.attr("type").unwrap_or("");
        for (c, used) in self.node.children.iter().zip(&self.used) {
            if !used.get() {
                let what = match c.attr("name") {
                    Some(n) => format!("unknown parameter \"{n}\" (<{}>)", c.tag),
                    None => format!("unexpected <{}>", c.tag),
                };
                self.ctx
                    .unknown(&c.at, format!("{what} of <{} type=\"{plugin}\">", self.node.tag))?;
            }
        }
        Ok(())
    }
}

/// A colour value element (`rgb`, `spectrum`, `float`, `integer`) as linear RGB.
pub fn color_value(ctx: &Ctx<'_>, n: &Node, emitter: bool) -> Result<[f64; 3]> {
    match n.tag.as_str() {
        "rgb" => {
            let v = numbers(n, n.need("value")?)?;
            match v[..] {
                [g] => Ok([g, g, g]),
                [r, g, b] => Ok([r, g, b]),
                _ => Err(n.at.error("expected one or three numbers")),
            }
        }
        "float" | "integer" => {
            let g = number(n, n.need("value")?)?;
            Ok([g, g, g])
        }
        "spectrum" => {
            let pairs = if let Some(f) = n.attr("filename") {
                let path = ctx.doc.resolve(f);
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| n.at.error(format!("{}: {e}", path.display())))?;
                spectra::parse_file(&text).map_err(|e| n.at.error(format!("{}: {e}", path.display())))?
            } else {
                spectra::parse_value(n.need("value")?).map_err(|e| n.at.error(e))?
            };
            Ok(spectra::to_rgb(&pairs, emitter))
        }
        t => Err(n
            .at
            .error(format!("expected <rgb>, <spectrum> or <float>, found <{t}>"))),
    }
}
