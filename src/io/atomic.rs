//! Atomic file replacement: write a temporary file next to the target, then
//! rename it over the target.
//!
//! Why: goldens and reports are overwritten in place. A crash, a full disk or
//! an encoder error halfway through must leave the previous good file, not a
//! truncated one that the next run would compare against. A rename within one
//! directory is atomic on POSIX file systems (and replaces the target on
//! Windows), which is why the temporary file lives in the target's directory
//! rather than in the system temp directory, possibly on another file system.

use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, ErrorKind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::error::HdrIoError;

/// Distinguishes temporary files of concurrent writes from one process.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Runs `write` into a temporary file and renames it to `path` only if
/// `write` succeeded; otherwise (error or panic) the temporary file is
/// removed and `path` is left as it was.
pub(crate) fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), HdrIoError>,
) -> Result<(), HdrIoError> {
    let file_name = path.display().to_string();
    let io_error = |action: &'static str| {
        let file = file_name.clone();
        move |source: std::io::Error| HdrIoError::Io {
            file,
            action,
            source,
        }
    };

    let (temp_path, temp_file) =
        create_temp_next_to(path).map_err(io_error("create a temporary file next to"))?;
    let mut guard = RemoveOnDrop(Some(temp_path.clone()));

    let mut writer = BufWriter::new(temp_file);
    write(&mut writer)?;
    let file = writer
        .into_inner()
        .map_err(|e| e.into_error())
        .map_err(io_error("write"))?;
    // Flush to disk before the rename, or a crash could leave the new name
    // pointing at an empty file.
    file.sync_all().map_err(io_error("write"))?;
    drop(file);
    fs::rename(&temp_path, path).map_err(io_error("replace"))?;
    guard.0 = None;
    Ok(())
}

fn create_temp_next_to(path: &Path) -> std::io::Result<(PathBuf, File)> {
    let directory = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| std::io::Error::new(ErrorKind::InvalidInput, "the path has no file name"))?;
    loop {
        let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
        // Hidden, and ending in .tmp so that globs for *.png or *.exr skip it.
        let candidate = directory.join(format!(".{name}.{}-{n}.tmp", std::process::id()));
        match OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&candidate)
        {
            Ok(file) => return Ok((candidate, file)),
            Err(e) if e.kind() == ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
}

/// Removes the temporary file on every exit path that did not rename it,
/// including a panic inside an encoder.
struct RemoveOnDrop(Option<PathBuf>);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        if let Some(path) = self.0.take() {
            let _ = fs::remove_file(path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), HdrIoError> {
        write_atomically(path, |w| {
            w.write_all(bytes).map_err(|source| HdrIoError::Io {
                file: path.display().to_string(),
                action: "write",
                source,
            })
        })
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("golden.png");
        write_bytes_atomically(&target, b"good").unwrap();

        let result = write_atomically(&target, |w| {
            w.write_all(b"half of a new fi").unwrap();
            Err(HdrIoError::Encode {
                file: "golden.png".into(),
                format: "PNG",
                detail: "simulated failure".into(),
            })
        });
        assert!(matches!(result, Err(HdrIoError::Encode { .. })));
        assert_eq!(fs::read(&target).unwrap(), b"good");
        assert_eq!(entries(dir.path()), vec!["golden.png"]);
    }

    #[test]
    fn a_panicking_encoder_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.exr");
        let outcome = std::panic::catch_unwind(|| {
            let _ = write_atomically(&target, |w| {
                w.write_all(b"partial").unwrap();
                panic!("encoder bug");
            });
        });
        assert!(outcome.is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn a_successful_write_replaces_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("a.pfm");
        write_bytes_atomically(&target, b"old").unwrap();
        write_bytes_atomically(&target, b"new").unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"new");
        assert_eq!(entries(dir.path()), vec!["a.pfm"]);
    }

    #[test]
    fn a_missing_directory_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("no-such-dir").join("a.pfm");
        let message = write_bytes_atomically(&target, b"x")
            .unwrap_err()
            .to_string();
        assert!(message.contains("no-such-dir"), "{message}");
    }
}
