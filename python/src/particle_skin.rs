//! `ParticleSkin`: the `particles` command frame by frame.

use super::*;

/// A sequence's first frame, `(frame, positions, radii)`: the volume held.
pub(crate) type Reference<'py> = (
    i64,
    PyArrayLike2<'py, f32, AllowTypeChange>,
    Option<PyArrayLike1<'py, f32, AllowTypeChange>>,
);

/// A skin on a particle simulation, advanced one frame at a time by its particles —
/// the `particles` command's frame loop, fed from memory.
///
/// ```python
/// skin = activeskin.ParticleSkin(radius=0.005, fps=24)
/// for positions, velocities, ids in frames:
///     mesh = skin.advance(positions, velocities=velocities, ids=ids)
///     mesh.save(f"out/skin.{mesh.frame:04d}.ply")
/// ```
#[pyclass(module = "activeskin")]
pub(crate) struct ParticleSkin {
    frames: Stepper<Particles>,
    attributes: AttributeChoice,
}

#[pymethods]
impl ParticleSkin {
    #[new]
    #[pyo3(signature = (radius, *, voxel_size=None, alpha=DEFAULT_ALPHA, beta=None, smooth=None, smoothing_length=DEFAULT_SMOOTHING_LENGTH, iso=None, fps=DEFAULT_FPS, velocities=true, hold_volume=true, attributes=None, first_frame=1, ignore_radii=false, volume_reference=None, velocity_grid=false, region=None, collider=None, collider_gap=None, collider_depth=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        radius: f32,
        voxel_size: Option<f32>,
        alpha: f32,
        beta: Option<f32>,
        smooth: Option<f32>,
        smoothing_length: f32,
        iso: Option<f32>,
        fps: f64,
        velocities: bool,
        hold_volume: bool,
        attributes: Option<Vec<String>>,
        first_frame: i64,
        ignore_radii: bool,
        volume_reference: Option<Reference>,
        velocity_grid: bool,
        region: Option<Bound<'_, PyAny>>,
        collider: Option<std::path::PathBuf>,
        collider_gap: Option<f32>,
        collider_depth: f32,
    ) -> PyResult<Self> {
        let defaults = ParticleInput::with_radius(radius);
        let choice = match attributes {
            None => AttributeChoice::None,
            Some(names) if names.iter().any(|n| n == "all") => AttributeChoice::All,
            Some(names) => AttributeChoice::Named(names),
        };
        let particles = ParticleInput {
            smoothing_length,
            iso: iso.unwrap_or_else(|| fluid_iso(smoothing_length)),
            dx: voxel_size.unwrap_or(defaults.dx),
            attributes: choice.clone(),
            ignore_radii,
            ..defaults
        };
        let reference = match volume_reference {
            Some((frame, positions, radii)) => {
                let positions = points("volume_reference positions", &positions)?;
                let n = positions.len();
                let radii = match radii {
                    Some(r) if r.as_array().len() != n => {
                        return Err(PyValueError::new_err(format!(
                            "volume_reference radii must have one per particle ({n})"
                        )))
                    }
                    r => r.map(|r| r.as_array().to_vec()),
                };
                let particles = Particles {
                    positions,
                    radii,
                    ..Particles::default()
                };
                particles.check().map_err(|e| {
                    PyValueError::new_err(format!("volume_reference {}: {e}", e.field()))
                })?;
                Some((frame, particles))
            }
            None => None,
        };
        let dx = particles.dx;
        let physics = Physics {
            alpha,
            beta,
            smoothing: smooth,
            ..Physics::default()
        };
        let spec = StreamSpec {
            params: physics.particle_params(radius, dx),
            particles,
            fps,
            hold_volume,
            velocities,
            velocity_grid,
            first_frame,
            reference,
            region: region.map(|r| region_box(&r)).transpose()?,
            collider: collider_spec(collider, collider_gap, collider_depth)?,
        };
        let stream = ParticleStream::start(spec).map_err(value_error)?;
        Ok(ParticleSkin {
            frames: Stepper::new(stream, fps, first_frame),
            attributes: choice,
        })
    }

    /// Advances the skin to the next frame's particles and returns its surface.
    ///
    /// `positions` is `(n, 3)`; `velocities` `(n, 3)` (world units per second) and `ids`
    /// `(n,)` when the simulation has them — particles matched by id carry the skin by
    /// their own displacements; `attributes` maps names to `(n,)` or `(n, 3)` arrays;
    /// `radii` `(n,)` gives particles their own radius (unless `ignore_radii`).
    /// Any float dtype and any strides are accepted (converted once). The GIL is
    /// released while the frame computes; Ctrl-C raises KeyboardInterrupt (the skin
    /// cannot go on after it).
    #[pyo3(signature = (positions, velocities=None, ids=None, attributes=None, radii=None))]
    fn advance(
        &mut self,
        py: Python<'_>,
        positions: &Bound<'_, PyAny>,
        velocities: Option<&Bound<'_, PyAny>>,
        ids: Option<&Bound<'_, PyAny>>,
        attributes: Option<Bound<'_, PyDict>>,
        radii: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<Mesh>> {
        self.frames.check()?;
        let positions = points("positions", &array2("positions", positions)?)?;
        let n = positions.len();
        let velocities = match velocities {
            Some(v) => {
                let v = array2("velocities", v)?;
                if v.as_array().nrows() != n {
                    return Err(PyValueError::new_err(format!(
                        "velocities must have one row per particle ({n})"
                    )));
                }
                Some(points("velocities", &v)?)
            }
            None => None,
        };
        let ids = ids.map(|i| array1::<i64>("ids", i, n)).transpose()?;
        let radii = radii.map(|r| array1::<f32>("radii", r, n)).transpose()?;
        let mut carried = Vec::new();
        if let Some(dict) = attributes {
            for (name, array) in dict.iter() {
                let name: String = name.extract().map_err(|_| {
                    PyValueError::new_err("attributes must be a dict of names (str) to arrays")
                })?;
                let (components, values) = attribute_values(&name, &array, n)?;
                carried.push(Attribute {
                    name,
                    components,
                    values,
                });
            }
        }
        let particles = Particles {
            positions,
            velocities,
            ids,
            radii,
            attributes: carried,
        };
        // As the command checks a file's particles, with the argument named.
        particles
            .check()
            .map_err(|e| PyValueError::new_err(format!("{}: {e}", e.field())))?;
        self.frames.advance(py, particles)
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

    /// The attributes carried onto the surface: None, a list of names, or ["all"].
    #[getter]
    fn attributes(&self) -> Option<Vec<String>> {
        match &self.attributes {
            AttributeChoice::None => None,
            AttributeChoice::All => Some(vec!["all".into()]),
            AttributeChoice::Named(names) => Some(names.clone()),
        }
    }
}
