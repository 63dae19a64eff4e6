//! # activeskin
//!
//! Active implicit skins (Desbrun & Cani, 1997) for moving targets: a potential on a
//! block-sparse grid whose zero isosurface is attracted to a target (VDB level set or fog
//! volume, particles, analytic shape) while behaving like a membrane with surface tension.
//!
//! Files come and go through OpenVDB ([`vdb`]):
//!
//! ```no_run
//! use activeskin::vdb::{self, Grid, WriteOptions, FileMetadata};
//! # fn main() -> Result<(), activeskin::Error> {
//! let sphere = Grid::level_set_sphere(1.0, [0.0; 3], 0.05, 3.0)?;
//! let data = sphere.to_data()?; // leaf by leaf, in Rust
//! let back = Grid::from_data(&data)?;
//! let meta = FileMetadata { creator: "activeskin".into(), has_frame: true, frame: 1 };
//! vdb::write_grids("sphere.0001.vdb".as_ref(), &[(&back, WriteOptions::default())], &meta)?;
//! # Ok(()) }
//! ```

pub mod grid;
pub mod io;
pub mod mesh;
pub mod particles;
pub mod polygonize;
pub mod render;
pub mod sequence;
pub mod skin;
pub mod stencil;
pub mod target;
#[cfg(feature = "vdb")]
pub mod validate;
#[cfg(feature = "vdb")]
pub mod vdb;
pub mod volume;

/// Every error of the library, one variant per stage.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[cfg(feature = "vdb")]
    #[error(transparent)]
    Vdb(#[from] vdb::VdbError),
    #[error(transparent)]
    Mesh(#[from] mesh::MeshError),
    #[error(transparent)]
    Skin(#[from] skin::SkinError),
    #[error(transparent)]
    Pattern(#[from] sequence::PatternError),
    #[error(transparent)]
    Render(#[from] render::RenderError),
    #[error(transparent)]
    Particles(#[from] particles::ParticleError),
}
