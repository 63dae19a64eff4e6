//! Renders to files: EXR ([`super::exr`]) or PNG ([`super::png`]) by extension, written
//! through a temporary file renamed into place.

use std::path::Path;

use crate::render::Render;

/// A render that could not be written: the file, and the cause.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct RenderError {
    /// The image being written.
    pub path: std::path::PathBuf,
    #[source]
    /// Why it failed.
    pub source: ImageFault,
}

/// What went wrong writing an image.
#[derive(Debug, thiserror::Error)]
pub enum ImageFault {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Exr(#[from] exr::error::Error),
    #[error(transparent)]
    Png(#[from] png::EncodingError),
    #[error("renders must end in .exr or .png")]
    Extension,
}

/// The extensions [`write`] knows, lowercase.
pub const EXTENSIONS: &[&str] = &["exr", "png"];

/// Whether `path` ends in one of [`EXTENSIONS`] (any case): checked before a run.
pub fn is_written(path: &Path) -> bool {
    super::file::has_extension(path, EXTENSIONS)
}

/// Writes by extension: `.exr` (RGBA, Z, N.X/N.Y/N.Z) or `.png` (beauty over grey).
pub fn write(render: &Render, path: &Path) -> Result<(), RenderError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let error = |source| RenderError {
        path: path.to_path_buf(),
        source,
    };
    let write: fn(&Render, &Path) -> Result<(), ImageFault> = match ext.as_deref() {
        Some("exr") => |image, path| Ok(super::exr::write(image, path)?),
        Some("png") => |image, path| Ok(super::png::write(image, path)?),
        _ => return Err(error(ImageFault::Extension)),
    };
    super::file::write_atomically(path, |tmp| write(render, tmp)).map_err(error)
}
