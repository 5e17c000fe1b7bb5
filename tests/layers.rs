//! The core's imports run one way (docs/architecture.md, "Layers"): no file of `src/` imports,
//! through a `crate::` or `super::` path, from a file that imports it back (directly or through
//! others), and no file imports from a layer above its own. A module and its own submodules
//! count as one unit (a folder may re-export its children). Paths in comments and in
//! `#[cfg(test)] mod … { … }` blocks are not imports; test-only files (`tests.rs`, `tests/`)
//! are left out.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The layers, lowest first, by the first component of a module's path.
const LAYERS: [&[&str]; 7] = [
    &[
        "math", "lanes", "colour", "packed", "checksum", "prefetch", "limits", "error",
    ],
    &[
        "light",
        "bounds",
        "light_point",
        "brdf",
        "material",
        "infinite_light",
    ],
    &["build", "tree", "quantize"],
    &["importance"],
    &["sample", "cut", "trace"],
    &["infinite", "light_set"],
    &[
        "mis",
        "direct",
        "wavefront",
        "vpl",
        "baseline",
        "internals",
        "lib",
    ],
];

type Module = Vec<String>;

fn layer(m: &Module) -> usize {
    let top = m.first().map_or("lib", |s| s.as_str());
    LAYERS
        .iter()
        .position(|l| l.contains(&top))
        .unwrap_or_else(|| panic!("src/{}: in no layer of tests/layers.rs", m.join("/")))
}

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// `src/a/b.rs` and `src/a/b/mod.rs` are `[a, b]`; `src/lib.rs` is `[]`.
fn module_of(src: &Path, p: &Path) -> Module {
    let rel = p.strip_prefix(src).unwrap().with_extension("");
    let mut m: Module = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(m.last().map(String::as_str), Some("mod" | "lib")) {
        m.pop();
    }
    m
}

/// The source without comments and without `#[cfg(test)] mod name { … }` blocks.
fn code(src: &str) -> String {
    let no_comments: String = src
        .lines()
        .map(|l| l.find("//").map_or(l, |i| &l[..i]))
        .collect::<Vec<_>>()
        .join("\n");
    let mut s = no_comments;
    while let Some(start) = s.find("#[cfg(test)]") {
        let rest = &s[start..];
        let Some(brace) = rest.find('{') else { break };
        let semi = rest.find(';').unwrap_or(usize::MAX);
        if semi < brace || !rest[..brace].contains("mod ") {
            // `#[cfg(test)] mod tests;` or an attribute on something else: drop the marker.
            s.replace_range(start..start + "#[cfg(test)]".len(), "");
            continue;
        }
        let mut depth = 0usize;
        let mut end = start + brace;
        for (i, c) in s[start + brace..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = start + brace + i + 1;
                        break;
                    }
                }
                _ => {}
            }
        }
        s.replace_range(start..end, "");
    }
    s
}

/// The module paths a file names after `crate::` or `super::` (groups `{a, b::c}` expanded
/// one level).
fn paths(module: &Module, code: &str) -> Vec<Module> {
    let ident = |c: char| c.is_alphanumeric() || c == '_' || c == ':';
    let mut out = Vec::new();
    // `super` of `a/b.rs` and of `a/b/mod.rs` is `a`.
    let parent = module[..module.len().saturating_sub(1)].to_vec();
    for (prefix, base) in [("crate::", Vec::new()), ("super::", parent)] {
        let mut rest = code;
        while let Some(i) = rest.find(prefix) {
            let before = rest[..i].chars().last();
            rest = &rest[i + prefix.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
                continue;
            }
            let end = rest.find(|c: char| !ident(c)).unwrap_or(rest.len());
            let path = rest[..end].trim_end_matches(':');
            let mut head = base.clone();
            head.extend(path.split("::").filter(|s| !s.is_empty()).map(String::from));
            out.push(head.clone());
            if rest[end..].starts_with('{') {
                let close = rest[end..].find('}').map_or(rest.len(), |j| end + j);
                for item in rest[end + 1..close].split(',') {
                    let item = item.trim().trim_start_matches('{');
                    if item.is_empty() || item == "self" {
                        continue;
                    }
                    let mut m = head.clone();
                    m.extend(item.split("::").map(|s| s.trim().to_string()));
                    out.push(m);
                }
            }
        }
    }
    out
}

#[test]
fn core_imports_run_one_way() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut all = Vec::new();
    files(&src, &mut all);
    let mut text = BTreeMap::new();
    for p in &all {
        let m = module_of(&src, p);
        if m.iter().any(|c| c == "tests") {
            continue;
        }
        text.insert(m, fs::read_to_string(p).unwrap());
    }
    let known: BTreeSet<Module> = text.keys().cloned().collect();
    // The longest prefix of `path` that is a file's module.
    let resolve = |path: &Module| {
        (1..=path.len())
            .rev()
            .map(|n| path[..n].to_vec())
            .find(|m| known.contains(m))
    };
    let mut edges: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (m, src) in &text {
        let e = edges.entry(m.clone()).or_default();
        for p in paths(m, &code(src)) {
            let Some(t) = resolve(&p) else { continue };
            // A module and its ancestors or descendants are one unit.
            let related = t.len() <= m.len() && m[..t.len()] == t[..]
                || m.len() <= t.len() && t[..m.len()] == m[..];
            if !related {
                e.insert(t);
            }
        }
    }
    let name = |m: &Module| {
        if m.is_empty() {
            "lib".to_string()
        } else {
            m.join("/")
        }
    };
    let mut problems = Vec::new();
    for (a, targets) in &edges {
        for b in targets {
            if layer(b) > layer(a) {
                problems.push(format!(
                    "src/{} (layer {}) imports src/{} (layer {})",
                    name(a),
                    layer(a) + 1,
                    name(b),
                    layer(b) + 1
                ));
            }
        }
    }
    // A circle: a file that reaches itself through the edges.
    for start in edges.keys() {
        let mut seen = BTreeSet::new();
        let mut stack: Vec<Module> = edges[start].iter().cloned().collect();
        while let Some(m) = stack.pop() {
            if &m == start {
                problems.push(format!("src/{} is part of an import circle", name(start)));
                break;
            }
            if seen.insert(m.clone()) {
                stack.extend(edges.get(&m).into_iter().flatten().cloned());
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // The check sees the imports it is meant to see.
    let tree = edges.get(&vec!["tree".to_string()]).unwrap();
    assert!(tree.contains(&vec!["bounds".to_string()]), "{tree:?}");
    assert!(edges.len() > 40, "{} files", edges.len());
}
