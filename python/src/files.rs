//! Files and sequences as the commands read them; the memory budget.

use super::*;

/// Reads one particle file as the command reads it (PLY, VTK, VTU, BGEO, JSON, CSV, XYZ):
/// a dict of `positions` (n, 3), `velocities` (n, 3) or None, `ids` (n,) or None,
/// `radii` (n,) or None, and `attributes` by name.
#[pyfunction]
pub(crate) fn read_particles(
    py: Python<'_>,
    path: std::path::PathBuf,
) -> PyResult<Bound<'_, PyDict>> {
    let particles = py
        .detach(|| activeskin::io::particles::read(&path))
        .map_err(|e| PyValueError::new_err(said(&e)))?;
    let out = PyDict::new(py);
    out.set_item("positions", vectors_array(py, particles.positions))?;
    out.set_item(
        "velocities",
        particles.velocities.map(|v| vectors_array(py, v)),
    )?;
    out.set_item(
        "ids",
        particles.ids.map(|i| Array1::from_vec(i).into_pyarray(py)),
    )?;
    out.set_item(
        "radii",
        particles
            .radii
            .map(|r| Array1::from_vec(r).into_pyarray(py)),
    )?;
    let named = attributes_dict(py, particles.attributes)?;
    out.set_item("attributes", named)?;
    Ok(out)
}

/// Sets the most memory a frame may take, in GB, as the command's `--max-memory` does
/// (0 for the default: three quarters of the machine's memory or of `ulimit -v`). Work
/// that would take more is refused with a `MemoryError` before it is allocated.
#[pyfunction]
pub(crate) fn set_memory_budget(gb: f64) -> PyResult<()> {
    if !(gb.is_finite() && gb >= 0.0) {
        return Err(PyValueError::new_err(format!(
            "the memory budget must be a non-negative number of GB, got {gb}"
        )));
    }
    activeskin::budget::set_bytes((gb * 1e9) as u64);
    Ok(())
}

/// A sequence's frames as the commands find them: `(first, last, found, held)` — the range
/// (`frames`, else every frame found), the frames on disk, and whether `pattern` is one
/// file held for every frame (a file without a frame number, with `frames` given).
#[pyfunction]
#[pyo3(signature = (pattern, frames=None))]
pub(crate) fn sequence_frames(
    pattern: std::path::PathBuf,
    frames: Option<(i64, i64)>,
) -> PyResult<(i64, i64, Vec<i64>, bool)> {
    let input =
        activeskin::frames::InputFrames::find(Field::Target, &pattern.to_string_lossy(), frames)
            .map_err(value_error)?;
    let (first, last) = input.range;
    Ok((first, last, input.existing, input.pattern.is_held()))
}

/// A frame's file in `pattern` (`####`, `%04d`, `$F4`, `$F`, `#` or `{}`), as the commands
/// name it.
#[pyfunction]
pub(crate) fn frame_path(pattern: std::path::PathBuf, frame: i64) -> PyResult<std::path::PathBuf> {
    let pattern = activeskin::sequence::FramePattern::parse(&pattern.to_string_lossy())
        .map_err(|e| PyValueError::new_err(said(&e)))?;
    Ok(pattern.path(frame))
}

/// The frames a farm chunk or a resumed bake warms up on before its first, as the
/// commands' `--warmup auto`: enough for the start to fade to 1/40 (ln(40)·fps/α).
#[pyfunction]
#[pyo3(signature = (alpha=DEFAULT_ALPHA, fps=DEFAULT_FPS))]
pub(crate) fn warmup_frames(alpha: f32, fps: f64) -> i64 {
    activeskin::frames::auto_warmup(f64::from(alpha), fps)
}

/// The voxel size a particle skin of `radius` takes when none is given.
#[pyfunction]
pub(crate) fn particle_voxel_size(radius: f32) -> f32 {
    activeskin::frames::ParticleInput::with_radius(radius).dx
}

/// The most memory a frame may take, in GB ([`set_memory_budget`]).
#[pyfunction]
pub(crate) fn memory_budget() -> f64 {
    activeskin::budget::bytes() as f64 / 1e9
}
