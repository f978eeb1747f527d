//! docs/architecture.md matches the tree: its crate table is `cargo metadata`'s workspace and
//! dependency graph, every file or folder it names exists, and every library module of `src/`
//! is named. A crate or module added, removed or rewired without the page fails here.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn doc() -> String {
    std::fs::read_to_string(root().join("docs/architecture.md")).expect("docs/architecture.md")
}

/// Workspace crates and their normal dependencies on other workspace crates.
fn metadata() -> BTreeMap<String, BTreeSet<String>> {
    let out = Command::new(env!("CARGO"))
        .args([
            "metadata",
            "--no-deps",
            "--format-version",
            "1",
            "--offline",
        ])
        .current_dir(root())
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let pkgs = v["packages"].as_array().unwrap();
    let names: BTreeSet<String> = pkgs
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    pkgs.iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| d["kind"].is_null())
                .map(|d| d["name"].as_str().unwrap().to_string())
                .filter(|n| names.contains(n))
                .collect();
            (p["name"].as_str().unwrap().to_string(), deps)
        })
        .collect()
}

/// The page's table: `| \`crate\` | \`dep\`, ... |` rows.
fn table(doc: &str) -> BTreeMap<String, BTreeSet<String>> {
    let tick = |s: &str| -> Vec<String> {
        s.split('`')
            .skip(1)
            .step_by(2)
            .map(str::to_string)
            .collect()
    };
    doc.lines()
        .filter(|l| l.starts_with("| `magswarm"))
        .map(|l| {
            let cells: Vec<&str> = l.split('|').collect();
            let name = tick(cells[1]).remove(0);
            (name, tick(cells[2]).into_iter().collect())
        })
        .collect()
}

#[test]
fn the_crate_table_is_the_workspace_graph() {
    let meta = metadata();
    let page = table(&doc());
    assert_eq!(
        page.keys().collect::<Vec<_>>(),
        meta.keys().collect::<Vec<_>>(),
        "docs/architecture.md's crate table lists other crates than the workspace"
    );
    for (name, deps) in &meta {
        assert_eq!(
            &page[name], deps,
            "docs/architecture.md: the dependencies of {name} differ from cargo metadata"
        );
    }
}

#[test]
fn every_path_the_page_names_exists() {
    let doc = doc();
    let mut missing = Vec::new();
    for chunk in doc.split('`').skip(1).step_by(2) {
        let looks_like_path = (chunk.starts_with("src/")
            || chunk.starts_with("crates/")
            || chunk.starts_with("docs/")
            || chunk.starts_with("tests/")
            || chunk.starts_with("packaging/")
            || chunk.starts_with("scripts/")
            || chunk.starts_with("examples/"))
            && !chunk.contains(' ')
            && !chunk.contains('*');
        if looks_like_path && !root().join(chunk.trim_end_matches('/')).exists() {
            missing.push(chunk.to_string());
        }
    }
    assert!(
        missing.is_empty(),
        "docs/architecture.md names paths that do not exist: {missing:?}"
    );
}

#[test]
fn every_library_module_is_named() {
    let doc = doc();
    let lib = std::fs::read_to_string(root().join("src/lib.rs")).unwrap();
    let mods: Vec<&str> = lib
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .map(|m| m.trim_end_matches(';').trim())
        .collect();
    assert!(mods.len() >= 10, "{mods:?}");
    let unnamed: Vec<&&str> = mods
        .iter()
        .filter(|m| !doc.contains(&format!("`{m}`")))
        .collect();
    assert!(
        unnamed.is_empty(),
        "modules of src/lib.rs docs/architecture.md does not name: {unnamed:?}"
    );
}

/// What the project relies on from outside is described in its own docs: no source file
/// cites a contracts file the repository does not hold.
#[test]
fn no_source_cites_a_file_outside_the_repository() {
    fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if p.is_dir() {
                if !matches!(name.as_str(), "target" | ".git" | ".venv" | "node_modules") {
                    walk(&p, out);
                }
            } else if [".rs", ".py", ".sh", ".toml"]
                .iter()
                .any(|x| name.ends_with(x))
            {
                out.push(p);
            }
        }
    }
    let mut files = Vec::new();
    for d in [
        "src",
        "crates",
        "tests",
        "examples",
        "scripts",
        "packaging",
        "benches",
    ] {
        walk(&root().join(d), &mut files);
    }
    let needle = ["CONTRACTS", ".md"].concat();
    let citing: Vec<String> = files
        .iter()
        .filter(|f| {
            std::fs::read_to_string(f)
                .map(|s| s.contains(&needle))
                .unwrap_or(false)
        })
        .map(|f| f.display().to_string())
        .collect();
    assert!(citing.is_empty(), "sources citing {needle}: {citing:?}");
}
