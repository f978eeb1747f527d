//! No import circles between the top-level modules of any crate of the workspace: a module that
//! uses another (a `crate::x` path, or `super::x` from a top-level file) may not be used back by
//! it, directly or through others. Circles make a crate one big room: nothing can be read,
//! tested or moved alone. (Circles between crates cannot exist: cargo refuses them.)
//!
//! The count is over source text outside comments and the `#[cfg(test)] mod tests` blocks,
//! per crate, over the modules directly below its root (`src/x.rs` or `src/x/`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The `src/` folder of every package of the workspace (the root package, crates/*, packaging).
fn sources() -> Vec<(String, PathBuf)> {
    let mut out = vec![("magswarm".to_string(), root().join("src"))];
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(root().join("crates"))
        .expect("crates/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    dirs.push(root().join("packaging"));
    dirs.sort();
    for d in dirs {
        let src = d.join("src");
        if src.is_dir() {
            let name = d.file_name().unwrap().to_string_lossy().to_string();
            out.push((name, src));
        }
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("a readable folder").flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The source without line comments and without the unit-test module at its end.
fn code(text: &str) -> String {
    let body: String = text
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    match body.find("#[cfg(test)]\nmod tests") {
        Some(i) => body[..i].to_string(),
        None => body,
    }
}

/// The names after every `prefix` in `text` (`crate::x`, `crate::{x, y::z}`).
fn paths_after(text: &str, prefix: &str) -> BTreeSet<String> {
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut out = BTreeSet::new();
    let mut rest = text;
    while let Some(i) = rest.find(prefix) {
        // A whole path segment: not `some_crate::` or `xcrate::`.
        let before = rest[..i].chars().last();
        rest = &rest[i + prefix.len()..];
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let name = ident(item.trim());
                if !name.is_empty() {
                    out.insert(name);
                }
            }
        } else {
            let name = ident(rest);
            if !name.is_empty() {
                out.insert(name);
            }
        }
    }
    out
}

/// The top-level module graph of one crate.
fn graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(src).unwrap();
        let parts: Vec<String> = rel
            .components()
            .map(|c| c.as_os_str().to_string_lossy().to_string())
            .collect();
        if parts.len() == 1 && (parts[0] == "lib.rs" || parts[0] == "main.rs") {
            continue;
        }
        let top = parts[0].trim_end_matches(".rs").to_string();
        if top == "tests" || parts.last().is_some_and(|p| p == "tests.rs") {
            continue;
        }
        let text = code(&std::fs::read_to_string(&f).expect("a readable source file"));
        let mut deps = paths_after(&text, "crate::");
        // `super::` names a top-level module only from a file directly below the root.
        if parts.len() == 1 || (parts.len() == 2 && parts[1] == "mod.rs") {
            deps.extend(paths_after(&text, "super::"));
        }
        let e = g.entry(top.clone()).or_default();
        e.extend(deps.into_iter().filter(|d| *d != top));
    }
    let modules: BTreeSet<String> = g.keys().cloned().collect();
    for deps in g.values_mut() {
        deps.retain(|d| modules.contains(d));
    }
    g
}

/// Strongly connected components with more than one module (Tarjan).
fn circles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        next: usize,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        t.index.insert(v, t.next);
        t.low.insert(v, t.next);
        t.next += 1;
        t.stack.push(v);
        t.on.insert(v);
        for w in &t.g[v] {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                comp.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                t.out.push(comp);
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

#[test]
fn no_crate_has_an_import_circle_between_its_modules() {
    let mut found = Vec::new();
    let mut modules = 0;
    for (name, src) in sources() {
        let g = graph(&src);
        modules += g.len();
        for c in circles(&g) {
            found.push(format!("{name}: {}", c.join(" <-> ")));
        }
    }
    assert!(
        modules > 50,
        "only {modules} modules read: is the tree where the test looks?"
    );
    assert!(
        found.is_empty(),
        "import circles between modules:\n  {}",
        found.join("\n  ")
    );
}

#[test]
fn the_circle_finder_finds_a_circle_and_reads_grouped_paths() {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let deps = paths_after(
        "use crate::{a, b::c};\nlet x = crate::d::e(); my_crate::z;",
        "crate::",
    );
    assert_eq!(
        deps,
        ["a", "b", "d"]
            .iter()
            .map(|s| s.to_string())
            .collect::<BTreeSet<_>>()
    );
    g.insert("a".into(), ["b".to_string()].into());
    g.insert("b".into(), ["c".to_string()].into());
    g.insert("c".into(), ["a".to_string()].into());
    g.insert("d".into(), ["a".to_string()].into());
    assert_eq!(circles(&g), vec![vec!["a", "b", "c"]]);
    g.insert("c".into(), BTreeSet::new());
    assert!(circles(&g).is_empty());
}
