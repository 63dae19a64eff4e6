//! Renders to files: EXR ([`super::exr`]) or PNG ([`super::png`]) by extension, written
//! through a temporary file renamed into place.

use std::path::Path;

use crate::render::Render;

/// A surface could not be rendered or written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct RenderError {
    pub path: String,
    pub message: String,
}

/// Writes by extension: `.exr` (RGBA, Z, N.X/N.Y/N.Z) or `.png` (beauty over grey).
pub fn write(render: &Render, path: &Path) -> Result<(), RenderError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let error = |message: String| RenderError {
        path: path.display().to_string(),
        message,
    };
    let write: fn(&Render, &Path) -> Result<(), String> = match ext.as_deref() {
        Some("exr") => super::exr::write,
        Some("png") => super::png::write,
        _ => return Err(error("renders must end in .exr or .png".into())),
    };
    super::write_atomically(path, |tmp| write(render, tmp)).map_err(error)
}
