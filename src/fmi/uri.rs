//! `fmuResourceLocation` (a `file:` URI) to a filesystem path.
//!
//! Accepted forms: `file:///abs/path`, `file://localhost/abs/path`, `file:/abs/path`, with
//! percent-encoded bytes (`%20`), with or without a trailing slash (fmpy passes none). The
//! scheme is case-insensitive. Anything else (another scheme, another host, a relative path, a
//! broken or NUL escape) is an error that says what is wrong.

use std::path::PathBuf;

/// Why a resource URI could not be turned into a path.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum UriError {
    /// Not a `file:` URI.
    #[error("resource location {0:?} is not a file: URI (only file: URIs are supported)")]
    NotFile(String),
    /// `file://host/...` with a host other than `localhost`.
    #[error("resource location {uri:?} names the host {host:?}; only local files (file:/// or file://localhost/) are supported")]
    RemoteHost {
        /// The whole URI.
        uri: String,
        /// The host part.
        host: String,
    },
    /// The path is not absolute.
    #[error("resource location {0:?} does not hold an absolute path")]
    NotAbsolute(String),
    /// A `%` not followed by two hex digits, or `%00`.
    #[error("resource location {uri:?} has an invalid percent escape at byte {position}")]
    BadEscape {
        /// The whole URI.
        uri: String,
        /// Byte offset of the `%`.
        position: usize,
    },
    /// The decoded path is not valid UTF-8 on a platform that needs it.
    #[error("resource location {0:?} does not decode to a valid path")]
    BadEncoding(String),
}

/// Converts a `file:` URI to the path it names (trailing slash removed, except for `/`).
pub fn resource_uri_to_path(uri: &str) -> Result<PathBuf, UriError> {
    let scheme_end = uri
        .find(':')
        .ok_or_else(|| UriError::NotFile(uri.to_owned()))?;
    if !uri[..scheme_end].eq_ignore_ascii_case("file") {
        return Err(UriError::NotFile(uri.to_owned()));
    }
    let rest = &uri[scheme_end + 1..];
    let path_part = if let Some(after) = rest.strip_prefix("//") {
        // authority, then the absolute path
        let slash = after.find('/').unwrap_or(after.len());
        let host = &after[..slash];
        if !(host.is_empty() || host.eq_ignore_ascii_case("localhost")) {
            return Err(UriError::RemoteHost {
                uri: uri.to_owned(),
                host: host.to_owned(),
            });
        }
        &after[slash..]
    } else {
        rest
    };
    if !path_part.starts_with('/') {
        return Err(UriError::NotAbsolute(uri.to_owned()));
    }
    let offset = uri.len() - path_part.len();
    let mut bytes = percent_decode(path_part).map_err(|position| UriError::BadEscape {
        uri: uri.to_owned(),
        position: position + offset,
    })?;
    while bytes.len() > 1 && bytes.last() == Some(&b'/') {
        bytes.pop();
    }
    bytes_to_path(bytes).ok_or_else(|| UriError::BadEncoding(uri.to_owned()))
}

/// Decodes `%XX` escapes; the error is the byte offset of a bad escape (or of `%00`).
fn percent_decode(s: &str) -> Result<Vec<u8>, usize> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = |c: u8| (c as char).to_digit(16);
            let (hi, lo) = match (
                b.get(i + 1).copied().and_then(hex),
                b.get(i + 2).copied().and_then(hex),
            ) {
                (Some(hi), Some(lo)) => (hi, lo),
                _ => return Err(i),
            };
            let byte = (hi * 16 + lo) as u8;
            if byte == 0 {
                return Err(i);
            }
            out.push(byte);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    Ok(out)
}

#[cfg(unix)]
fn bytes_to_path(bytes: Vec<u8>) -> Option<PathBuf> {
    use std::os::unix::ffi::OsStringExt;
    Some(PathBuf::from(std::ffi::OsString::from_vec(bytes)))
}

#[cfg(not(unix))]
fn bytes_to_path(bytes: Vec<u8>) -> Option<PathBuf> {
    let s = String::from_utf8(bytes).ok()?;
    // file:///C:/dir -> C:/dir
    let s = match s.as_bytes() {
        [b'/', d, b':', ..] if d.is_ascii_alphabetic() => s[1..].to_owned(),
        _ => s,
    };
    Some(PathBuf::from(s))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(s: &str) -> PathBuf {
        PathBuf::from(s)
    }

    #[test]
    fn triple_slash() {
        assert_eq!(
            resource_uri_to_path("file:///tmp/tmpab12/resources"),
            Ok(p("/tmp/tmpab12/resources"))
        );
    }

    #[test]
    fn single_slash() {
        assert_eq!(
            resource_uri_to_path("file:/tmp/x/resources"),
            Ok(p("/tmp/x/resources"))
        );
    }

    #[test]
    fn localhost() {
        assert_eq!(
            resource_uri_to_path("file://localhost/tmp/x/resources/"),
            Ok(p("/tmp/x/resources"))
        );
        assert_eq!(
            resource_uri_to_path("file://LOCALHOST/tmp/x"),
            Ok(p("/tmp/x"))
        );
    }

    #[test]
    fn trailing_slash_or_not() {
        assert_eq!(
            resource_uri_to_path("file:///tmp/x/resources/"),
            Ok(p("/tmp/x/resources"))
        );
        assert_eq!(
            resource_uri_to_path("file:///tmp/x/resources//"),
            Ok(p("/tmp/x/resources"))
        );
        assert_eq!(resource_uri_to_path("file:///"), Ok(p("/")));
    }

    #[test]
    fn scheme_is_case_insensitive() {
        assert_eq!(resource_uri_to_path("FILE:///tmp/x"), Ok(p("/tmp/x")));
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(
            resource_uri_to_path("file:///tmp/my%20dir/res%2Fx"),
            Ok(p("/tmp/my dir/res/x"))
        );
        assert_eq!(
            resource_uri_to_path("file:///tmp/%C3%A9t%c3%a9"),
            Ok(p("/tmp/été"))
        );
        assert_eq!(
            resource_uri_to_path("file:///tmp/100%25"),
            Ok(p("/tmp/100%"))
        );
    }

    #[test]
    fn invalid_escapes() {
        assert!(matches!(
            resource_uri_to_path("file:///tmp/a%2"),
            Err(UriError::BadEscape { position: 13, .. })
        ));
        assert!(matches!(
            resource_uri_to_path("file:///tmp/a%zz"),
            Err(UriError::BadEscape { .. })
        ));
        assert!(matches!(
            resource_uri_to_path("file:///tmp/a%"),
            Err(UriError::BadEscape { .. })
        ));
        assert!(matches!(
            resource_uri_to_path("file:///tmp/a%00b"),
            Err(UriError::BadEscape { .. })
        ));
    }

    #[test]
    fn not_a_file_uri() {
        for uri in [
            "http://example.com/res",
            "https:///tmp/x",
            "/tmp/x",
            "",
            "fil:///tmp",
        ] {
            let err = resource_uri_to_path(uri).unwrap_err();
            assert!(matches!(err, UriError::NotFile(_)), "{uri}: {err:?}");
            assert!(err.to_string().contains("not a file: URI"));
        }
    }

    #[test]
    fn remote_host_and_relative_paths() {
        assert!(matches!(
            resource_uri_to_path("file://server/share/x"),
            Err(UriError::RemoteHost { .. })
        ));
        assert!(matches!(
            resource_uri_to_path("file:relative/x"),
            Err(UriError::NotAbsolute(_))
        ));
        assert!(matches!(
            resource_uri_to_path("file://"),
            Err(UriError::NotAbsolute(_))
        ));
    }
}
