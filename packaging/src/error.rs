//! What can go wrong while packaging an FMU, as a type: the CLI (and the bridge's `fmu`
//! command) print it, tests match on it. Every variant names the file or entry involved, so
//! a message says what to fix and where.

use std::path::PathBuf;

/// An error of `magswarm-packaging`.
#[derive(Debug, thiserror::Error)]
pub enum PackagingError {
    /// Reading, creating or writing a file or folder failed.
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        /// What was being done ("read", "write", "create").
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// Writing an entry of the zip archive failed.
    #[error("cannot write zip entry {entry}: {source}")]
    Zip {
        /// The entry's name inside the archive (empty when finishing the archive).
        entry: String,
        /// The zip writer's reason.
        source: zip::result::ZipError,
    },
    /// The file given as the shared library is not an ELF file.
    #[error("{} is not an ELF shared library", .0.display())]
    NotElf(PathBuf),
    /// `cargo build` of the FMU crate could not be run or failed.
    #[error("cannot build the FMU library {krate}: {reason}")]
    Build {
        /// The cargo package.
        krate: String,
        /// What went wrong.
        reason: String,
    },
    /// The compiled library is not where it should be.
    #[error("{} not found; build it with `cargo build --release -p {krate}` or pass --lib PATH", lib.display())]
    LibraryNotFound {
        /// Where it was looked for.
        lib: PathBuf,
        /// The cargo package that builds it.
        krate: String,
    },
    /// The running executable's path is unknown (needed to find the library beside it).
    #[error("cannot locate the running executable: {0}")]
    CurrentExe(std::io::Error),
    /// The library could not be loaded, or lacks the magswarm description symbols.
    #[error("{}: {what}: {source}", lib.display())]
    Load {
        /// The library.
        lib: PathBuf,
        /// "cannot load" or "not a magswarm FMU library".
        what: &'static str,
        /// The loader's reason.
        source: libloading::Error,
    },
    /// The JSON to bake in holds a NUL byte (it cannot cross the C interface).
    #[error("the {what} JSON contains a NUL byte")]
    JsonNul {
        /// Which JSON ("model", "controller configuration", "rig config").
        what: String,
    },
    /// The library refused the JSON, or has no description of the asked FMI version.
    #[error("{} rejected the {what} or has no FMI {fmi_version}.0 description", lib.display())]
    Rejected {
        /// The library.
        lib: PathBuf,
        /// Which JSON.
        what: String,
        /// The FMI major version asked for.
        fmi_version: u32,
    },
    /// The library was built from other sources than this binary (its GUID differs).
    #[error(
        "{} was built from other sources than this magswarm binary (GUID differs); \
         rebuild both with `cargo build --release --workspace`",
        .0.display()
    )]
    Stale(PathBuf),
    /// The library is another FMU's.
    #[error("{} is not the {model_identifier} library", lib.display())]
    WrongModel {
        /// The library.
        lib: PathBuf,
        /// The model identifier expected.
        model_identifier: String,
    },
    /// The model to bake in is not valid.
    #[error(transparent)]
    Model(#[from] magswarm_model::ModelError),
}

impl PackagingError {
    /// An I/O error while doing `action` on `path`.
    pub fn io(
        action: &'static str,
        path: impl Into<PathBuf>,
    ) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |source| PackagingError::Io {
            action,
            path,
            source,
        }
    }
}

/// The result type of this crate.
pub type Result<T, E = PackagingError> = std::result::Result<T, E>;
