//! File output helpers shared by every writer.

use std::path::{Path, PathBuf};

/// The temporary name a file is written under before being renamed to `path`: hidden,
/// in the same folder (so the rename is atomic), unique to this process.
pub fn temporary_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Runs `write` on a temporary path, then renames it to `path`. On any failure the
/// temporary file is removed and `path` is left as it was.
pub fn write_atomically<F>(path: &Path, write: F) -> Result<(), String>
where
    F: FnOnce(&Path) -> Result<(), String>,
{
    let tmp = temporary_path(path);
    let result = write(&tmp).and_then(|()| std::fs::rename(&tmp, path).map_err(|e| e.to_string()));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An injected failing writer (a disk that fills up half-way): the earlier file
    /// stays as it was and no temporary is left.
    #[test]
    fn a_writer_failing_half_way_leaves_the_earlier_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.0001.vdb");
        std::fs::write(&path, b"the earlier, whole frame").unwrap();
        let result = write_atomically(&path, |tmp| {
            std::fs::write(tmp, b"half a fr").map_err(|e| e.to_string())?;
            Err("No space left on device (os error 28)".into())
        });
        assert_eq!(result.unwrap_err(), "No space left on device (os error 28)");
        assert_eq!(std::fs::read(&path).unwrap(), b"the earlier, whole frame");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "a temporary file was left");
    }
}
