//! The architecture, as a test: which top-level module of `src/` may use
//! which, and no circle between the rooms of any module.
//!
//! Reads the sources (comments and string literals skipped, so doc links do
//! not count; `#[cfg(test)]` code counts like any other) and resolves every
//! path that starts with `crate::`, `super::` or `self::`, and every `use`,
//! to the module it names, following `super::` out of inline modules and a
//! module's re-exports (`pub use room::Item` in a `mod.rs`, or a glob
//! `pub use room::*` through the `pub` items the room's file defines) to the
//! room that defines the item; a glob import (`use crate::a::b::*`) is a use
//! of the module it names. (A glob of an ancestor, `use super::*`, is not
//! followed to the items it brings in.) Then:
//! - a top-level module may use only modules of strictly lower layers (which
//!   also rules out every cycle between them); a new module must be given a
//!   layer here;
//! - at every folder level, the rooms of one module (its files and
//!   subfolders, not its `mod.rs`, which holds them together) form no
//!   circle.
//!
//! (`cargo modules … --acyclic` reports every type and its own methods as a
//! cycle, so it cannot be used for this.)
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Bottom to top. A module may use only modules of lower layers.
const LAYERS: &[&[&str]] = &[
    // Leaves: rays and hits, the physics of one interface, random numbers,
    // provenance lines, event counters, vectors of SIMD lanes.
    &["ray", "optics", "sampling", "provenance", "counters", "simd3"],
    // The one FFI module.
    &["embree"],
    // Errors; the benchmarks' clocks and medians (over the FFI module's binding).
    &["error", "timing"],
    // Pure models and solvers with no scene: the camera, gradient-index
    // media, the warp solvers (plate, tube, the paper's approximation),
    // exact per-pixel sums, the microfacet BSDFs.
    &["camera", "media", "warp", "accum", "bsdf"],
    // The scene model and its builder.
    &["scene"],
    // The nested rule; image files.
    &["dielectric", "image_io"],
    &["integrator"],
    // Renders, the audit of interior lists, the fan of curved rays.
    &["render", "audit", "grin_fan"],
    // What drives renders: parts, overrides, benchmarks, the warp renderer.
    &["part", "overrides", "bench", "ceiling", "warp_render"],
    &["merge", "farm", "fuzz"],
    // The importers' fuzzer (it reuses the scene fuzzer's mutations).
    &["fuzz_import"],
    &["report"],
];

fn layer_of(layers: &[&[&str]], m: &str) -> Option<usize> {
    layers.iter().position(|l| l.contains(&m))
}

/// A module path from the crate root, `["scene", "shapes", "set"]`.
type ModPath = Vec<String>;

/// Every `.rs` file under `dir`.
fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module a file under `src` holds (`lib.rs`: the root; `x/mod.rs`:
/// `x`); None for the binaries, which see the library only as `snell::`.
fn module_of(src: &Path, file: &Path) -> Option<ModPath> {
    let rel = file.strip_prefix(src).ok()?;
    let mut parts: Vec<String> = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
    if parts.first().is_some_and(|d| d == "bin") || parts == ["main.rs"] {
        return None;
    }
    let last = parts.pop()?;
    match last.as_str() {
        "lib.rs" if parts.is_empty() => {}
        "mod.rs" => {}
        f => parts.push(f.trim_end_matches(".rs").to_string()),
    }
    Some(parts)
}

/// The source without comments (line comments, doc comments, block
/// comments) and without the contents of string literals.
fn strip_comments(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let mut depth = 0;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    depth += 1;
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if b[i] == b'"' && (i == 0 || b[i - 1] != b'\'') {
            // A string literal (raw strings with # are not used in paths).
            let raw = i > 0 && b[i - 1] == b'r';
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' && !raw {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// A path as written where it is used: its segments (`crate`, `super`,
/// `self` included), the name it is known by (its last segment, or the
/// alias after `as`), whether it sits in a `use`, and the inline modules
/// (`mod tests { … }`) around it.
#[derive(Debug, Clone, PartialEq)]
struct Written {
    segs: Vec<String>,
    name: String,
    in_use: bool,
    inline: Vec<String>,
}

/// A path tree at `i` (`a::b`, `a::{b, c::d as e}`, `a::*`): every path
/// it expands to, each with its name (`*` for a glob's module), appended
/// to `prefix`; returns the position after the tree.
fn path_tree(b: &[u8], mut i: usize, prefix: &[String], out: &mut Vec<(Vec<String>, String)>) -> usize {
    let skip_ws = |mut i: usize| {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        i
    };
    let mut segs = prefix.to_vec();
    loop {
        i = skip_ws(i);
        if i < b.len() && b[i] == b'{' {
            i += 1;
            loop {
                i = skip_ws(i);
                if i >= b.len() || b[i] == b'}' {
                    return i + 1;
                }
                if b[i] == b',' {
                    i += 1;
                    continue;
                }
                let before = i;
                i = path_tree(b, i, &segs, out);
                if i == before {
                    i += 1; // not a path: step over it
                }
            }
        }
        if i < b.len() && b[i] == b'*' {
            // A glob: a use of the module it names, known by the name `*`.
            if !segs.is_empty() {
                out.push((segs, "*".to_string()));
            }
            return i + 1;
        }
        let s = i;
        while i < b.len() && is_ident(b[i]) {
            i += 1;
        }
        if s == i {
            return i;
        }
        segs.push(String::from_utf8_lossy(&b[s..i]).into_owned());
        let j = skip_ws(i);
        if b[j..].starts_with(b"::") {
            i = j + 2;
            continue;
        }
        let mut name = segs.last().unwrap().clone();
        if b[j..].starts_with(b"as") && b.get(j + 2).is_some_and(|c| c.is_ascii_whitespace()) {
            let k = skip_ws(j + 2);
            let mut e = k;
            while e < b.len() && is_ident(b[e]) {
                e += 1;
            }
            name = String::from_utf8_lossy(&b[k..e]).into_owned();
            i = e;
        }
        out.push((segs, name));
        return i;
    }
}

/// Every path of `code` (comments stripped) that starts with `crate::`,
/// `super::` or `self::`, and every path of a `use`.
fn written_paths(code: &str) -> Vec<Written> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    // Inline modules open around the cursor, with the depth inside each.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut pending_mod: Option<String> = None;
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c == b'{' {
            depth += 1;
            if let Some(m) = pending_mod.take() {
                inline.push((m, depth));
            }
            i += 1;
            continue;
        }
        if c == b'}' {
            if inline.last().is_some_and(|(_, d)| *d == depth) {
                inline.pop();
            }
            depth = depth.saturating_sub(1);
            i += 1;
            continue;
        }
        if c == b';' {
            pending_mod = None;
        }
        if !is_ident(c) || (i > 0 && (is_ident(b[i - 1]) || b[i - 1] == b':')) {
            i += 1;
            continue;
        }
        let s = i;
        while i < b.len() && is_ident(b[i]) {
            i += 1;
        }
        let word = &code[s..i];
        let names: Vec<String> = inline.iter().map(|(m, _)| m.clone()).collect();
        match word {
            "mod" => {
                let mut j = i;
                while j < b.len() && b[j].is_ascii_whitespace() {
                    j += 1;
                }
                let k = j;
                while j < b.len() && is_ident(b[j]) {
                    j += 1;
                }
                pending_mod = (j > k).then(|| code[k..j].to_string());
                i = j;
            }
            "use" => {
                let mut paths = Vec::new();
                i = path_tree(b, i, &[], &mut paths);
                for (segs, name) in paths {
                    out.push(Written {
                        segs,
                        name,
                        in_use: true,
                        inline: names.clone(),
                    });
                }
            }
            "crate" | "super" | "self" if b[i..].starts_with(b"::") => {
                let mut paths = Vec::new();
                i = path_tree(b, s, &[], &mut paths);
                for (segs, name) in paths {
                    out.push(Written {
                        segs,
                        name,
                        in_use: false,
                        inline: names.clone(),
                    });
                }
            }
            _ => {}
        }
    }
    out
}

/// The names of the `pub` items (`pub(crate)`, `pub(super)` too) `code`
/// defines: what a glob re-export of its module makes visible.
fn pub_items(code: &str) -> BTreeSet<String> {
    let b = code.as_bytes();
    let mut out = BTreeSet::new();
    // The next word after `i` (skipping spaces, `""` and `(…)`), and where it ends.
    let word = |mut i: usize| {
        loop {
            while i < b.len() && (b[i].is_ascii_whitespace() || b[i] == b'"') {
                i += 1;
            }
            if i < b.len() && b[i] == b'(' {
                while i < b.len() && b[i] != b')' {
                    i += 1;
                }
                i += 1;
                continue;
            }
            break;
        }
        let s = i;
        while i < b.len() && is_ident(b[i]) {
            i += 1;
        }
        (&code[s..i], i)
    };
    let mut i = 0;
    while i < b.len() {
        if !(b[i..].starts_with(b"pub") && (i == 0 || !is_ident(b[i - 1])))
            || b.get(i + 3).is_some_and(|&c| is_ident(c))
        {
            i += 1;
            continue;
        }
        let (mut w, mut j) = word(i + 3);
        loop {
            let (next, k) = word(j);
            match w {
                "unsafe" | "async" | "extern" | "mut" => {}
                "const" if matches!(next, "fn" | "unsafe" | "async" | "extern") => {}
                "fn" | "struct" | "enum" | "trait" | "type" | "const" | "static" | "mod" | "union" => {
                    let name = if next == "mut" { word(k).0 } else { next };
                    if !name.is_empty() {
                        out.insert(name.to_string());
                    }
                    break;
                }
                _ => break,
            }
            (w, j) = (next, k);
        }
        i = j.max(i + 3);
    }
    out
}

/// `segs` as a path from the crate root, written in module `at`; None for
/// a path that leaves the crate (an extern crate's, or too many `super`s).
fn resolve(at: &[String], segs: &[String], in_use: bool) -> Option<ModPath> {
    let mut cur: ModPath = at.to_vec();
    let mut rest = segs;
    match segs.first().map(String::as_str) {
        Some("crate") => {
            cur.clear();
            rest = &segs[1..];
        }
        Some("super" | "self") => {}
        // A bare path: in a `use`, relative to the module (or an extern crate).
        Some(_) if in_use => {}
        _ => return None,
    }
    for s in rest {
        match s.as_str() {
            "super" => {
                cur.pop()?;
            }
            "self" => {}
            _ => cur.push(s.clone()),
        }
    }
    Some(cur)
}

/// The sources of a crate: for each file its module and its paths.
struct Crate {
    files: Vec<(PathBuf, ModPath, Vec<Written>)>,
    /// Every module that is a file or a folder.
    modules: BTreeSet<ModPath>,
    /// Re-exports: in module `P`, the name `n` is the room `r` of `P`'s.
    reexports: BTreeMap<(ModPath, String), String>,
    /// Glob re-exports (`pub use room::*`): the rooms of `P`'s whose items
    /// `P` shows.
    globs: BTreeMap<ModPath, BTreeSet<String>>,
    /// The `pub` items each module's file defines.
    items: BTreeMap<ModPath, BTreeSet<String>>,
}

impl Crate {
    fn read(src: &Path) -> Crate {
        let mut all = Vec::new();
        files(src, &mut all);
        all.sort();
        let mut files_ = Vec::new();
        let mut modules = BTreeSet::new();
        let mut items = BTreeMap::new();
        for f in all {
            let Some(m) = module_of(src, &f) else { continue };
            let code = strip_comments(&std::fs::read_to_string(&f).unwrap());
            for k in 0..=m.len() {
                modules.insert(m[..k].to_vec());
            }
            items.insert(m.clone(), pub_items(&code));
            files_.push((f, m, written_paths(&code)));
        }
        let mut reexports = BTreeMap::new();
        let mut globs: BTreeMap<ModPath, BTreeSet<String>> = BTreeMap::new();
        for (_, m, paths) in &files_ {
            for w in paths.iter().filter(|w| w.in_use && w.inline.is_empty()) {
                let Some(t) = resolve(m, &w.segs, true) else {
                    continue;
                };
                let below = t.len() > m.len() && t.starts_with(m) && modules.contains(&t[..m.len() + 1]);
                if below && w.name == "*" {
                    globs.entry(m.clone()).or_default().insert(t[m.len()].clone());
                } else if below && t.len() > m.len() + 1 {
                    reexports.insert((m.clone(), w.name.clone()), t[m.len()].clone());
                }
            }
        }
        Crate {
            files: files_,
            modules,
            reexports,
            globs,
            items,
        }
    }

    /// The room of module `p` that `name` (a path segment after `p`) is in:
    /// a room's own name, or an item `p` re-exports from a room, by name
    /// or by a glob.
    fn room(&self, p: &[String], name: &str) -> Option<String> {
        let mut q = p.to_vec();
        q.push(name.to_string());
        if self.modules.contains(&q) {
            return Some(name.to_string());
        }
        if let Some(r) = self.reexports.get(&(p.to_vec(), name.to_string())) {
            return Some(r.clone());
        }
        self.globs.get(p)?.iter().find_map(|r| {
            let mut q = p.to_vec();
            q.push(r.clone());
            self.items.get(&q)?.contains(name).then(|| r.clone())
        })
    }

    /// Every use of one room by another: (the module whose rooms they are,
    /// user, used, the file that uses).
    fn edges(&self) -> BTreeSet<(ModPath, String, String, PathBuf)> {
        let mut out = BTreeSet::new();
        for (f, m, paths) in &self.files {
            for w in paths {
                let at: ModPath = m.iter().chain(&w.inline).cloned().collect();
                let Some(t) = resolve(&at, &w.segs, w.in_use) else {
                    continue;
                };
                let k = m.iter().zip(&t).take_while(|(a, b)| a == b).count();
                if k == m.len() || k == t.len() {
                    continue; // the module's own file, or an ancestor's item
                }
                let p = m[..k].to_vec();
                if let Some(used) = self.room(&p, &t[k]) {
                    if used != m[k] {
                        out.insert((p, m[k].clone(), used, f.clone()));
                    }
                }
            }
        }
        out
    }
}

/// Which top-level module uses which (every top-level module a key).
fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let c = Crate::read(src);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for m in c.modules.iter().filter(|m| m.len() == 1) {
        g.entry(m[0].clone()).or_default();
    }
    for (p, user, used, _) in c.edges() {
        if p.is_empty() {
            g.entry(user).or_default().insert(used);
        }
    }
    g
}

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every use against `layers` in the graph of `src/`.
fn violations(layers: &[&[&str]]) -> Vec<String> {
    let g = module_graph(&src_dir());
    let mut wrong = Vec::new();
    for (m, uses) in &g {
        let Some(lm) = layer_of(layers, m) else {
            wrong.push(format!("{m}: not in LAYERS (give it a layer)"));
            continue;
        };
        for u in uses {
            match layer_of(layers, u) {
                None => wrong.push(format!("{u}: not in LAYERS")),
                Some(lu) if lu >= lm => wrong.push(format!(
                    "{m} (layer {lm}) uses {u} (layer {lu}): only lower layers may be used"
                )),
                Some(_) => {}
            }
        }
    }
    wrong.sort();
    wrong.dedup();
    wrong
}

/// The circles between the rooms of every module of the crate at `src`,
/// one per module that has any, with the files that make each step.
fn circles(src: &Path) -> Vec<String> {
    let c = Crate::read(src);
    let mut levels: BTreeMap<ModPath, BTreeMap<String, BTreeMap<String, PathBuf>>> = BTreeMap::new();
    for (p, user, used, file) in c.edges() {
        levels
            .entry(p)
            .or_default()
            .entry(user)
            .or_default()
            .entry(used)
            .or_insert(file);
    }
    // Depth-first search for a back edge.
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeMap<String, PathBuf>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(1) => {
                let k = path.iter().position(|p| p == n).unwrap();
                let mut c = path[k..].to_vec();
                c.push(n.to_string());
                return Some(c);
            }
            Some(_) => return None,
            None => {}
        }
        state.insert(n.to_string(), 1);
        path.push(n.to_string());
        for u in g.get(n).into_iter().flat_map(|m| m.keys()) {
            if let Some(c) = visit(u, g, state, path) {
                return Some(c);
            }
        }
        path.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut wrong = Vec::new();
    for (p, g) in &levels {
        let mut state = BTreeMap::new();
        for n in g.keys() {
            if let Some(cycle) = visit(n, g, &mut state, &mut Vec::new()) {
                let module = if p.is_empty() {
                    "crate".to_string()
                } else {
                    p.join("::")
                };
                let steps: Vec<String> = cycle
                    .windows(2)
                    .map(|w| {
                        let f = &g[&w[0]][&w[1]];
                        let f = f.strip_prefix(src).unwrap_or(f).display();
                        format!("{} -> {} ({f})", w[0], w[1])
                    })
                    .collect();
                wrong.push(format!("{module}: {}", steps.join(", ")));
                break;
            }
        }
    }
    wrong
}

#[test]
fn every_module_uses_only_lower_layers() {
    let wrong = violations(LAYERS);
    assert!(wrong.is_empty(), "layering violations:\n{}", wrong.join("\n"));
}

/// The check has power: with the nested rule put above the integrator, the
/// integrator's use of it is reported.
#[test]
fn a_wrong_order_is_caught() {
    let mut swapped: Vec<&[&str]> = LAYERS.to_vec();
    let d = swapped.iter().position(|l| l.contains(&"dielectric")).unwrap();
    let i = swapped.iter().position(|l| l.contains(&"integrator")).unwrap();
    swapped.swap(d, i);
    let wrong = violations(&swapped);
    assert!(
        wrong
            .iter()
            .any(|w| w.starts_with("integrator") && w.contains("uses dielectric")),
        "{wrong:?}"
    );
}

#[test]
fn no_circle_between_the_rooms_of_any_module() {
    let wrong = circles(&src_dir());
    assert!(wrong.is_empty(), "circles between rooms:\n{}", wrong.join("\n"));
}

/// A crate written out for the check: `files` as (path under src, text).
fn synthetic(name: &str, files: &[(&str, &str)]) -> PathBuf {
    let src = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name).join("src");
    let _ = std::fs::remove_dir_all(&src);
    for (p, text) in files {
        let p = src.join(p);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    src
}

/// The circle check has power at every depth: a circle made through a
/// re-export and a test module's `super::super::`, one between two
/// folders' files through `crate::` paths, and one through globs (a glob
/// import, and an item a glob re-export shows) are each reported; without
/// their back edges there is none.
#[test]
fn circles_are_caught_at_every_depth() {
    let lib = ("lib.rs", "mod a;\nmod b;\nmod c;\n");
    let a = [
        ("a/mod.rs", "mod x;\nmod y;\npub use y::Thing;\n"),
        ("a/x.rs", "use super::Thing;\npub fn f() -> Thing { Thing }\n"),
    ];
    let b = [
        ("b/mod.rs", "mod p;\nmod q;\n"),
        ("b/p/mod.rs", "mod deep;\n"),
        ("b/p/deep.rs", "pub fn g() { crate::b::q::leaf::h() }\n"),
        ("b/q/mod.rs", "pub mod leaf;\n"),
    ];
    let c = [
        ("c/mod.rs", "mod s;\nmod t;\npub use s::*;\n"),
        ("c/t.rs", "use super::S;\npub fn t() -> S { S }\n"),
    ];
    let s_back = ("c/s.rs", "use super::t::*;\npub struct S;\n");
    let y_back = (
        "a/y.rs",
        "pub struct Thing;\n#[cfg(test)]\nmod tests {\n    use super::super::x::f;\n}\n",
    );
    let leaf_back = (
        "b/q/leaf.rs",
        "// crate::b::p::deep::g() in a comment\npub fn h() { let _ = crate::b::p::deep::g; }\n",
    );
    let mut files: Vec<(&str, &str)> = vec![lib];
    files.extend(a);
    files.extend(b);
    files.extend(c);
    files.extend([y_back, leaf_back, s_back]);
    let wrong = circles(&synthetic("layering_circles", &files));
    assert_eq!(wrong.len(), 3, "{wrong:?}");
    assert!(
        wrong[0].starts_with("a: x -> y (a/x.rs), y -> x (a/y.rs)"),
        "{wrong:?}"
    );
    assert!(
        wrong[1].starts_with("b: p -> q (b/p/deep.rs), q -> p (b/q/leaf.rs)"),
        "{wrong:?}"
    );
    assert!(
        wrong[2].starts_with("c: s -> t (c/s.rs), t -> s (c/t.rs)"),
        "{wrong:?}"
    );
    // The same crate without the back edges (the comment does not count).
    let y = ("a/y.rs", "pub struct Thing;\n");
    let leaf = (
        "b/q/leaf.rs",
        "// crate::b::p::deep::g() in a comment\npub fn h() {}\n",
    );
    let mut files: Vec<(&str, &str)> = vec![lib];
    files.extend(a);
    files.extend(b);
    files.extend(c);
    files.extend([y, leaf, ("c/s.rs", "pub struct S;\n")]);
    assert_eq!(
        circles(&synthetic("layering_no_circles", &files)),
        Vec::<String>::new()
    );
}

#[test]
fn the_parser_sees_groups_paths_and_not_comments() {
    let code = strip_comments(
        "use crate::{a::X, b, c::{d, e as f}};\n// crate::commented\n/// [`crate::doc_link`]\nlet s = \"crate::in_a_string\";\nlet y = crate::g::h(1);\nlet z = other_crate::i;\nuse super::j::*;\n",
    );
    let got: Vec<(Vec<String>, String)> = written_paths(&code)
        .into_iter()
        .map(|w| (w.segs, w.name))
        .collect();
    let p = |s: &str, n: &str| (s.split("::").map(String::from).collect::<Vec<_>>(), n.to_string());
    assert_eq!(
        got,
        vec![
            p("crate::a::X", "X"),
            p("crate::b", "b"),
            p("crate::c::d", "d"),
            p("crate::c::e", "f"),
            p("crate::g::h", "h"),
            p("super::j", "*"),
        ]
    );
    // The items a glob re-export shows.
    let items = pub_items(&strip_comments(
        "pub struct A;\npub(crate) fn b() {}\npub const fn c() {}\npub const D: u8 = 1;\npub static mut E: u8 = 0;\npub unsafe extern \"C\" fn f() {}\nfn private() {}\npub use x::Y;\npub(super) mod g;\nlet public = 1;\n",
    ));
    let want: BTreeSet<String> = ["A", "b", "c", "D", "E", "f", "g"].map(String::from).into();
    assert_eq!(items, want);
    // Test modules count, and `super::` inside them starts from them.
    let code = strip_comments("use crate::kept;\n#[cfg(test)]\nmod tests {\n    use super::super::up;\n    fn f() { if x { crate::nested::y(); } }\n}\nuse crate::after;\n");
    let w = written_paths(&code);
    let at = |k: usize| {
        resolve(
            &["m".to_string()]
                .iter()
                .chain(&w[k].inline)
                .cloned()
                .collect::<Vec<_>>(),
            &w[k].segs,
            w[k].in_use,
        )
        .unwrap()
    };
    let got: Vec<String> = (0..w.len()).map(|k| at(k).join("::")).collect();
    assert_eq!(got, vec!["kept", "up", "nested::y", "after"]);
}
