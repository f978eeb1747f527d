//! Turning `fmuResourceLocation` into a directory path.
//!
//! FMI 2.0 passes the resources folder as a URI (RFC 3986), and importers disagree on the
//! spelling: `file:///tmp/x`, `file:/tmp/x`, `file://localhost/tmp/x`, with or without a
//! trailing slash, with spaces percent-encoded or not, and (old importers) as a bare path.
//! All of those are accepted; other schemes and remote hosts are rejected, because the FMU
//! can only read local files.

use std::path::{Path, PathBuf};

/// Why a resource location could not be turned into a local path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UriError(pub String);

impl std::fmt::Display for UriError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UriError {}

/// Decode a resource location to a local directory. `Ok(None)` for NULL-equivalent (empty)
/// input. The result has no trailing slash (except for the root).
pub fn resource_dir(location: &str) -> Result<Option<PathBuf>, UriError> {
    let loc = location.trim();
    if loc.is_empty() {
        return Ok(None);
    }
    let path_part: &str = if let Some(rest) = strip_prefix_ci(loc, "file:") {
        if let Some(after) = rest.strip_prefix("//") {
            // Authority: empty or localhost, then the absolute path.
            let (host, path) = match after.find('/') {
                Some(i) => (&after[..i], &after[i..]),
                None => (after, ""),
            };
            if !(host.is_empty() || host.eq_ignore_ascii_case("localhost")) {
                return Err(UriError(format!(
                    "resource location \"{location}\" names the remote host \"{host}\"; only local files are supported"
                )));
            }
            if path.is_empty() {
                return Err(UriError(format!(
                    "resource location \"{location}\" has no path"
                )));
            }
            path
        } else {
            rest
        }
    } else if has_scheme(loc) {
        return Err(UriError(format!(
            "resource location \"{location}\" is not a file: URI; only local files are supported"
        )));
    } else {
        // A bare path: taken literally (no percent-decoding; a file name may contain '%').
        return Ok(Some(trim_trailing_slash(PathBuf::from(loc))));
    };
    // Strip any query or fragment.
    let path_part = path_part.split(['?', '#']).next().unwrap_or("");
    let bytes = percent_decode(path_part).ok_or_else(|| {
        UriError(format!(
            "resource location \"{location}\" has an invalid percent-escape"
        ))
    })?;
    let path = bytes_to_path(bytes, location)?;
    Ok(Some(trim_trailing_slash(path)))
}

/// The `resources/` folder of the unpacked FMU this code was loaded from, if it runs from
/// `<fmu>/binaries/<platform>/<id>.so` and that folder exists. Lets an FMU that was packaged
/// with resources notice that the importer pointed it somewhere else.
pub fn packaged_resources() -> Option<PathBuf> {
    let lib = own_library_path()?;
    let platform = lib.parent()?;
    let binaries = platform.parent()?;
    if binaries.file_name()? != "binaries" {
        return None;
    }
    let res = binaries.parent()?.join("resources");
    res.is_dir().then_some(res)
}

/// The resource file `name` an instance reads: `resource_dir/name` if it is a file, `None` if
/// neither the importer's resource location nor the FMU's own `resources/` (`packaged`) has
/// it (the model's built-in defaults apply). When the FMU was packaged with `name` but the
/// location the importer passed lacks it, the importer pointed the FMU elsewhere and the
/// defaults would silently be the wrong ones: an error naming both folders.
pub fn packaged_resource(
    resource_dir: Option<&Path>,
    packaged: Option<&Path>,
    name: &str,
) -> Result<Option<PathBuf>, crate::ModelError> {
    let given = resource_dir.map(|d| d.join(name)).filter(|p| p.is_file());
    let baked = packaged.map(|d| d.join(name)).filter(|p| p.is_file());
    match (given, baked) {
        (Some(p), _) => Ok(Some(p)),
        (None, Some(b)) => Err(crate::ModelError::error(format!(
            "this FMU was packaged with {} but the resource location passed at instantiation \
             ({}) holds no {name}; refusing to run with the built-in defaults instead (pass the \
             unpacked FMU's resources folder as the resource location)",
            b.display(),
            resource_dir.map_or("none".to_string(), |d| d.display().to_string())
        ))),
        (None, None) => Ok(None),
    }
}

#[cfg(unix)]
fn own_library_path() -> Option<PathBuf> {
    use std::ffi::{c_char, c_int, c_void, CStr};
    use std::os::unix::ffi::OsStrExt;
    #[repr(C)]
    struct DlInfo {
        dli_fname: *const c_char,
        dli_fbase: *mut c_void,
        dli_sname: *const c_char,
        dli_saddr: *mut c_void,
    }
    extern "C" {
        fn dladdr(addr: *const c_void, info: *mut DlInfo) -> c_int;
    }
    let mut info = DlInfo {
        dli_fname: std::ptr::null(),
        dli_fbase: std::ptr::null_mut(),
        dli_sname: std::ptr::null(),
        dli_saddr: std::ptr::null_mut(),
    };
    // SAFETY: dladdr only reads the address (a function of this library) and fills `info`.
    let ok = unsafe { dladdr(own_library_path as *const c_void, &mut info) };
    if ok == 0 || info.dli_fname.is_null() {
        return None;
    }
    // SAFETY: on success dli_fname is a NUL-terminated path owned by the loader.
    let name = unsafe { CStr::from_ptr(info.dli_fname) };
    Some(PathBuf::from(std::ffi::OsStr::from_bytes(name.to_bytes())))
}

#[cfg(not(unix))]
fn own_library_path() -> Option<PathBuf> {
    None
}

fn strip_prefix_ci<'a>(s: &'a str, prefix: &str) -> Option<&'a str> {
    // `get`, not indexing: the location may start with a multi-byte character.
    match s.get(..prefix.len()) {
        Some(head) if head.eq_ignore_ascii_case(prefix) => s.get(prefix.len()..),
        _ => None,
    }
}

/// `scheme:` per RFC 3986, with at least two letters so that `C:\x` counts as a path.
fn has_scheme(s: &str) -> bool {
    match s.find(':') {
        Some(i) if i >= 2 => {
            let scheme = &s[..i];
            scheme
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic())
                && scheme
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
        }
        _ => false,
    }
}

fn percent_decode(s: &str) -> Option<Vec<u8>> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b.get(i + 1..i + 3)?;
            let hex = std::str::from_utf8(hex).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    Some(out)
}

#[cfg(unix)]
fn bytes_to_path(bytes: Vec<u8>, _location: &str) -> Result<PathBuf, UriError> {
    use std::os::unix::ffi::OsStringExt;
    Ok(PathBuf::from(std::ffi::OsString::from_vec(bytes)))
}

#[cfg(not(unix))]
fn bytes_to_path(bytes: Vec<u8>, location: &str) -> Result<PathBuf, UriError> {
    let s = String::from_utf8(bytes).map_err(|_| {
        UriError(format!(
            "resource location \"{location}\" is not valid UTF-8"
        ))
    })?;
    // "/C:/dir" -> "C:/dir"
    let b = s.as_bytes();
    let s = if b.len() >= 3 && b[0] == b'/' && b[1].is_ascii_alphabetic() && b[2] == b':' {
        s[1..].to_string()
    } else {
        s
    };
    Ok(PathBuf::from(s))
}

fn trim_trailing_slash(p: PathBuf) -> PathBuf {
    let s = p.as_os_str().to_string_lossy();
    if s.len() > 1 && (s.ends_with('/') || s.ends_with('\\')) {
        let trimmed = s.trim_end_matches(['/', '\\']);
        if trimmed.is_empty() {
            return PathBuf::from("/");
        }
        // Only lossless when the path is valid UTF-8; otherwise keep it as is.
        if p.to_str().is_some() {
            return PathBuf::from(trimmed);
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(s: &str) -> PathBuf {
        resource_dir(s).unwrap().unwrap()
    }

    #[test]
    fn spellings_of_file_uris() {
        assert_eq!(
            dir("file:///tmp/fmu/resources"),
            PathBuf::from("/tmp/fmu/resources")
        );
        assert_eq!(
            dir("file:///tmp/fmu/resources/"),
            PathBuf::from("/tmp/fmu/resources")
        );
        assert_eq!(
            dir("file:/tmp/fmu/resources"),
            PathBuf::from("/tmp/fmu/resources")
        );
        assert_eq!(dir("file://localhost/tmp/x"), PathBuf::from("/tmp/x"));
        assert_eq!(dir("FILE:///tmp/x"), PathBuf::from("/tmp/x"));
        assert_eq!(dir("file:///"), PathBuf::from("/"));
    }

    #[test]
    fn percent_escapes() {
        assert_eq!(
            dir("file:///tmp/my%20fmu/r%C3%A9s"),
            PathBuf::from("/tmp/my fmu/rés")
        );
        assert_eq!(dir("file:///tmp/a%2fb"), PathBuf::from("/tmp/a/b"));
        assert!(resource_dir("file:///tmp/bad%2").is_err());
        assert!(resource_dir("file:///tmp/bad%zz").is_err());
    }

    #[test]
    fn multi_byte_text_is_not_sliced_inside_a_character() {
        for loc in ["\u{fffd}\u{fffd}\u{fffd}", "éééé", "file:éé", "fil\u{e9}:x"] {
            let _ = resource_dir(loc);
        }
        assert_eq!(dir("éééé"), PathBuf::from("éééé"));
    }

    #[test]
    fn empty_bare_and_rejected() {
        assert_eq!(resource_dir("").unwrap(), None);
        assert_eq!(resource_dir("   ").unwrap(), None);
        assert_eq!(dir("/plain/path/"), PathBuf::from("/plain/path"));
        assert!(resource_dir("http://example.invalid/res").is_err());
        assert!(resource_dir("file://server/share").is_err());
        assert!(resource_dir("file://").is_err());
    }
}
