//! The `.fmu` archive: `modelDescription.xml`, `binaries/linux64/scm.so`, `resources/`,
//! `documentation/index.html`.
//!
//! The archive is written to a temporary file next to `out` and renamed at the end, so a failed
//! pack never leaves a half-written `.fmu`. Entries carry a fixed timestamp, so the same inputs
//! give the same bytes.

use std::collections::BTreeSet;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

/// Path of the shared library inside the FMU.
pub const LIBRARY_ENTRY: &str = "binaries/linux64/scm.so";

/// Why an FMU could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file that failed.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The zip writer failed.
    #[error("{path}: zip: {source}")]
    Zip {
        /// The archive being written.
        path: PathBuf,
        /// The zip error.
        source: zip::result::ZipError,
    },
    /// The folder the archive is to be written into does not exist.
    #[error("{path}: the folder {} does not exist (create it first)", folder.display())]
    NoFolder {
        /// The archive asked for.
        path: PathBuf,
        /// Its folder.
        folder: PathBuf,
    },
    /// A resource name that would escape `resources/` or is not portable.
    #[error("resource name {name:?} is not allowed: {reason}")]
    BadResourceName {
        /// The name given.
        name: String,
        /// Why it is refused.
        reason: &'static str,
    },
}

/// Checks that a resource name is a relative path with `/` separators that stays inside
/// `resources/`.
pub fn check_resource_name(name: &str) -> Result<(), PackError> {
    let bad = |reason| {
        Err(PackError::BadResourceName {
            name: name.to_owned(),
            reason,
        })
    };
    if name.is_empty() {
        return bad("empty name");
    }
    if name.contains('\\') {
        return bad("backslashes are not allowed (use '/')");
    }
    if name.starts_with('/') || name.as_bytes().get(1) == Some(&b':') {
        return bad("absolute names are not allowed");
    }
    if name.contains('\0') {
        return bad("NUL is not allowed");
    }
    for component in name.split('/') {
        match component {
            ".." => return bad("'..' is not allowed"),
            "." | "" => return bad("empty or '.' path components are not allowed"),
            _ => {}
        }
    }
    Ok(())
}

/// Writes the FMU `out` (see the module documentation). `resources` are `(name, bytes)` with
/// names relative to `resources/`.
pub fn write_fmu(
    out: &Path,
    model_description_xml: &str,
    library: &Path,
    resources: &[(String, Vec<u8>)],
    documentation_html: Option<&str>,
) -> Result<(), PackError> {
    let mut names = BTreeSet::new();
    for (name, _) in resources {
        check_resource_name(name)?;
        if !names.insert(name.as_str()) {
            return Err(PackError::BadResourceName {
                name: name.clone(),
                reason: "given twice",
            });
        }
    }
    // Checked here so that the error names the folder, not the temporary file beside `out`.
    if let Some(folder) = out.parent().filter(|f| !f.as_os_str().is_empty()) {
        if !folder.is_dir() {
            return Err(PackError::NoFolder {
                path: out.to_owned(),
                folder: folder.to_owned(),
            });
        }
    }
    let library_bytes = std::fs::read(library).map_err(|source| PackError::Io {
        path: library.to_owned(),
        source,
    })?;

    let file_name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out.fmu".into());
    let temp = out.with_file_name(format!(".{file_name}.{}.tmp", std::process::id()));
    let result = write_archive(
        &temp,
        out,
        model_description_xml,
        &library_bytes,
        resources,
        documentation_html,
    )
    .and_then(|()| {
        std::fs::rename(&temp, out).map_err(|source| PackError::Io {
            path: out.to_owned(),
            source,
        })
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result
}

/// Writes the archive to `path`; errors name `shown` (the file the user asked for).
fn write_archive(
    path: &Path,
    shown: &Path,
    model_description_xml: &str,
    library: &[u8],
    resources: &[(String, Vec<u8>)],
    documentation_html: Option<&str>,
) -> Result<(), PackError> {
    let io = |source| PackError::Io {
        path: shown.to_owned(),
        source,
    };
    let zip_err = |source| PackError::Zip {
        path: shown.to_owned(),
        source,
    };
    let file = File::create(path).map_err(io)?;
    let mut zip = ZipWriter::new(BufWriter::new(file));
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(DateTime::default())
        .unix_permissions(0o644);
    let mut entries: Vec<(String, &[u8], u32)> = vec![
        (
            "modelDescription.xml".into(),
            model_description_xml.as_bytes(),
            0o644,
        ),
        (LIBRARY_ENTRY.into(), library, 0o755),
    ];
    entries.extend(
        resources
            .iter()
            .map(|(name, bytes)| (format!("resources/{name}"), bytes.as_slice(), 0o644)),
    );
    if let Some(html) = documentation_html {
        entries.push(("documentation/index.html".into(), html.as_bytes(), 0o644));
    }
    for (name, bytes, mode) in entries {
        zip.start_file(name, options.unix_permissions(mode))
            .map_err(zip_err)?;
        zip.write_all(bytes).map_err(io)?;
    }
    let writer = zip.finish().map_err(zip_err)?;
    let file = writer.into_inner().map_err(|e| io(e.into_error()))?;
    file.sync_all().map_err(io)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    fn temp_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("scm-pack-test-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn read_entry(archive: &mut zip::ZipArchive<File>, name: &str) -> Vec<u8> {
        let mut f = archive
            .by_name(name)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let mut v = Vec::new();
        f.read_to_end(&mut v).unwrap();
        v
    }

    #[test]
    fn writes_every_part_and_reads_back() {
        let dir = temp_dir("ok");
        let lib = dir.join("libscm.so");
        std::fs::write(&lib, b"\x7fELF fake library").unwrap();
        let out = dir.join("scene.fmu");
        let resources = vec![
            ("scene.xml".to_string(), b"<mujoco/>".to_vec()),
            ("meshes/a.obj".to_string(), b"v 0 0 0\n".to_vec()),
        ];
        write_fmu(
            &out,
            "<fmiModelDescription/>",
            &lib,
            &resources,
            Some("<html>doc</html>"),
        )
        .unwrap();

        let mut archive = zip::ZipArchive::new(File::open(&out).unwrap()).unwrap();
        let mut names: Vec<String> = archive
            .file_names()
            .map(|n| n.unwrap().into_owned())
            .collect();
        names.sort();
        assert_eq!(
            names,
            [
                "binaries/linux64/scm.so",
                "documentation/index.html",
                "modelDescription.xml",
                "resources/meshes/a.obj",
                "resources/scene.xml"
            ]
        );
        assert_eq!(
            read_entry(&mut archive, "modelDescription.xml"),
            b"<fmiModelDescription/>"
        );
        assert_eq!(
            read_entry(&mut archive, "binaries/linux64/scm.so"),
            b"\x7fELF fake library"
        );
        assert_eq!(
            read_entry(&mut archive, "resources/meshes/a.obj"),
            b"v 0 0 0\n"
        );
        assert_eq!(
            read_entry(&mut archive, "documentation/index.html"),
            b"<html>doc</html>"
        );
        assert_eq!(
            archive
                .by_name("binaries/linux64/scm.so")
                .unwrap()
                .unix_mode()
                .map(|m| m & 0o777),
            Some(0o755)
        );
        // no temporary file left behind
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left.len(), 2, "{left:?}");

        // reproducible: same inputs, same bytes
        let first = std::fs::read(&out).unwrap();
        write_fmu(
            &out,
            "<fmiModelDescription/>",
            &lib,
            &resources,
            Some("<html>doc</html>"),
        )
        .unwrap();
        assert_eq!(first, std::fs::read(&out).unwrap());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn without_documentation() {
        let dir = temp_dir("nodoc");
        let lib = dir.join("lib.so");
        std::fs::write(&lib, b"x").unwrap();
        let out = dir.join("a.fmu");
        write_fmu(&out, "<x/>", &lib, &[], None).unwrap();
        let archive = zip::ZipArchive::new(File::open(&out).unwrap()).unwrap();
        assert_eq!(archive.len(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn refuses_bad_resource_names() {
        for name in [
            "../evil",
            "a/../../b",
            "/etc/passwd",
            "a\\b",
            "",
            "a//b",
            "./a",
            "C:/x",
        ] {
            assert!(
                matches!(
                    check_resource_name(name),
                    Err(PackError::BadResourceName { .. })
                ),
                "{name:?}"
            );
        }
        for name in ["scene.xml", "meshes/a.obj", "a..b"] {
            assert!(check_resource_name(name).is_ok(), "{name:?}");
        }
        let dir = temp_dir("bad");
        let lib = dir.join("lib.so");
        std::fs::write(&lib, b"x").unwrap();
        let out = dir.join("a.fmu");
        let err = write_fmu(&out, "<x/>", &lib, &[("../x".into(), vec![])], None).unwrap_err();
        assert!(err.to_string().contains("../x"), "{err}");
        assert!(!out.exists());
        let dup = vec![("a".to_string(), vec![]), ("a".to_string(), vec![])];
        assert!(write_fmu(&out, "<x/>", &lib, &dup, None).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn failure_names_the_path_and_leaves_nothing() {
        let dir = temp_dir("fail");
        let out = dir.join("a.fmu");
        let missing = dir.join("no-such-lib.so");
        let err = write_fmu(&out, "<x/>", &missing, &[], None).unwrap_err();
        assert!(err.to_string().contains("no-such-lib.so"), "{err}");
        assert!(!out.exists());
        let out_in_missing_dir = dir.join("no-such-dir").join("a.fmu");
        let lib = dir.join("lib.so");
        std::fs::write(&lib, b"x").unwrap();
        let err = write_fmu(&out_in_missing_dir, "<x/>", &lib, &[], None).unwrap_err();
        // The path asked for and its folder, not the temporary file beside it.
        let text = err.to_string();
        assert!(
            text.starts_with(&format!("{}: ", out_in_missing_dir.display()))
                && text.contains("no-such-dir does not exist")
                && !text.contains(".tmp"),
            "{err}"
        );
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left.len(), 1, "{left:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
