//! A mutation fuzzer for scene files on stable Rust: byte-level and
//! token-level mutations of the shipped scenes and OBJ files. Every case must
//! end in a built scene (rendered at a tiny size) or a clear error; a panic, a
//! non-located scene error or a case slower than the limit is a finding.
//! `snell fuzz --cases N` runs it; `tests/fuzz_smoke.rs` runs a few thousand.
use crate::render::{render, RenderOptions, RenderSettings};
use crate::sampling::Rng;
use crate::scene::{load_scene_str, BuildOptions};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::time::{Duration, Instant};

/// Does an input error point at a line that cannot hold its key? The line
/// must contain the key's last name (`objects[2].material.ior` → `ior`), or,
/// for a key ending in an index or naming a whole table (`objects[2]`,
/// `objects[2].shape`), the parent's name or a table header. Errors about the
/// whole document and keys the file never wrote (a missing key, reported at
/// its table) are not judged by the name, only by being a real line.
pub fn mislocated(text: &str, key: &str, line: usize) -> bool {
    let lines: Vec<&str> = text.lines().collect();
    if key.is_empty() || key.starts_with('(') {
        return false;
    }
    let Some(l) = line.checked_sub(1).and_then(|i| lines.get(i)) else {
        return line > lines.len() + 1;
    };
    // Line 1 is where a key the document never wrote is reported; an empty
    // key name (`"" = 1`) has no name to look for.
    if line == 1 || key.ends_with('.') {
        return false;
    }
    let names: Vec<&str> = key
        .split('.')
        .map(|seg| seg.split('[').next().unwrap_or(""))
        .filter(|n| !n.is_empty())
        .collect();
    let Some(last) = names.last() else { return false };
    // A key inside the i-th [[objects]] / [[lights]] must point into that block.
    let first = key.split('.').next().unwrap_or("");
    if let Some((table, idx)) = first.strip_suffix(']').and_then(|f| f.split_once('[')) {
        if let Ok(idx) = idx.parse::<usize>() {
            let header = format!("[[{table}]]");
            let starts: Vec<usize> = lines
                .iter()
                .enumerate()
                .filter(|(_, t)| t.trim() == header)
                .map(|(i, _)| i)
                .collect();
            if let Some(&s0) = starts.get(idx) {
                let end = lines
                    .iter()
                    .enumerate()
                    .skip(s0 + 1)
                    .find(|(_, t)| t.trim_start().starts_with('['))
                    .map(|(i, _)| i)
                    .unwrap_or(lines.len());
                if !(s0..end).contains(&(line - 1)) {
                    return true;
                }
            }
        }
    }
    if l.contains(last) {
        return false;
    }
    // The key was not written at all (a default or a missing key): its table's
    // header or inline table is the right place; any line mentioning a parent.
    let written = text.contains(last);
    if !written || l.trim_start().starts_with('[') || l.contains('{') {
        return false;
    }
    !names.iter().any(|n| l.contains(n))
}

/// Replacement tokens that probe numeric and structural edge cases.
const TOKENS: &[&str] = &[
    "-1",
    "0",
    "0.0",
    "-0.0",
    "1e300",
    "-1e300",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "1000000000",
    "18446744073709551615",
    "\"\"",
    "\"x\"",
    "[]",
    "[1]",
    "[1, 2]",
    "{}",
    "true",
    "[[1,2],[3]]",
    "\"sphere\"",
    "\"mesh\"",
    "\"dielectric\"",
    "999999999999",
    "0.5",
    "[0.0, 0.0, 0.0]",
    "[1e30, 1e30, 1e30]",
];

/// Outcome counts of a fuzz run.
#[derive(Debug, Clone, Default)]
pub struct FuzzReport {
    /// Cases run.
    pub cases: u64,
    /// Cases that built a scene and rendered it (at 4×3 pixels, 1 spp).
    pub rendered: u64,
    /// Cases refused with an error (located or not).
    pub errors: u64,
    /// Findings: cases that panicked, each `case i (name): message` with the document.
    pub panics: Vec<String>,
    /// Findings: errors that are not input errors, or input errors whose line
    /// does not hold their key ([`mislocated`]).
    pub unlocated_errors: Vec<String>,
    /// Findings: cases slower than the limit, with the document, and their seconds.
    pub slow: Vec<(String, f64)>,
    /// The slowest case: seconds and `case i (name)`.
    pub slowest: (f64, String),
}

/// Mutate `text` once, deterministically from `rng`.
pub fn mutate(text: &str, rng: &mut Rng) -> String {
    let bytes = text.as_bytes();
    let pick = |rng: &mut Rng, n: usize| if n == 0 { 0 } else { rng.next_u32() as usize % n };
    match rng.next_u32() % 6 {
        0 => {
            // Flip a byte.
            let mut b = bytes.to_vec();
            if !b.is_empty() {
                let i = pick(rng, b.len());
                b[i] ^= 1 << (rng.next_u32() % 7);
            }
            String::from_utf8_lossy(&b).into_owned()
        }
        1 => {
            // Replace a number or word token with an edge-case token.
            let spans: Vec<(usize, usize)> = token_spans(text);
            if spans.is_empty() {
                return text.to_string();
            }
            let (s, e) = spans[pick(rng, spans.len())];
            format!("{}{}{}", &text[..s], TOKENS[pick(rng, TOKENS.len())], &text[e..])
        }
        2 => {
            // Delete a line.
            let lines: Vec<&str> = text.lines().collect();
            let k = pick(rng, lines.len());
            lines
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != k)
                .map(|(_, l)| *l)
                .collect::<Vec<_>>()
                .join("\n")
        }
        3 => {
            // Duplicate a line.
            let lines: Vec<&str> = text.lines().collect();
            let k = pick(rng, lines.len());
            let mut out: Vec<&str> = lines.clone();
            if !lines.is_empty() {
                out.insert(k, lines[k]);
            }
            out.join("\n")
        }
        4 => {
            // Truncate.
            let mut k = pick(rng, text.len());
            while !text.is_char_boundary(k) {
                k -= 1;
            }
            text[..k].to_string()
        }
        _ => {
            // Rename a key.
            let spans = token_spans(text);
            if spans.is_empty() {
                return text.to_string();
            }
            let (s, e) = spans[pick(rng, spans.len())];
            format!("{}{}x{}", &text[..s], &text[s..e], &text[e..])
        }
    }
}

fn token_spans(text: &str) -> Vec<(usize, usize)> {
    let mut v = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_alphanumeric() || b[i] == b'-' || b[i] == b'.' || b[i] == b'_' {
            let s = i;
            while i < b.len()
                && (b[i].is_ascii_alphanumeric() || b[i] == b'-' || b[i] == b'.' || b[i] == b'_')
            {
                i += 1;
            }
            v.push((s, i));
        } else {
            i += 1;
        }
    }
    v
}

/// Run `cases` mutated scene documents (1–3 mutations each) of the seeds.
/// OBJ files in `scene_dir` are mutated too, written to a temporary directory
/// beside copies of the scenes that reference them.
///
/// Case i draws from `Rng::for_sample(seed, i, 0)`; a case slower than `limit`
/// is a finding. Panics of the cases are caught (the panic hook is silenced
/// meanwhile) and reported.
///
/// # Panics
///
/// If `seeds` is empty.
pub fn run(
    seeds: &[(String, String)],
    scene_dir: &Path,
    cases: u64,
    seed: u64,
    limit: Duration,
) -> FuzzReport {
    run_from(seeds, scene_dir, 0, cases, seed, limit)
}

/// `run` starting at case `first` (case i is the same document for any
/// `first`: reproduce a finding with `snell fuzz --first i --cases 1`).
///
/// # Panics
///
/// If `seeds` is empty.
pub fn run_from(
    seeds: &[(String, String)],
    scene_dir: &Path,
    first: u64,
    cases: u64,
    seed: u64,
    limit: Duration,
) -> FuzzReport {
    let mut rep = FuzzReport::default();
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    // OBJ seeds: every scene that loads meshes, with one of its OBJ files mutated
    // in a private directory (the other files copied beside it).
    let objs: Vec<(String, String)> = std::fs::read_dir(scene_dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "obj"))
                .filter_map(|p| {
                    let name = p.file_name()?.to_string_lossy().to_string();
                    std::fs::read_to_string(&p).ok().map(|t| (name, t))
                })
                .collect()
        })
        .unwrap_or_default();
    let mesh_scenes: Vec<&(String, String)> = seeds.iter().filter(|(_, t)| t.contains(".obj\"")).collect();
    let obj_dir = std::env::temp_dir().join(format!("snell-fuzz-{}-{seed}", std::process::id()));
    let have_obj_dir =
        !objs.is_empty() && !mesh_scenes.is_empty() && std::fs::create_dir_all(&obj_dir).is_ok();
    if have_obj_dir {
        for (n, t) in &objs {
            let _ = std::fs::write(obj_dir.join(n), t);
        }
    }
    for i in first..first.saturating_add(cases) {
        let mut rng = Rng::for_sample(seed, i, 0);
        let mutate_obj = have_obj_dir && rng.next_u32().is_multiple_of(4);
        let (name, base, dir, restore) = if mutate_obj {
            let (sname, stext) = mesh_scenes[(rng.next_u32() as usize) % mesh_scenes.len()];
            let (oname, otext) = &objs[(rng.next_u32() as usize) % objs.len()];
            let mut m = otext.clone();
            for _ in 0..1 + rng.next_u32() % 3 {
                m = mutate(&m, &mut rng);
            }
            let _ = std::fs::write(obj_dir.join(oname), m);
            (
                format!("{sname} with mutated {oname}"),
                stext.clone(),
                obj_dir.as_path(),
                Some((oname, otext)),
            )
        } else {
            let (name, base) = &seeds[(rng.next_u32() as usize) % seeds.len()];
            let mut text = base.clone();
            for _ in 0..1 + rng.next_u32() % 3 {
                text = mutate(&text, &mut rng);
            }
            (name.clone(), text, scene_dir, None)
        };
        let (name, text) = (&name, base);
        let t = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            match load_scene_str(name, &text, dir, &BuildOptions::default()) {
                Ok(s) => {
                    // Render tiny: the point is that it runs, not what it shows.
                    let (w, h) = (4.min(s.width), 3.min(s.height));
                    let Ok(set) = RenderSettings::from_scene(&s).with_resolution(w, h) else {
                        return Err("resolution".to_string());
                    };
                    render(
                        &s,
                        &set.with_spp(1),
                        &RenderOptions {
                            threads: Some(1),
                            want_aovs: false,
                            ..Default::default()
                        },
                    )
                    .map(|_| true)
                    .map_err(|e| e.to_string())
                }
                Err(crate::Error::Input { ref key, line, .. }) if mislocated(&text, key, line) => {
                    Err(format!(
                        "mislocated: the error names {key} but line {line} does not hold it: {:?}",
                        text.lines().nth(line.saturating_sub(1)).unwrap_or("")
                    ))
                }
                Err(crate::Error::Input { .. }) => Ok(false),
                Err(e) => Err(e.to_string()),
            }
        }));
        let el = t.elapsed().as_secs_f64();
        if let Some((oname, otext)) = restore {
            let _ = std::fs::write(obj_dir.join(oname), otext);
        }
        rep.cases += 1;
        if el > rep.slowest.0 {
            rep.slowest = (el, format!("case {i} ({name})"));
        }
        if el > limit.as_secs_f64() {
            rep.slow
                .push((format!("case {i} ({name})\n--- document ---\n{text}"), el));
        }
        match outcome {
            Ok(Ok(true)) => rep.rendered += 1,
            Ok(Ok(false)) => rep.errors += 1,
            Ok(Err(msg)) => {
                // Errors that are not located input errors (e.g. an Embree error).
                rep.errors += 1;
                rep.unlocated_errors.push(format!("case {i} ({name}): {msg}"));
            }
            Err(p) => {
                let msg = panic_message(p.as_ref());
                rep.panics
                    .push(format!("case {i} ({name}): {msg}\n--- document ---\n{text}"));
            }
        }
    }
    std::panic::set_hook(prev);
    if have_obj_dir {
        let _ = std::fs::remove_dir_all(&obj_dir);
    }
    rep
}

/// The shipped scenes as fuzz seeds (name, text).
pub fn shipped_scenes(dir: &Path) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "toml"))
                .filter_map(|p| {
                    std::fs::read_to_string(&p)
                        .ok()
                        .map(|t| (p.display().to_string(), t))
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// The text of a caught panic.
fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_default()
}

/// Which batch tool a JSON document is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JsonTool {
    /// `snell grin-trace` ([`crate::media::grin_trace_json`]).
    GrinTrace,
    /// `snell warp-points` (`warp::points::warp_points_json`).
    WarpPoints,
}

/// Outcomes of a JSON fuzz run, per tool.
#[derive(Debug, Clone, Default)]
pub struct JsonFuzzReport {
    /// Documents run.
    pub cases: u64,
    /// Documents answered (per-query statuses may still be errors).
    pub answered: u64,
    /// Queries or points inside answered documents whose status is an error.
    pub item_errors: u64,
    /// Documents refused as a whole, with a message naming the key or line.
    pub refused: u64,
    /// Findings: documents that panicked, `case i (name): message` with the document.
    pub panics: Vec<String>,
    /// Findings: refusals whose message names no key and no line.
    pub unlocated: Vec<String>,
    /// Findings: documents slower than the limit, with the document, and their seconds.
    pub slow: Vec<(String, f64)>,
    /// The slowest document: seconds and `case i (name)`.
    pub slowest: (f64, String),
}

/// Run `cases` mutated JSON documents (1–3 mutations each) through the
/// `grin-trace` and `warp-points` tools, in process, each with a time limit
/// (a case over `limit` is a finding: the tools bound their work up front).
pub fn run_json(
    seeds: &[(JsonTool, String, String)],
    cases: u64,
    seed: u64,
    limit: Duration,
) -> JsonFuzzReport {
    let mut rep = JsonFuzzReport::default();
    if seeds.is_empty() {
        return rep;
    }
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    for i in 0..cases {
        let mut rng = Rng::for_sample(seed ^ 0x4a53_4f4e, i, 0);
        let (tool, name, base) = &seeds[(rng.next_u32() as usize) % seeds.len()];
        let mut text = base.clone();
        if rng.next_u32().is_multiple_of(2) {
            // Structural: valid JSON with values replaced, keys dropped or added.
            if let Ok(mut v) = serde_json::from_str::<serde_json::Value>(&text) {
                for _ in 0..1 + rng.next_u32() % 3 {
                    mutate_json(&mut v, &mut rng);
                }
                text = v.to_string();
            }
        } else {
            for _ in 0..1 + rng.next_u32() % 3 {
                text = mutate(&text, &mut rng);
            }
        }
        let t = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| match tool {
            JsonTool::GrinTrace => crate::media::grin_trace_json(&text).map_err(|e| e.to_string()),
            JsonTool::WarpPoints => crate::warp::points::warp_points_json(name, &text),
        }));
        let el = t.elapsed().as_secs_f64();
        rep.cases += 1;
        let label = format!("case {i} ({name})");
        if el > rep.slowest.0 {
            rep.slowest = (el, label.clone());
        }
        if el > limit.as_secs_f64() {
            rep.slow.push((format!("{label}\n--- document ---\n{text}"), el));
        }
        match outcome {
            Ok(Ok(out)) => {
                rep.answered += 1;
                // Every status that is not "ok…" is an item error.
                let statuses = out.matches("\"status\": \"").count();
                let ok = out.matches("\"status\": \"ok").count();
                rep.item_errors += statuses.saturating_sub(ok) as u64;
            }
            Ok(Err(msg)) => {
                rep.refused += 1;
                // A whole-document error must say where: a key, or line and column.
                let located =
                    msg.contains(':') && (msg.contains("line") || msg.contains('.') || msg.contains('('));
                if !located {
                    rep.unlocated.push(format!("{label}: {msg}"));
                }
            }
            Err(p) => {
                let msg = panic_message(p.as_ref());
                rep.panics
                    .push(format!("{label}: {msg}\n--- document ---\n{text}"));
            }
        }
    }
    std::panic::set_hook(prev);
    rep
}

/// Replacement JSON values (numeric edge cases and wrong types).
fn json_token(rng: &mut Rng) -> serde_json::Value {
    use serde_json::json;
    let vals = [
        json!(0),
        json!(-1),
        json!(1e300),
        json!(-1e300),
        json!(1e-300),
        json!(1e-12),
        json!(4e9),
        json!(1e12),
        json!(0.5),
        json!(-0.0),
        json!("x"),
        json!(""),
        json!(null),
        json!(true),
        json!([]),
        json!([1]),
        json!([0, 0, 0]),
        json!([1e300, 0, 0]),
        json!({}),
        json!("rk45"),
        json!("paper"),
        json!("exact"),
        json!("euler"),
        json!("plate"),
        json!("hollow_cylinder"),
        json!(18446744073709551615u64),
    ];
    vals[(rng.next_u32() as usize) % vals.len()].clone()
}

/// One structural mutation of a JSON value: replace a random node, drop a
/// random key, add an unknown key, or duplicate an array element.
fn mutate_json(v: &mut serde_json::Value, rng: &mut Rng) {
    // Collect paths to every node (as JSON pointers).
    fn paths(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
        out.push(at.clone());
        match v {
            serde_json::Value::Object(m) => {
                for (k, c) in m {
                    paths(c, format!("{at}/{k}"), out);
                }
            }
            serde_json::Value::Array(a) => {
                for (i, c) in a.iter().enumerate() {
                    paths(c, format!("{at}/{i}"), out);
                }
            }
            _ => {}
        }
    }
    let mut all = Vec::new();
    paths(v, String::new(), &mut all);
    let at = all[(rng.next_u32() as usize) % all.len()].clone();
    let op = rng.next_u32() % 4;
    let tok = json_token(rng);
    let Some(node) = v.pointer_mut(&at) else { return };
    match (op, node) {
        (1, serde_json::Value::Object(m)) if !m.is_empty() => {
            let k = m
                .keys()
                .nth((rng.next_u32() as usize) % m.len())
                .cloned()
                .unwrap_or_default();
            m.remove(&k);
        }
        (2, serde_json::Value::Object(m)) => {
            m.insert("colour".into(), tok);
        }
        (3, serde_json::Value::Array(a)) if !a.is_empty() => {
            let x = a[(rng.next_u32() as usize) % a.len()].clone();
            for _ in 0..1 + rng.next_u32() % 50 {
                a.push(x.clone());
            }
        }
        (_, n) => *n = tok,
    }
}

/// The JSON seeds shipped in `dir` (tests/data/fuzz): files named `grin*.json`
/// are grin-trace documents, the others warp-points documents.
pub fn json_seeds(dir: &Path) -> Vec<(JsonTool, String, String)> {
    let mut v: Vec<(JsonTool, String, String)> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "json"))
                .filter_map(|p| {
                    let name = p.file_name()?.to_string_lossy().to_string();
                    let tool = if name.starts_with("grin") {
                        JsonTool::GrinTrace
                    } else {
                        JsonTool::WarpPoints
                    };
                    std::fs::read_to_string(&p)
                        .ok()
                        .map(|t| (tool, p.display().to_string(), t))
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort_by(|a, b| a.1.cmp(&b.1));
    v
}

#[cfg(test)]
mod tests {
    use super::mislocated;

    #[test]
    fn location_check_catches_lines_outside_the_keys_block() {
        let doc = "[film]\nwidth = 8\n[[objects]]\nname = \"a\"\n[[objects]]\nname = \"b\"\nshape = { type = \"sphere\" }\n[[objects]]\nname = \"a\"\n";
        // Right: the third object's name at line 9; a key at its own line.
        assert!(!mislocated(doc, "objects[2].name", 9));
        assert!(!mislocated(doc, "film.width", 2));
        assert!(!mislocated(doc, "objects[1].shape.radius", 7));
        assert!(!mislocated(doc, "(document)", 1));
        // Wrong: the third object's key at the second object's line (as when
        // a duplicate name is located at its first use), a key at a line that
        // holds another.
        assert!(mislocated(doc, "objects[2].name", 6));
        assert!(mislocated(doc, "film.width", 4));
        assert!(mislocated(doc, "film.width", 99));
    }
}
