//! The FMU archive layout (the same in FMI 2.0 and 3.0 but for the platform folder): a zip
//! with `modelDescription.xml` at the root, the shared library under
//! `binaries/<platform>/<modelIdentifier>.so` (executable), data under `resources/` and a
//! page under `documentation/`. Every FMU is written through [`fmu_zip`], so the layout and
//! the compression settings are decided once.

use std::io::Write;
use std::path::Path;

use crate::error::{PackagingError, Result};
use magswarm_fmi::FmiVersion;

/// The platform folder inside an FMU of `version` for the target this packager was compiled
/// for (the library it packages is built for the same target): FMI 2.0 names platforms
/// `<os><bits>` (`linux64`, `win64`, `darwin64`), FMI 3.0 `<arch>-<os>` (`x86_64-linux`,
/// `aarch64-darwin`). Only Linux is built and tested here; the other names follow the
/// standards' tables.
pub fn platform_folder(version: FmiVersion) -> &'static str {
    let os = if cfg!(target_os = "windows") {
        "win"
    } else if cfg!(target_os = "macos") {
        "darwin"
    } else {
        "linux"
    };
    match version {
        FmiVersion::V2 => match (os, cfg!(target_pointer_width = "64")) {
            ("win", true) => "win64",
            ("win", false) => "win32",
            ("darwin", _) => "darwin64",
            (_, true) => "linux64",
            (_, false) => "linux32",
        },
        FmiVersion::V3 => {
            let arch = if cfg!(target_arch = "aarch64") {
                "aarch64"
            } else if cfg!(target_arch = "x86") {
                "x86"
            } else if cfg!(target_arch = "arm") {
                "aarch32"
            } else {
                "x86_64"
            };
            match (arch, os) {
                ("x86_64", "linux") => "x86_64-linux",
                ("aarch64", "linux") => "aarch64-linux",
                ("x86", "linux") => "x86-linux",
                ("aarch32", "linux") => "aarch32-linux",
                ("x86_64", "win") => "x86_64-windows",
                ("x86", "win") => "x86-windows",
                ("aarch64", "darwin") => "aarch64-darwin",
                ("x86_64", "darwin") => "x86_64-darwin",
                _ => "x86_64-linux",
            }
        }
    }
}

/// One file of an archive.
pub struct Entry<'a> {
    /// Path inside the zip, `/`-separated.
    pub name: String,
    pub data: &'a [u8],
    /// Unix mode 0755 instead of the default (the shared library must be loadable as is after
    /// an importer unpacks the archive).
    pub executable: bool,
}

impl<'a> Entry<'a> {
    /// A plain (non-executable) file.
    pub fn file(name: impl Into<String>, data: &'a [u8]) -> Self {
        Entry {
            name: name.into(),
            data,
            executable: false,
        }
    }

    /// `modelDescription.xml` at the root of the archive.
    pub fn model_description(xml: &'a str) -> Self {
        Self::file("modelDescription.xml", xml.as_bytes())
    }

    /// The compiled library as `binaries/<platform>/<model_identifier>.so`, the platform
    /// folder of FMI `version` ([`platform_folder`]).
    pub fn binary(model_identifier: &str, so: &'a [u8], version: FmiVersion) -> Self {
        Entry {
            name: format!(
                "binaries/{}/{model_identifier}.so",
                platform_folder(version)
            ),
            data: so,
            executable: true,
        }
    }

    /// `resources/<name>`: what the FMU reads at instantiation (the resource location the
    /// importer passes points at this folder).
    pub fn resource(name: &str, data: &'a [u8]) -> Self {
        Self::file(format!("resources/{name}"), data)
    }

    /// `documentation/index.html`, the page FMI tools show for the model.
    pub fn documentation(html: &'a str) -> Self {
        Self::file("documentation/index.html", html.as_bytes())
    }
}

/// The archive bytes of `entries`, in the given order, deflated.
pub fn fmu_zip(entries: &[Entry<'_>]) -> Result<Vec<u8>> {
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut zip = zip::ZipWriter::new(&mut buf);
        let deflate = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        let exec = deflate.unix_permissions(0o755);
        for e in entries {
            let opts = if e.executable { exec } else { deflate };
            let zip_err = |source| PackagingError::Zip {
                entry: e.name.clone(),
                source,
            };
            zip.start_file(e.name.as_str(), opts).map_err(zip_err)?;
            zip.write_all(e.data)
                .map_err(|io| zip_err(zip::result::ZipError::Io(io)))?;
        }
        zip.finish().map_err(|source| PackagingError::Zip {
            entry: String::new(),
            source,
        })?;
    }
    Ok(buf.into_inner())
}

/// Read the shared library to package, refusing anything that is not an ELF file (a wrong
/// `--lib` would otherwise give an archive that every importer rejects later, far from here).
pub fn read_shared_library(lib: &Path) -> Result<Vec<u8>> {
    let so = std::fs::read(lib).map_err(PackagingError::io("read", lib))?;
    if so.len() < 4 || &so[..4] != b"\x7fELF" {
        return Err(PackagingError::NotElf(lib.to_path_buf()));
    }
    Ok(so)
}

/// Write a file via a temporary sibling and a rename, creating parent folders, so an
/// interrupted run never leaves a truncated archive where an importer would find it.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(PackagingError::io("create", dir))?;
    }
    let tmp = path.with_extension("tmp-magswarm");
    std::fs::write(&tmp, bytes).map_err(PackagingError::io("write", &tmp))?;
    std::fs::rename(&tmp, path).map_err(PackagingError::io("write", path))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    #[test]
    fn archive_has_the_fmi_layout_and_an_executable_binary() {
        let so = b"\x7fELF fake";
        let bytes = fmu_zip(&[
            Entry::model_description("<fmiModelDescription/>"),
            Entry::binary("Demo", so, FmiVersion::V2),
            Entry::binary("Demo", so, FmiVersion::V3),
            Entry::resource("model.json", b"{}"),
            Entry::documentation("<html/>"),
        ])
        .unwrap();
        let mut z = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
        let names: Vec<String> = z.file_names().map(|n| n.unwrap().into_owned()).collect();
        assert_eq!(names.len(), 5);
        for n in [
            "modelDescription.xml",
            "binaries/linux64/Demo.so",
            "binaries/x86_64-linux/Demo.so",
            "resources/model.json",
            "documentation/index.html",
        ] {
            assert!(names.iter().any(|m| m == n), "{n} missing from {names:?}");
        }
        let mut bin = z.by_name("binaries/linux64/Demo.so").unwrap();
        assert_eq!(bin.unix_mode().map(|m| m & 0o777), Some(0o755));
        let mut data = Vec::new();
        bin.read_to_end(&mut data).unwrap();
        assert_eq!(data, so);
        drop(bin);
        let xml = z.by_name("modelDescription.xml").unwrap();
        assert_ne!(xml.unix_mode().map(|m| m & 0o111), Some(0o111));
    }

    #[test]
    fn non_elf_library_is_refused_with_its_path() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("lib.so");
        std::fs::write(&p, b"not a library").unwrap();
        let e = read_shared_library(&p).unwrap_err().to_string();
        assert!(e.contains("not an ELF") && e.contains("lib.so"), "{e}");
    }

    #[test]
    fn write_atomic_creates_folders_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a/b/X.fmu");
        write_atomic(&p, b"zip").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"zip");
        assert!(!p.with_extension("tmp-magswarm").exists());
    }
}
