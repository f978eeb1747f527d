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
    // `pub mod x;` and the crates re-exported as modules (`pub use magswarm_x as x;`,
    // `pub use magswarm_fit::{lm, optim};`, `pub use magswarm_report::plot;`).
    let mut mods: Vec<String> = Vec::new();
    for l in lib.lines().map(str::trim) {
        if let Some(m) = l.strip_prefix("pub mod ") {
            mods.push(m.trim_end_matches(';').trim().to_string());
        } else if let Some(u) = l.strip_prefix("pub use ") {
            let u = u.trim_end_matches(';');
            if let Some((_, alias)) = u.split_once(" as ") {
                mods.push(alias.trim().to_string());
            } else if let Some((_, list)) = u.split_once("::{") {
                mods.extend(
                    list.trim_end_matches('}')
                        .split(',')
                        .map(|x| x.trim().to_string()),
                );
            } else if let Some((_, last)) = u.rsplit_once("::") {
                mods.push(last.trim().to_string());
            }
        }
    }
    assert!(mods.len() >= 10, "{mods:?}");
    let unnamed: Vec<&String> = mods
        .iter()
        .filter(|m| !doc.contains(&format!("`{m}`")) && !doc.contains(&format!("`magswarm::{m}`")))
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

/// The docs describe what the project relies on in its own words (docs/interfaces.md): no
/// page cites the external contracts file, by name or as "the CONTRACTS log".
#[test]
fn no_doc_cites_the_contracts_file() {
    let mut pages = vec![root().join("README.md")];
    for e in std::fs::read_dir(root().join("docs")).unwrap().flatten() {
        if e.path().extension().is_some_and(|x| x == "md") {
            pages.push(e.path());
        }
    }
    let needle = ["CONTR", "ACTS"].concat();
    let citing: Vec<String> = pages
        .iter()
        .filter(|p| std::fs::read_to_string(p).is_ok_and(|s| s.contains(&needle)))
        .map(|p| p.display().to_string())
        .collect();
    assert!(citing.is_empty(), "docs citing {needle}: {citing:?}");
    let interfaces = std::fs::read_to_string(root().join("docs/interfaces.md")).unwrap();
    for name in [
        "`magswarm`",
        "`MagSwarm.fmu`",
        "`magswarm-bridge`",
        "`z_m`",
        "`omega_m`",
        "`r1_ss`",
        "`model_file`",
        "`t_s,z_m_mm,f_hz,r1_mm,r2_mm`",
        "`magswarm-model/2`",
        "`phase_lag`",
        "`camera_bias`",
        "`DIR/report.json`",
    ] {
        assert!(
            interfaces.contains(name),
            "docs/interfaces.md does not name {name}"
        );
    }
}

/// The source folder of a workspace crate by its library name (`magswarm_identify`), if the
/// workspace has it.
fn crate_src(lib: &str) -> Option<std::path::PathBuf> {
    if lib == "magswarm" {
        return Some(root().join("src"));
    }
    let dir = root()
        .join("crates")
        .join(lib.replace('_', "-"))
        .join("src");
    dir.is_dir().then_some(dir)
}

/// Whether `name` is a module of the module folder `dir` (its file or its folder), or, for the
/// `magswarm` facade's top level, a crate it re-exports under that name.
fn is_module(dir: &Path, name: &str, facade: bool) -> bool {
    if dir.join(format!("{name}.rs")).is_file() || dir.join(name).join("mod.rs").is_file() {
        return true;
    }
    if facade {
        let lib = std::fs::read_to_string(dir.join("lib.rs")).unwrap();
        return lib.lines().any(|l| {
            l.trim_start().starts_with("pub use ")
                && (l.contains(&format!(" as {name};"))
                    || l.contains(&format!("::{name};"))
                    || l.contains(&format!("{{{name},"))
                    || l.contains(&format!(", {name}}}"))
                    || l.contains(&format!("::{name}::")))
        });
    }
    false
}

/// Every crate the page names (`magswarm-...`) is a workspace crate, and every module path it
/// names (`magswarm_identify::data::Session`) exists: each segment but the last is a module
/// of the crate's source tree (the last may be a module or an item).
#[test]
fn every_crate_and_module_the_page_names_exists() {
    let doc = doc();
    let meta = metadata();
    let mut missing = Vec::new();
    for chunk in doc.split('`').skip(1).step_by(2) {
        if chunk.starts_with("magswarm-")
            && chunk.chars().all(|c| c.is_ascii_alphanumeric() || c == '-')
            && !meta.contains_key(chunk)
        {
            missing.push(format!("crate {chunk}"));
        }
        if !chunk.starts_with("magswarm") || !chunk.contains("::") || chunk.contains(' ') {
            continue;
        }
        let path = chunk.split('(').next().unwrap_or(chunk);
        let segs: Vec<&str> = path.split("::").collect();
        let Some(mut dir) = crate_src(segs[0]) else {
            missing.push(format!("crate of {chunk}"));
            continue;
        };
        let facade = segs[0] == "magswarm";
        for (k, seg) in segs.iter().enumerate().skip(1) {
            let last = k + 1 == segs.len();
            if is_module(&dir, seg, facade && k == 1) {
                // A module re-exported by the facade is checked in its own crate's doc line.
                if facade && k == 1 && !dir.join(format!("{seg}.rs")).is_file() {
                    break;
                }
                dir = dir.join(seg);
            } else if !last {
                missing.push(format!("module {seg} of {chunk}"));
                break;
            }
        }
    }
    assert!(
        missing.is_empty(),
        "docs/architecture.md names what does not exist: {missing:?}"
    );
}
