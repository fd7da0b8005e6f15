//! The architecture, as a test: which top-level module of `src/` may use
//! which. Reads the sources, collects every `crate::…` path (in `use` and in
//! code; comments are skipped, so doc links do not count) and `super::…`
//! from a module's root file, and fails on any use of a module that is not in
//! a strictly lower layer, which also rules out every cycle. A new module
//! must be given a layer here. Within each module the same check runs over
//! its files (no circle between sibling files either).
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

/// The source without comments (line comments, doc comments, block
/// comments), without the contents of string literals, and without inline
/// `#[cfg(test)] mod … { … }` blocks (tests may use whatever they test with).
fn code_only(src: &str) -> String {
    strip_test_modules(&strip_comments(src))
}

fn strip_test_modules(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(k) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..k]);
        let after = &rest[k + "#[cfg(test)]".len()..];
        let t = after.trim_start();
        if let Some(m) = t.strip_prefix("mod ") {
            let open = m.find(['{', ';']).unwrap_or(m.len());
            if m[open..].starts_with('{') {
                let mut depth = 0;
                let mut end = m.len();
                for (j, c) in m[open..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = open + j + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                rest = &m[end..];
                continue;
            }
        }
        rest = after;
    }
    out.push_str(rest);
    out
}

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

fn ident_at(s: &str) -> &str {
    let end = s
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    &s[..end]
}

/// First path segments named after every `prefix` in `code`, with
/// `prefix{a, b::c}` groups expanded.
fn uses_after(code: &str, prefix: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(k) = rest.find(prefix) {
        let before = rest[..k].chars().last();
        rest = &rest[k + prefix.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue; // `foo_crate::x`, `a::crate::x`: not ours
        }
        if let Some(group) = rest.strip_prefix('{') {
            // Top-level items of a (possibly nested) brace group.
            let (mut depth, mut item_start, mut end) = (0, true, group.len());
            for (j, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        end = j;
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => item_start = true,
                    c if item_start && !c.is_whitespace() => {
                        item_start = false;
                        let id = ident_at(&group[j..]);
                        if !id.is_empty() {
                            out.insert(id.to_string());
                        }
                    }
                    _ => {}
                }
            }
            rest = &group[end..];
        } else {
            let id = ident_at(rest);
            if !id.is_empty() {
                out.insert(id.to_string());
            }
        }
    }
    out
}

/// Top-level module of a file under src/, and whether the file is that
/// module's root (where `super::` is the crate root).
fn module_of(src: &Path, file: &Path) -> Option<(String, bool)> {
    let rel = file.strip_prefix(src).ok()?;
    let parts: Vec<String> = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
    match parts.as_slice() {
        [f] if f == "lib.rs" => None,
        // The `snell` binary: its own crate, which sees the library only as `snell::`.
        [d, ..] if d == "bin" => None,
        [f] => Some((f.trim_end_matches(".rs").to_string(), true)),
        [d, f] => Some((d.clone(), f == "mod.rs")),
        [d, ..] => Some((d.clone(), false)),
        [] => None,
    }
}

/// Which top-level module uses which.
fn module_graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut all = Vec::new();
    files(&src, &mut all);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in all {
        let Some((m, root)) = module_of(&src, &f) else {
            continue;
        };
        let code = code_only(&std::fs::read_to_string(&f).unwrap());
        let mut used = uses_after(&code, "crate::");
        if root {
            used.extend(uses_after(&code, "super::"));
        }
        let e = g.entry(m.clone()).or_default();
        e.extend(used.into_iter().filter(|u| *u != m));
    }
    g
}

/// Every use against `layers` in the graph of `src/`.
fn violations(layers: &[&[&str]]) -> Vec<String> {
    let g = module_graph();
    let mut wrong = Vec::new();
    for (m, uses) in &g {
        let Some(lm) = layer_of(layers, m) else {
            wrong.push(format!("{m}: not in LAYERS (give it a layer)"));
            continue;
        };
        for u in uses {
            match layer_of(layers, u) {
                None if g.contains_key(u) => wrong.push(format!("{u}: not in LAYERS")),
                None => {} // not a module of ours (e.g. `crate::Result` re-exports)
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
fn no_circle_between_the_files_of_a_module() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut wrong = Vec::new();
    for e in std::fs::read_dir(&src).unwrap() {
        let dir = e.unwrap().path();
        if !dir.is_dir() {
            continue;
        }
        let module = dir.file_name().unwrap().to_string_lossy().into_owned();
        // Sibling files (not mod.rs) and which siblings each one uses.
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for f in std::fs::read_dir(&dir).unwrap() {
            let p = f.unwrap().path();
            if p.extension().is_none_or(|x| x != "rs") || p.ends_with("mod.rs") {
                continue;
            }
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            let code = code_only(&std::fs::read_to_string(&p).unwrap());
            let mut used = uses_after(&code, "super::");
            used.extend(uses_after(&code, &format!("crate::{module}::")));
            g.insert(name, used);
        }
        let names: BTreeSet<String> = g.keys().cloned().collect();
        for v in g.values_mut() {
            v.retain(|u| names.contains(u));
        }
        // Depth-first search for a back edge.
        fn visit(
            n: &str,
            g: &BTreeMap<String, BTreeSet<String>>,
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
            for u in &g[n] {
                if u != n {
                    if let Some(c) = visit(u, g, state, path) {
                        return Some(c);
                    }
                }
            }
            path.pop();
            state.insert(n.to_string(), 2);
            None
        }
        let mut state = BTreeMap::new();
        for n in g.keys() {
            if let Some(c) = visit(n, &g, &mut state, &mut Vec::new()) {
                wrong.push(format!("{module}: {}", c.join(" -> ")));
                break;
            }
        }
    }
    assert!(wrong.is_empty(), "circles between files:\n{}", wrong.join("\n"));
}

#[test]
fn the_parser_sees_groups_paths_and_not_comments() {
    let code = code_only(
        "use crate::{a::X, b, c::{d, e}};\n// crate::commented\n/// [`crate::doc_link`]\nlet s = \"crate::in_a_string\";\nlet y = crate::f::g(1);\nlet z = other_crate::h;\n",
    );
    let got: Vec<String> = uses_after(&code, "crate::").into_iter().collect();
    assert_eq!(got, vec!["a", "b", "c", "f"]);
    let code = code_only("use crate::kept;\n#[cfg(test)]\nmod tests {\n    use crate::only_in_tests;\n    fn f() { if x { crate::nested::y(); } }\n}\nuse crate::after;\n");
    let got: Vec<String> = uses_after(&code, "crate::").into_iter().collect();
    assert_eq!(got, vec!["after", "kept"]);
}
