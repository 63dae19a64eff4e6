//! File formats, one module each. Leaves first — `file` (extensions, errors, atomic
//! writes), `points`, `scalar`, `mesh_write` — then the formats, then the dispatchers by
//! extension (`mesh`, `particles`, `image`); nothing here imports upward or in a circle
//! (`tests/layers.rs`).

pub mod bgeo;
pub mod exr;
pub mod file;
pub mod image;
pub mod json;
pub mod mesh;
mod mesh_write;
pub mod obj;
pub mod particles;
pub mod ply;
pub mod png;
mod points;
mod scalar;
pub mod text;
pub mod usd;
#[cfg(feature = "vdb")]
pub mod vdb;
pub mod vtk;
pub mod vtu;

pub use file::{
    error_chain, has_extension, not_a_file, printable, read_regular, remove_temporaries,
    temporary_path, write_atomically, EagerWriteback, WriteError,
};
pub use points::{find_array, PointArray};
