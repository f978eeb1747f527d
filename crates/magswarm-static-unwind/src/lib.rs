//! A build-script helper for the FMU crates: link the GCC unwinder (`libgcc_eh.a`) into the
//! shared library instead of depending on `libgcc_s.so.1`.
//!
//! Why: an FMU is a self-contained shared library that tools load into their own process, and
//! users check it with `ldd`, which should show the C runtime alone (libc, libm, the loader).
//! Rust's standard library on `*-linux-gnu` asks the linker for `-lgcc_s` because a panic
//! unwinds through the GCC unwinder, and the FMI shells need unwinding: their panic barrier
//! catches a panic and turns it into `fmi2Error`/`fmi3Error` instead of aborting the host.
//! `cc -static-libgcc` is how C++ libraries avoid the same dependency, but rustc names
//! `gcc_s` explicitly, so the driver's flag alone does not help. Instead the cdylib's link line
//! gets a directory, searched before the system's, holding `libgcc_s.a`: a link to the
//! toolchain's `libgcc_eh.a` (position-independent, the archive `-static-libgcc` itself uses).
//! The linker then resolves `-lgcc_s` to that archive, and the library carries a private copy
//! of the unwinder (a few tens of kilobytes), as `-static-libgcc` would.
//!
//! Only the artefact named is affected (`cargo:rustc-cdylib-link-arg`, or
//! `cargo:rustc-link-arg-bin` for a program that ships inside an FMU, such as the rig's
//! stepper watchdog): the crate's rlib, tests and other binaries are linked as before. Where no `libgcc_eh.a` is found (another
//! toolchain, another target) the build goes on with the usual dynamic unwinder and a cargo
//! warning says so.

use std::env;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What gets the static unwinder.
#[derive(Debug, Clone, Copy)]
pub enum Artefact<'a> {
    /// The crate's shared library (an FMU's binary).
    Cdylib,
    /// One of the crate's programs, by its `[[bin]]` name.
    Bin(&'a str),
}

/// Call from the `build.rs` of the crate that builds `artefact`.
pub fn link_unwinder_statically(artefact: Artefact) {
    println!("cargo:rerun-if-env-changed=CC");
    let os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let target_env = env::var("CARGO_CFG_TARGET_ENV").unwrap_or_default();
    if os != "linux" || target_env != "gnu" {
        return;
    }
    match archive_dir() {
        Ok(dir) => match artefact {
            Artefact::Cdylib => println!("cargo:rustc-cdylib-link-arg=-L{}", dir.display()),
            Artefact::Bin(name) => {
                println!("cargo:rustc-link-arg-bin={name}=-L{}", dir.display())
            }
        },
        Err(why) => println!("cargo:warning={artefact:?} will link libgcc_s dynamically: {why}"),
    }
}

/// A directory under `OUT_DIR` holding `libgcc_s.a`, a link to (or copy of) the toolchain's
/// `libgcc_eh.a`.
fn archive_dir() -> Result<PathBuf, String> {
    let eh = find_libgcc_eh()?;
    let out = env::var_os("OUT_DIR").ok_or("OUT_DIR is not set (not a build script?)")?;
    let dir = Path::new(&out).join("static-unwind");
    std::fs::create_dir_all(&dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    let target = dir.join("libgcc_s.a");
    let _ = std::fs::remove_file(&target);
    #[cfg(unix)]
    let linked = std::os::unix::fs::symlink(&eh, &target).is_ok();
    #[cfg(not(unix))]
    let linked = false;
    if !linked {
        std::fs::copy(&eh, &target)
            .map_err(|e| format!("copying {} to {}: {e}", eh.display(), target.display()))?;
    }
    println!("cargo:rerun-if-changed={}", eh.display());
    Ok(dir)
}

/// The C compiler's `libgcc_eh.a` (`cc -print-file-name=libgcc_eh.a`, the compiler named by
/// `CC` if set): the compiler prints the bare name back when it has no such file.
fn find_libgcc_eh() -> Result<PathBuf, String> {
    let cc = env::var("CC").unwrap_or_else(|_| "cc".into());
    let out = Command::new(&cc)
        .arg("-print-file-name=libgcc_eh.a")
        .output()
        .map_err(|e| format!("running `{cc} -print-file-name=libgcc_eh.a`: {e}"))?;
    let path = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    if out.status.success() && path.is_absolute() && path.is_file() {
        Ok(path)
    } else {
        Err(format!("`{cc}` knows no libgcc_eh.a"))
    }
}
