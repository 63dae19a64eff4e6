//! Meshes to and from files: OBJ ([`super::obj`]) or PLY ([`super::ply`]) chosen by
//! extension, each written through a temporary file renamed into place.

use std::path::Path;

pub use super::mesh_write::{MeshError, MeshFault, VertexValues};
use crate::mesh::Mesh;

/// The extensions [`write`] knows, lowercase.
pub const EXTENSIONS: &[&str] = &["obj", "ply"];

/// Whether `path` ends in one of [`EXTENSIONS`] (any case): checked before a run.
pub fn is_written(path: &Path) -> bool {
    super::file::has_extension(path, EXTENSIONS)
}

/// OBJ or PLY by the file's extension.
pub fn write(mesh: &Mesh, path: &Path) -> Result<(), MeshError> {
    write_with_values(mesh, VertexValues::default(), path)
}

/// Whether a mesh file at `path` keeps [`VertexValues`].
pub fn holds_values(path: &Path) -> bool {
    super::file::has_extension(path, &["ply"])
}

/// [`write`] with the vertices' values.
pub fn write_with_values(mesh: &Mesh, values: VertexValues, path: &Path) -> Result<(), MeshError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
    {
        Some(e) if e == "obj" => super::obj::write(mesh, path),
        Some(e) if e == "ply" => super::ply::write_mesh(mesh, values, path),
        _ => Err(MeshError::new(path, MeshFault::Extension)),
    }
}
