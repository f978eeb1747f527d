//! Unpacking a `.fmu` into a temporary folder that is always removed: when the [`Fmu`]
//! (and every slave made from it) is dropped, when importing fails half-way, at normal
//! process exit (for handles kept in statics, which Rust never drops) and on Ctrl-C or
//! SIGTERM. The archive is checked entry by entry before anything is written: paths that
//! would leave the folder (zip-slip), symbolic links, too many entries or too many bytes
//! (zip bombs), and a missing `modelDescription.xml` are errors naming the entry.
//!
//! [`Fmu`]: crate::Fmu

use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once};

use crate::error::{CosimError, Result};

/// Most entries an FMU archive may have.
pub const MAX_ENTRIES: usize = 10_000;
/// Most bytes an FMU archive may unpack to (all entries together).
pub const MAX_UNPACKED_BYTES: u64 = 1 << 30;
/// Prefix of the temporary folders (as the `fmi` crate names its own).
pub const PREFIX: &str = "fmi-rs";

/// Folders unpacked by this process and not removed yet.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static HOOKS: Once = Once::new();

fn live() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Remove every folder this process unpacked and still holds (at exit, on a signal, or for a
/// host that wants to clean up before an abrupt exit of its own).
pub fn remove_all() {
    let dirs = std::mem::take(&mut *live());
    for d in dirs {
        let _ = std::fs::remove_dir_all(&d);
    }
}

extern "C" fn remove_all_at_exit() {
    remove_all();
}

extern "C" {
    fn atexit(cb: extern "C" fn()) -> std::ffi::c_int;
}

/// At exit and on SIGINT/SIGTERM, remove the folders (installed at the first import).
fn install_hooks() {
    HOOKS.call_once(|| {
        // SAFETY: registers a function without arguments that only touches a Mutex and the
        // file system; it runs once at `exit`.
        unsafe {
            atexit(remove_all_at_exit);
        }
        #[cfg(unix)]
        {
            use signal_hook::consts::{SIGINT, SIGTERM};
            if let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) {
                let _ = std::thread::Builder::new()
                    .name("magswarm-fmu-cleanup".into())
                    .spawn(move || {
                        if let Some(sig) = signals.forever().next() {
                            remove_all();
                            // Then what the signal would have done without us.
                            let _ = signal_hook::low_level::emulate_default_handler(sig);
                            std::process::exit(128 + sig);
                        }
                    });
            }
        }
    });
}

/// A registered temporary folder: removed (and unregistered) on drop.
#[derive(Debug)]
pub struct Unpacked {
    dir: Option<tempfile::TempDir>,
    path: PathBuf,
}

impl Unpacked {
    /// Where the archive was unpacked.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Hand the folder to the `fmi` crate's import type, which removes it on drop; it stays
    /// registered here until [`Registration`] is dropped.
    pub fn into_parts(mut self) -> (tempfile::TempDir, Registration) {
        let dir = self.dir.take().expect("present until taken");
        (
            dir,
            Registration {
                path: self.path.clone(),
            },
        )
    }
}

impl Drop for Unpacked {
    fn drop(&mut self) {
        if let Some(d) = self.dir.take() {
            let _ = d.close();
            unregister(&self.path);
        }
    }
}

/// Keeps a folder registered for removal at exit; unregisters (and removes) it on drop.
#[derive(Debug)]
pub struct Registration {
    path: PathBuf,
}

impl Drop for Registration {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
        unregister(&self.path);
    }
}

fn unregister(p: &Path) {
    live().retain(|d| d != p);
}

/// Unpack `fmu` into a new registered temporary folder and read its `modelDescription.xml`.
pub fn unpack(fmu: &Path) -> Result<(Unpacked, String)> {
    install_hooks();
    let bad = |message: String| CosimError::BadArchive {
        path: fmu.to_path_buf(),
        message,
    };
    let file = std::fs::File::open(fmu).map_err(|e| bad(format!("cannot open: {e}")))?;
    let mut zip = zip::ZipArchive::new(file).map_err(|e| bad(format!("not a zip archive: {e}")))?;
    if zip.len() > MAX_ENTRIES {
        return Err(bad(format!(
            "{} entries, more than the {MAX_ENTRIES} an FMU may have",
            zip.len()
        )));
    }
    // Check every entry before writing anything.
    let mut total = 0u64;
    let mut has_xml = false;
    for i in 0..zip.len() {
        let e = zip
            .by_index(i)
            .map_err(|e| bad(format!("entry {i}: {e}")))?;
        let name = e.name().map(|n| n.into_owned()).unwrap_or_default();
        if e.enclosed_name().is_none() {
            return Err(bad(format!(
                "entry {name:?} would be written outside the unpacked folder (absolute path or \"..\")"
            )));
        }
        if e.is_symlink() {
            return Err(bad(format!("entry {name:?} is a symbolic link")));
        }
        total = total.saturating_add(e.size());
        if total > MAX_UNPACKED_BYTES {
            return Err(bad(format!(
                "unpacks to more than {MAX_UNPACKED_BYTES} bytes (at entry {name:?}): not an FMU"
            )));
        }
        has_xml |= name == "modelDescription.xml";
    }
    if !has_xml {
        return Err(bad(
            "no modelDescription.xml at the top of the archive".into()
        ));
    }
    let dir = tempfile::Builder::new()
        .prefix(PREFIX)
        .tempdir()
        .map_err(|e| bad(format!("cannot create a temporary folder: {e}")))?;
    let path = dir.path().to_path_buf();
    live().push(path.clone());
    let unpacked = Unpacked {
        dir: Some(dir),
        path,
    };
    // Written by hand, entry by entry, so the declared sizes above are enforced on the
    // actual bytes too (a lying header cannot unpack more than it declared).
    let mut written = 0u64;
    for i in 0..zip.len() {
        let mut e = zip
            .by_index(i)
            .map_err(|e| bad(format!("entry {i}: {e}")))?;
        let name = e.name().map(|n| n.into_owned()).unwrap_or_default();
        let rel = e
            .enclosed_name()
            .ok_or_else(|| bad(format!("entry {name:?}")))?;
        let out = unpacked.path().join(rel);
        if e.is_dir() {
            std::fs::create_dir_all(&out).map_err(|err| bad(format!("entry {name:?}: {err}")))?;
            continue;
        }
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent).map_err(|err| bad(format!("entry {name:?}: {err}")))?;
        }
        let declared = e.size();
        let mut f =
            std::fs::File::create(&out).map_err(|err| bad(format!("entry {name:?}: {err}")))?;
        let n = std::io::copy(&mut (&mut e).take(declared + 1), &mut f)
            .map_err(|err| bad(format!("entry {name:?}: {err}")))?;
        if n > declared {
            return Err(bad(format!(
                "entry {name:?} unpacks to more bytes than its header declares ({declared})"
            )));
        }
        written += n;
        if written > MAX_UNPACKED_BYTES {
            return Err(bad(format!(
                "unpacks to more than {MAX_UNPACKED_BYTES} bytes"
            )));
        }
        #[cfg(unix)]
        if let Some(mode) = e.unix_mode() {
            use std::os::unix::fs::PermissionsExt;
            let _ = std::fs::set_permissions(&out, std::fs::Permissions::from_mode(mode & 0o755));
        }
    }
    let xml = std::fs::read_to_string(unpacked.path().join("modelDescription.xml"))
        .map_err(|e| bad(format!("modelDescription.xml: {e}")))?;
    Ok((unpacked, xml))
}

/// Number of folders this process unpacked and still holds (for tests).
pub fn live_count() -> usize {
    live().len()
}
