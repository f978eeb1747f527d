//! The `.fmu` archives of magswarm: what goes where inside them, where the XML comes from, and
//! the check that the packaged library is the one this build was made from.
//!
//! `magswarm fmu` (the CLI) parses its arguments and calls [`plant::package`] or
//! [`pid::package`] with the FMI version to write; everything about the archive itself lives
//! here so the tree has one place that knows the FMU layout (see `packaging/README.md`):
//!
//! - [`archive`]: the zip layout (`modelDescription.xml`, `binaries/<platform>/<id>.so` with
//!   the platform folder of the version, `resources/`, `documentation/index.html`) and atomic
//!   writing of the result;
//! - [`library`]: finding (and building) the compiled FMU library and asking it for its own
//!   modelDescription.xml, so the XML in an archive is the one its binary was compiled from;
//! - [`stale`]: the staleness check (the library's GUID / instantiation token against this
//!   build's variable table);
//! - [`plant`]: `MagSwarm.fmu`; [`pid`]: the controller FMU `MagSwarmPID.fmu`.

pub mod archive;
pub mod error;
pub mod library;
pub mod pid;
pub mod plant;
pub mod stale;

pub use archive::{platform_folder, write_atomic};
pub use error::{PackagingError, Result};
pub use library::{locate_library, xml_from_library};
pub use magswarm_fmi::FmiVersion;

/// Escape text for HTML element content and attribute values (the documentation pages).
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    #[test]
    fn esc_escapes_markup_and_quotes() {
        assert_eq!(super::esc(r#"a<b>&"c""#), "a&lt;b&gt;&amp;&quot;c&quot;");
    }
}
