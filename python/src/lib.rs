//! `activeskin` for Python: a particle skin advanced by numpy arrays frame by frame,
//! through the library's own frame loop ([`ParticleStream`]) — the surfaces the
//! `particles` command makes from the same particles, byte for byte. A thin front end:
//! arrays in and out, parameters checked by the library, its messages raised as
//! `ValueError`. One module a topic: `particle_skin`, `level_set_skin`, `mesh` (the
//! frame's surface), `stepper` (a skin's loop on its own thread), `files` (reading,
//! sequences, the budget), `arrays` (numpy in and out), `errors`; the imports below are
//! their shared prelude (`use super::*`).

use std::time::Duration;

use activeskin::field::{spell, Field};
use activeskin::flow::Timing;
use activeskin::frames::DEFAULT_FPS;
use activeskin::frames::{
    dense_grid, write_usd_frame, AttributeChoice, FrameError, FrameStream, FrameSurface,
    LevelSetFrame, LevelSetSpec, LevelSetStream, ParticleInput, ParticleStream, StreamSpec,
    TargetUnits, UsdSpec, VoxelVelocities,
};
use activeskin::io::mesh::{write_with_values, VertexValues};
use activeskin::mesh::Mesh as SkinMesh;
use activeskin::particles::{Attribute, Particles};
use activeskin::render::Up;
use activeskin::skin::speed::DEFAULT_ALPHA;
use activeskin::skin::Physics;
use activeskin::skin::SkinError;
use activeskin::target::fluid_iso;
use activeskin::target::DEFAULT_SMOOTHING_LENGTH;
use activeskin::volume::{GridClass, GridData, VectorGrid};
use glam::Vec3;
use numpy::ndarray::{Array1, Array2};
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray2, PyArrayLike1, PyArrayLike2, PyArrayLikeDyn,
    PyArrayMethods, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

mod arrays;
mod errors;
mod files;
mod level_set_skin;
mod mesh;
mod particle_skin;
mod stepper;

use arrays::*;
use errors::*;
use files::*;
use level_set_skin::*;
use mesh::*;
use particle_skin::*;
use stepper::*;

#[pymodule]
fn _activeskin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_particles, m)?)?;
    m.add_function(wrap_pyfunction!(set_memory_budget, m)?)?;
    m.add_function(wrap_pyfunction!(memory_budget, m)?)?;
    m.add_function(wrap_pyfunction!(sequence_frames, m)?)?;
    m.add_function(wrap_pyfunction!(frame_path, m)?)?;
    m.add_function(wrap_pyfunction!(warmup_frames, m)?)?;
    m.add_function(wrap_pyfunction!(particle_voxel_size, m)?)?;
    m.add("DEFAULT_ALPHA", DEFAULT_ALPHA)?;
    m.add("DEFAULT_FPS", DEFAULT_FPS)?;
    m.add(
        "DEFAULT_PARTICLE_SMOOTHING",
        activeskin::skin::DEFAULT_PARTICLE_SMOOTHING,
    )?;
    #[cfg(feature = "vdb")]
    m.add_function(wrap_pyfunction!(measure_velocity, m)?)?;
    m.add_class::<ParticleSkin>()?;
    m.add_class::<LevelSetSkin>()?;
    // Whether VDB files can be read and written (the `vdb` feature).
    m.add("HAS_VDB", cfg!(feature = "vdb"))?;
    m.add_class::<Mesh>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
