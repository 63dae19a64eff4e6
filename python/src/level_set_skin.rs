//! `LevelSetSkin` and the velocity measure: the `skin` and `morph` commands frame by frame.

use super::*;

/// What a level set's distances are in, by name.
pub(crate) fn units_named(units: &str) -> PyResult<TargetUnits> {
    match units {
        "auto" => Ok(TargetUnits::Auto),
        "world" => Ok(TargetUnits::World),
        "voxel" => Ok(TargetUnits::Voxel),
        other => Err(PyValueError::new_err(format!(
            "units must be 'auto', 'world' or 'voxel', got '{other}'"
        ))),
    }
}

/// How a target's grid is placed when it is an array.
#[derive(Clone, Copy)]
pub(crate) struct Lattice {
    spacing: Option<f32>,
    origin: [f64; 3],
}

/// A target as handed to `LevelSetSkin`: a VDB file's path, or a dense `(nx, ny, nz)`
/// array of distances (or densities, `fog`) on `lattice`, with an `(nx, ny, nz, 3)`
/// velocity array beside it.
pub(crate) fn level_set_frame(
    target: &Bound<'_, PyAny>,
    velocity: Option<&Bound<'_, PyAny>>,
    (lattice, fog, grid): (Lattice, bool, Option<&str>),
    label: String,
) -> PyResult<LevelSetFrame> {
    if let Ok(path) = target.extract::<std::path::PathBuf>() {
        return vdb_frame(target.py(), &path, velocity, grid);
    }
    let array: PyArrayLikeDyn<f32, AllowTypeChange> = target.extract().map_err(|_| {
        PyValueError::new_err("a target is a path to a VDB file or an (nx, ny, nz) array")
    })?;
    let view = array.as_array();
    let dims: [usize; 3] = view.shape().try_into().map_err(|_| {
        PyValueError::new_err(format!(
            "an array target must be (nx, ny, nz), got shape {:?}",
            view.shape()
        ))
    })?;
    let spacing = lattice.spacing.ok_or_else(|| {
        PyValueError::new_err("an array target needs its voxel size: give spacing=")
    })?;
    // In C order whatever the array's strides.
    let values: Vec<f32> = view.iter().copied().collect();
    let class = match fog {
        true => GridClass::FogVolume,
        false => GridClass::LevelSet,
    };
    let grid = dense_grid(class, (dims, &values), spacing, lattice.origin).map_err(value_error)?;
    let velocity = match velocity {
        None => None,
        Some(v) if v.is_none() => None,
        Some(v) => {
            let array: PyArrayLikeDyn<f32, AllowTypeChange> = v.extract().map_err(|_| {
                PyValueError::new_err("an array target's velocity is an (nx, ny, nz, 3) array")
            })?;
            let view = array.as_array();
            if view.shape() != [dims[0], dims[1], dims[2], 3] {
                return Err(PyValueError::new_err(format!(
                    "the velocity must be ({}, {}, {}, 3), as the target, got shape {:?}",
                    dims[0],
                    dims[1],
                    dims[2],
                    view.shape()
                )));
            }
            let flat: Vec<f32> = view.iter().copied().collect();
            let vectors: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            Some(VectorGrid::from_dense(
                "velocity",
                (dims, &vectors),
                grid.transform,
            ))
        }
    };
    Ok(LevelSetFrame {
        grid,
        velocity,
        label: label.into(),
    })
}

/// A VDB file's target and velocity: `velocity` None for the file's `vel`, `v` or
/// `velocity` grid when it has one, False for none, a name for that grid.
#[cfg(feature = "vdb")]
pub(crate) fn vdb_frame(
    py: Python<'_>,
    path: &std::path::Path,
    velocity: Option<&Bound<'_, PyAny>>,
    grid: Option<&str>,
) -> PyResult<LevelSetFrame> {
    use activeskin::frames::{read_level_set_frame, VelocitySource};
    let source = match velocity {
        None => VelocitySource::Auto,
        Some(v) if v.is_none() => VelocitySource::Auto,
        Some(v) => match (v.extract::<bool>(), v.extract::<String>()) {
            (Ok(false), _) => VelocitySource::Off,
            (_, Ok(name)) => VelocitySource::Named(name),
            _ => {
                return Err(PyValueError::new_err(
                    "a VDB target's velocity is read from its file: velocity=None (its vel, v or velocity grid), False (none) or a grid's name",
                ))
            }
        },
    };
    py.detach(|| read_level_set_frame(path, grid, source))
        .map_err(value_error)
}

#[cfg(not(feature = "vdb"))]
pub(crate) fn vdb_frame(
    _py: Python<'_>,
    _path: &std::path::Path,
    _velocity: Option<&Bound<'_, PyAny>>,
    _grid: Option<&str>,
) -> PyResult<LevelSetFrame> {
    Err(no_vdb())
}

/// Measures what turns a VDB sequence's velocity into world units per second, and which
/// frames' velocity carries each interval, as the `skin` command does by default
/// (`--velocity-scale auto --velocity-time auto`): a dict of `scale` (None when the
/// velocity does not explain the surface's motion: leave it out), `timing` ("start" or
/// "mid") and `note` (the command's line); None when the files hold no velocity.
#[cfg(feature = "vdb")]
#[pyfunction]
#[pyo3(signature = (pattern, *, frames=None, grid=None, velocity=None, fps=DEFAULT_FPS, units="auto", velocity_time=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn measure_velocity<'py>(
    py: Python<'py>,
    pattern: std::path::PathBuf,
    frames: Option<(i64, i64)>,
    grid: Option<String>,
    velocity: Option<String>,
    fps: f64,
    units: &str,
    velocity_time: Option<&str>,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    use activeskin::frames::{InputFrames, VelocityInput, VelocitySource};
    let timing = match velocity_time {
        None => None,
        Some("start") => Some(Timing::Start),
        Some("mid") => Some(Timing::Mid),
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "velocity_time must be 'start' or 'mid', got '{other}'"
            )))
        }
    };
    let units = units_named(units)?;
    let spec = pattern.to_string_lossy().into_owned();
    let settled = py
        .detach(|| {
            let input = InputFrames::find(Field::Target, &spec, frames)?;
            let mut measured = VelocityInput {
                source: velocity.map_or(VelocitySource::Auto, VelocitySource::Named),
                files: None,
                scale: 1.0,
            };
            measured.settle_scale(&input, (grid.as_deref(), units), fps, timing)
        })
        .map_err(value_error)?;
    let Some((estimate, note)) = settled else {
        return Ok(None);
    };
    let out = PyDict::new(py);
    out.set_item("scale", estimate.scale)?;
    out.set_item("timing", estimate.timing.name())?;
    out.set_item("note", said(&note))?;
    Ok(Some(out))
}

/// A skin on a sequence of level sets or fog volumes — a liquid simulation's surface
/// (Mantaflow's `phi`, Houdini's `surface`), or a morph's end shape — advanced one frame
/// at a time: the `skin` command's frame loop (`morph`'s with `seed=False` and `init`),
/// fed from memory.
///
/// ```python
/// skin = activeskin.LevelSetSkin(spacing=0.02, origin=(-1, -1, -1), fps=24)
/// for phi, velocity in frames:        # (nx, ny, nz) and (nx, ny, nz, 3) arrays
///     mesh = skin.advance(phi, velocity)
/// ```
#[pyclass(module = "activeskin")]
pub(crate) struct LevelSetSkin {
    frames: Stepper<LevelSetFrame>,
    lattice: Lattice,
    fog: bool,
    next_frame: i64,
}

#[pymethods]
impl LevelSetSkin {
    #[new]
    #[pyo3(signature = (*, voxel_size=None, alpha=DEFAULT_ALPHA, beta=None, smooth=None, volume_gain=0.0, area_gain=0.0, fps=DEFAULT_FPS, velocities=true, velocity_time="start", velocity_scale=1.0, iso=None, units="auto", first_frame=1, seed=true, init=None, spacing=None, origin=(0.0, 0.0, 0.0), grid=None, velocity_grid=false, region=None, collider=None, collider_gap=None, collider_depth=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        voxel_size: Option<f32>,
        alpha: f32,
        beta: Option<f32>,
        smooth: Option<f32>,
        volume_gain: f32,
        area_gain: f32,
        fps: f64,
        velocities: bool,
        velocity_time: &str,
        velocity_scale: f32,
        iso: Option<f32>,
        units: &str,
        first_frame: i64,
        seed: bool,
        init: Option<Bound<'_, PyAny>>,
        spacing: Option<f32>,
        origin: (f64, f64, f64),
        grid: Option<String>,
        velocity_grid: bool,
        region: Option<Bound<'_, PyAny>>,
        collider: Option<std::path::PathBuf>,
        collider_gap: Option<f32>,
        collider_depth: f32,
    ) -> PyResult<Self> {
        let timing = match velocity_time {
            "start" => Timing::Start,
            "mid" => Timing::Mid,
            other => {
                return Err(PyValueError::new_err(format!(
                    "velocity_time must be 'start' or 'mid', got '{other}'"
                )))
            }
        };
        let lattice = Lattice {
            spacing,
            origin: [origin.0, origin.1, origin.2],
        };
        let fog = iso.is_some();
        let init = init
            .map(|i| level_set_frame(&i, None, (lattice, false, grid.as_deref()), "init".into()))
            .transpose()?;
        let spec = LevelSetSpec {
            physics: Physics {
                voxel_size,
                alpha,
                beta,
                volume_gain,
                area_gain,
                smoothing: smooth,
                ..Physics::default()
            },
            fps,
            timing,
            velocity_scale,
            iso,
            units: units_named(units)?,
            velocities,
            velocity_grid,
            first_frame,
            seed,
            init,
            region: region.map(|r| region_box(&r)).transpose()?,
            collider: collider_spec(collider, collider_gap, collider_depth)?,
        };
        let stream = py
            .detach(|| LevelSetStream::start(spec))
            .map_err(value_error)?;
        Ok(LevelSetSkin {
            frames: Stepper::new(stream, fps, first_frame),
            lattice,
            fog,
            next_frame: first_frame,
        })
    }

    /// Advances the skin to the next frame's target and returns its surface.
    ///
    /// `target` is a path to a VDB file (a level set, or a fog volume when the skin has
    /// an `iso`; its `grid`, else its first float grid) or an `(nx, ny, nz)` array of
    /// signed distances (negative inside; in world units or voxels, see `units`) or of
    /// densities, voxel (i, j, k) centred at `origin + (i, j, k) * spacing`.
    /// `velocity` (world units per second) is an `(nx, ny, nz, 3)` array beside an
    /// array target; for a VDB file, None reads its `vel`, `v` or `velocity` grid, False
    /// none, a string that grid. Any float dtype and any strides are accepted.
    #[pyo3(signature = (target, velocity=None, *, spacing=None, origin=None, grid=None))]
    fn advance(
        &mut self,
        py: Python<'_>,
        target: Bound<'_, PyAny>,
        velocity: Option<Bound<'_, PyAny>>,
        spacing: Option<f32>,
        origin: Option<(f64, f64, f64)>,
        grid: Option<String>,
    ) -> PyResult<Py<Mesh>> {
        self.frames.check()?;
        let lattice = Lattice {
            spacing: spacing.or(self.lattice.spacing),
            origin: origin.map_or(self.lattice.origin, |o| [o.0, o.1, o.2]),
        };
        let frame = level_set_frame(
            &target,
            velocity.as_ref(),
            (lattice, self.fog, grid.as_deref()),
            format!("frame {}", self.next_frame),
        )?;
        let mesh = self.frames.advance(py, frame)?;
        self.next_frame += 1;
        Ok(mesh)
    }

    /// The surface of the frame last advanced to (None before the first).
    #[getter]
    fn mesh(&self, py: Python<'_>) -> Option<Py<Mesh>> {
        self.frames.mesh(py)
    }

    /// The last frame's measures (the `--stats` fields), None before the first.
    #[getter]
    fn stats(&self, py: Python<'_>) -> Option<Py<PyDict>> {
        self.frames.stats(py)
    }

    /// Writes the last frame's skin as a VDB level set (grid `surface`), as the
    /// command's `--out` does.
    fn save_vdb(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        self.frames.save_vdb(py, &path)
    }
}
