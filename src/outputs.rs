//! Errors before work: every command checks where it will write before it starts, so a
//! missing or unusable output folder is reported at once, naming the option and the path,
//! instead of after seconds of fitting. A missing folder is created; a path whose folder
//! cannot be created or written to is refused.

use std::path::Path;

use anyhow::{bail, Context, Result};

/// `flag` names a file to be written: create its folder if missing, and check that a file
/// can be created there (a probe file, removed at once).
pub fn prepare_file(flag: &str, path: &Path) -> Result<()> {
    if path.is_dir() {
        bail!(
            "{flag} {}: is a folder, expected a file path",
            path.display()
        );
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    prepare_dir(flag, parent).with_context(|| format!("{flag} {}", path.display()))
}

/// `flag` names a folder to be written into: create it if missing and check that a file can
/// be created in it.
pub fn prepare_dir(flag: &str, dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!("{flag}: {} exists and is not a folder", dir.display());
    }
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{flag}: cannot create the folder {}", dir.display()))?;
    tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("{flag}: cannot write into the folder {}", dir.display()))?;
    Ok(())
}
