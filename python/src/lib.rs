//! `activeskin` for Python: a particle skin advanced by numpy arrays frame by frame,
//! through the library's own frame loop ([`ParticleStream`]) — the surfaces the
//! `particles` command makes from the same particles, byte for byte. A thin front end:
//! arrays in and out, parameters checked by the library, its messages raised as
//! `ValueError`.

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

fn value_error(e: FrameError) -> PyErr {
    match &e {
        // Refused before allocating: Python's own word for it, which a caller can catch.
        FrameError::OverBudget(_) | FrameError::Skin(SkinError::OverBudget { .. }) => {
            PyMemoryError::new_err(said(&e))
        }
        _ => PyValueError::new_err(said(&e)),
    }
}

/// A library message as Python says it: each field it names as the argument that sets it
/// (`radius=`), not as the command's flag.
fn said(message: &impl ToString) -> String {
    spell(&message.to_string(), |field| match field {
        Field::TargetUnits => "units=".into(),
        Field::NoVelocity => "velocities=False".into(),
        Field::MaxMemory => "activeskin.set_memory_budget()".into(),
        Field::Target | Field::Particles => "pattern".into(),
        Field::Usd => "the stage".into(),
        Field::ShotFrames => "frames=".into(),
        other => format!("{}=", other.name()),
    })
}

/// What `object` is, for a message: its shape when it has one, else its type.
fn described(object: &Bound<'_, PyAny>) -> String {
    match object.getattr("shape") {
        Ok(shape) => format!("shape {shape}"),
        Err(_) => match object.get_type().name() {
            Ok(name) => format!("a {name}"),
            Err(_) => "something else".into(),
        },
    }
}

/// `object` as a 2-D array of float32 (converted once, any strides), or a `ValueError`
/// naming the argument.
fn array2<'py>(
    name: &str,
    object: &Bound<'py, PyAny>,
) -> PyResult<PyArrayLike2<'py, f32, AllowTypeChange>> {
    object.extract().map_err(|_| {
        PyValueError::new_err(format!(
            "{name} must be an (n, 3) array of numbers, got {}",
            described(object)
        ))
    })
}

/// `object` as a 1-D array of `n` values, copied, or a `ValueError` naming the argument.
fn array1<T: numpy::Element + Copy>(
    name: &str,
    object: &Bound<'_, PyAny>,
    n: usize,
) -> PyResult<Vec<T>>
where
    for<'a, 'py> PyArrayLike1<'py, T, AllowTypeChange>: FromPyObject<'a, 'py>,
{
    let wrong = || {
        PyValueError::new_err(format!(
            "{name} must be an ({n},) array of numbers, one per particle, got {}",
            described(object)
        ))
    };
    let array: PyArrayLike1<T, AllowTypeChange> = object.extract().map_err(|_| wrong())?;
    let view = array.as_array();
    // The length first: a broadcast view of billions of rows is never copied.
    if view.len() != n {
        return Err(wrong());
    }
    Ok(view.to_vec())
}

/// `n` particles within the memory budget, before their arrays are copied: a
/// `MemoryError` otherwise (a copy past the machine's memory would abort the process,
/// and the artist's Blender with it).
fn fits(name: &str, n: usize) -> PyResult<()> {
    use activeskin::budget;
    budget::particles_fit(n).map_err(|needed| {
        PyMemoryError::new_err(format!(
            "{name}: {n} particles would take at least {}, over the memory budget of {}: activeskin.set_memory_budget(gb) allows more",
            budget::size(needed),
            budget::size(budget::bytes())
        ))
    })
}

/// `n × 3` floats as points, checked: shape, then the memory budget, then copied.
fn points(name: &str, array: &PyArrayLike2<f32, AllowTypeChange>) -> PyResult<Vec<Vec3>> {
    let view = array.as_array();
    if view.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must be an (n, 3) array, got shape {:?}",
            view.shape()
        )));
    }
    fits(name, view.nrows())?;
    Ok(view
        .rows()
        .into_iter()
        .map(|r| Vec3::new(r[0], r[1], r[2]))
        .collect())
}

/// Vectors as an `n × 3` numpy array, handed over without a copy.
fn vectors_array(py: Python<'_>, vectors: Vec<Vec3>) -> Bound<'_, PyArray2<f32>> {
    let n = vectors.len();
    let flat: Vec<f32> = flatten(vectors);
    Array2::from_shape_vec((n, 3), flat)
        .expect("3 floats a vector")
        .into_pyarray(py)
}

/// `Vec<Vec3>` as its floats, without copying them.
fn flatten(vectors: Vec<Vec3>) -> Vec<f32> {
    let mut vectors = std::mem::ManuallyDrop::new(vectors);
    let (ptr, len, capacity) = (vectors.as_mut_ptr(), vectors.len(), vectors.capacity());
    // SAFETY: glam's `Vec3` is `#[repr(C)]` of three `f32` (size 12, alignment 4, no
    // SIMD padding), so an allocation of `capacity` vectors is one of `3 * capacity`
    // floats with the same layout, and the first `3 * len` are initialised.
    unsafe { Vec::from_raw_parts(ptr.cast::<f32>(), 3 * len, 3 * capacity) }
}

/// Attributes as numpy arrays by name, `(n,)` or `(n, c)`, handed over without a copy.
fn attributes_dict(py: Python<'_>, attributes: Vec<Attribute>) -> PyResult<Bound<'_, PyDict>> {
    let named = PyDict::new(py);
    for a in attributes {
        let array = match a.components {
            1 => Array1::from_vec(a.values).into_pyarray(py).into_any(),
            c => Array2::from_shape_vec((a.values.len() / c, c), a.values)
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?
                .into_pyarray(py)
                .into_any(),
        };
        named.set_item(a.name, array)?;
    }
    Ok(named)
}

/// An attribute's array, `(n,)` or `(n, c)` of any number type: its components and its
/// values as floats, row by row.
/// An attribute's `(n,)` or `(n, 3)` values and its components, checked before they are
/// copied.
fn attribute_values(name: &str, array: &Bound<'_, PyAny>, n: usize) -> PyResult<(usize, Vec<f32>)> {
    let wrong = || {
        PyValueError::new_err(format!(
            "attribute '{name}' must be an ({n},) or ({n}, 3) array, got {}",
            described(array)
        ))
    };
    match array.extract::<PyArrayLike2<f32, AllowTypeChange>>() {
        Ok(two) => {
            let view = two.as_array();
            if view.nrows() != n || view.ncols() != 3 {
                return Err(wrong());
            }
            Ok((3, view.iter().copied().collect()))
        }
        Err(_) => Ok((
            1,
            array1(&format!("attribute '{name}'"), array, n).map_err(|_| wrong())?,
        )),
    }
}

/// The surface of one frame: numpy arrays handed over without a copy.
#[pyclass(module = "activeskin", frozen)]
struct Mesh {
    /// Vertex positions, `(n, 3)` float32, world units.
    #[pyo3(get)]
    vertices: Py<PyArray2<f32>>,
    /// Triangles as vertex indices, `(m, 3)` uint32, counter-clockwise seen from outside.
    #[pyo3(get)]
    triangles: Py<PyArray2<u32>>,
    /// Unit outward normals, `(n, 3)` float32.
    #[pyo3(get)]
    normals: Py<PyArray2<f32>>,
    /// The surface's velocity at each vertex, `(n, 3)` float32, world units per second
    /// (None when the skin was made with `velocities=False`).
    #[pyo3(get)]
    velocities: Option<Py<PyArray2<f32>>>,
    /// The particles' attributes at each vertex, by name: `(n,)` or `(n, 3)` float32.
    #[pyo3(get)]
    attributes: Py<PyDict>,
    /// The frame's number.
    #[pyo3(get)]
    frame: i64,
    /// The frame's measures: the fields of the command's `--stats` lines.
    #[pyo3(get)]
    stats: Py<PyDict>,
}

impl Mesh {
    /// The mesh, its velocities and attributes back as the library's, to write.
    fn contents(&self, py: Python<'_>) -> PyResult<(SkinMesh, Option<Vec<Vec3>>, Vec<Attribute>)> {
        let read = |a: &Py<PyArray2<f32>>| -> Vec<Vec3> {
            let a = a.bind(py).readonly();
            a.as_array()
                .rows()
                .into_iter()
                .map(|r| Vec3::new(r[0], r[1], r[2]))
                .collect()
        };
        let triangles = self.triangles.bind(py).readonly();
        let mesh = SkinMesh {
            positions: read(&self.vertices),
            normals: read(&self.normals),
            triangles: triangles
                .as_array()
                .rows()
                .into_iter()
                .map(|r| [r[0], r[1], r[2]])
                .collect(),
        };
        let velocities = self.velocities.as_ref().map(read);
        let mut attributes = Vec::new();
        for (name, array) in self.attributes.bind(py).iter() {
            let name: String = name.extract()?;
            let (components, values) = attribute_values(&name, &array, mesh.positions.len())?;
            attributes.push(Attribute {
                name,
                components,
                values,
            });
        }
        Ok((mesh, velocities, attributes))
    }

    /// The mesh of `surface`, and its settled skin.
    fn new(py: Python<'_>, surface: FrameSurface, time: f64) -> PyResult<(Self, SettledSkin)> {
        let FrameSurface {
            frame,
            mesh,
            velocities,
            attributes,
            stats,
            level_set,
            voxel_velocities,
        } = surface;
        let n_triangles = mesh.triangles.len();
        let triangles: Vec<u32> = {
            let mut t = std::mem::ManuallyDrop::new(mesh.triangles);
            let (ptr, len, capacity) = (t.as_mut_ptr(), t.len(), t.capacity());
            // SAFETY: `[u32; 3]` is three `u32` with no padding (size 12, alignment 4):
            // the allocation is `3 * capacity` `u32`, the first `3 * len` initialised.
            unsafe { Vec::from_raw_parts(ptr.cast::<u32>(), 3 * len, 3 * capacity) }
        };
        let named = attributes_dict(py, attributes)?;
        let measures = PyDict::new(py);
        measures.set_item("frame", frame)?;
        measures.set_item("time", time)?;
        measures.set_item("substeps", stats.substeps)?;
        measures.set_item("band_nodes", stats.band_nodes)?;
        measures.set_item("blocks", stats.blocks)?;
        measures.set_item("area", stats.area)?;
        measures.set_item("volume", stats.volume)?;
        measures.set_item("euler_characteristic", stats.euler_characteristic)?;
        measures.set_item("components", stats.components)?;
        let mesh = Mesh {
            vertices: vectors_array(py, mesh.positions).unbind(),
            normals: vectors_array(py, mesh.normals).unbind(),
            triangles: Array2::from_shape_vec((n_triangles, 3), triangles)
                .expect("3 indices a triangle")
                .into_pyarray(py)
                .unbind(),
            velocities: velocities.map(|v| vectors_array(py, v).unbind()),
            attributes: named.unbind(),
            frame,
            stats: measures.unbind(),
        };
        Ok((mesh, (frame, level_set, voxel_velocities)))
    }
}

#[pymethods]
impl Mesh {
    /// Writes the mesh as OBJ or PLY by the extension (PLY with the velocities and
    /// attributes), as the command writes it.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let (mesh, velocities, attributes) = self.contents(py)?;
        let values = VertexValues {
            velocities: velocities.as_deref(),
            attributes: &attributes,
        };
        py.detach(|| write_with_values(&mesh, values, &path))
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(said(&e)))
    }

    /// Writes the mesh as its frame of the USD shot `stage` (`.usda`) over `frames`
    /// (first, last), as the command's `--usd` does: the frame's layer beside the stage,
    /// and the stage, the same for every frame of the shot.
    #[pyo3(signature = (stage, frames, *, fps=DEFAULT_FPS, up="y", meters_per_unit=1.0))]
    fn save_usd(
        &self,
        py: Python<'_>,
        stage: std::path::PathBuf,
        frames: (i64, i64),
        fps: f64,
        up: &str,
        meters_per_unit: f64,
    ) -> PyResult<()> {
        let up = match up {
            "y" | "Y" => Up::Y,
            "z" | "Z" => Up::Z,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "up must be \"y\" or \"z\", got {up:?}"
                )))
            }
        };
        let (mesh, velocities, attributes) = self.contents(py)?;
        let values = VertexValues {
            velocities: velocities.as_deref(),
            attributes: &attributes,
        };
        let spec = UsdSpec {
            stage,
            meters_per_unit,
            shot: Some(frames),
        };
        py.detach(|| write_usd_frame(&spec, self.frame, (fps, up), &mesh, values))
            .map_err(|e| match e {
                FrameError::Usage(_) => value_error(e),
                _ => pyo3::exceptions::PyOSError::new_err(said(&e)),
            })
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Mesh(frame={}, vertices={}, triangles={})",
            self.frame,
            self.vertices.bind(py).len(),
            self.triangles.bind(py).len()
        )
    }
}

/// A frame's number, settled skin and the surface's velocity at its voxels (when asked
/// for): what its VDB holds.
type SettledSkin = (i64, GridData, Option<VoxelVelocities>);

/// A skin's frame loop on its thread, and what Python sees of it.
struct Stepper<T> {
    /// Behind a mutex for Python's threads (`&mut self` methods reach it without locking).
    stream: std::sync::Mutex<Option<FrameStream<T>>>,
    fps: f64,
    first_frame: i64,
    /// Why the skin cannot go on (an interrupt mid-frame, an error).
    broken: Option<String>,
    /// The surface of the frame last advanced to.
    last: Option<Py<Mesh>>,
    /// Its settled skin, for `save_vdb`.
    level_set: Option<SettledSkin>,
}

impl<T: Send + 'static> Stepper<T> {
    fn new(stream: FrameStream<T>, fps: f64, first_frame: i64) -> Self {
        Stepper {
            stream: std::sync::Mutex::new(Some(stream)),
            fps,
            first_frame,
            broken: None,
            last: None,
            level_set: None,
        }
    }

    /// Refuses to go on after an interrupt or an error.
    fn check(&self) -> PyResult<()> {
        match &self.broken {
            Some(why) => Err(PyRuntimeError::new_err(why.clone())),
            None => Ok(()),
        }
    }

    /// Hands `frame` over and waits for its surface with the GIL released, checking for
    /// Ctrl-C every 50 ms.
    fn advance(&mut self, py: Python<'_>, frame: T) -> PyResult<Py<Mesh>> {
        self.check()?;
        let stream = self
            .stream
            .get_mut()
            .map_err(|_| PyRuntimeError::new_err("the skin has stopped"))?
            .as_mut()
            .ok_or_else(|| PyRuntimeError::new_err("the skin has stopped"))?;
        if let Err(e) = stream.send(frame) {
            return Err(value_error(e));
        }
        let surface = loop {
            match py.detach(|| stream.wait(Duration::from_millis(50))) {
                Ok(Some(surface)) => break surface,
                Ok(None) => {
                    if let Err(interrupt) = py.check_signals() {
                        self.broken =
                            Some("interrupted mid-frame: make a new skin to start again".into());
                        return Err(interrupt);
                    }
                }
                Err(e) => {
                    self.broken = Some(format!("the skin stopped: {e}"));
                    return Err(value_error(e));
                }
            }
        };
        let time = (surface.frame - self.first_frame) as f64 / self.fps;
        let (mesh, settled) = Mesh::new(py, surface, time)?;
        self.level_set = Some(settled);
        let mesh = Py::new(py, mesh)?;
        self.last = Some(mesh.clone_ref(py));
        Ok(mesh)
    }

    fn mesh(&self, py: Python<'_>) -> Option<Py<Mesh>> {
        self.last.as_ref().map(|m| m.clone_ref(py))
    }

    fn stats(&self, py: Python<'_>) -> Option<Py<PyDict>> {
        self.last.as_ref().map(|m| m.get().stats.clone_ref(py))
    }

    #[cfg(feature = "vdb")]
    fn save_vdb(&self, py: Python<'_>, path: &std::path::Path) -> PyResult<()> {
        let (frame, level_set, velocities) = self
            .level_set
            .as_ref()
            .ok_or_else(|| PyRuntimeError::new_err("no frame yet: advance the skin first"))?;
        py.detach(|| {
            activeskin::frames::write_skin_vdb(path, *frame, level_set, velocities.as_ref())
        })
        .map_err(|e| pyo3::exceptions::PyOSError::new_err(said(&e)))
    }

    #[cfg(not(feature = "vdb"))]
    fn save_vdb(&self, _py: Python<'_>, _path: &std::path::Path) -> PyResult<()> {
        Err(no_vdb())
    }
}

/// The error of a VDB file asked of a wheel built without OpenVDB.
#[cfg(not(feature = "vdb"))]
fn no_vdb() -> PyErr {
    PyRuntimeError::new_err(
        "this activeskin was built without OpenVDB: build the wheel with `maturin build --release --features vdb` (needs libopenvdb-dev) to read and write VDB files",
    )
}

/// A sequence's first frame, `(frame, positions, radii)`: the volume held.
type Reference<'py> = (
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
struct ParticleSkin {
    frames: Stepper<Particles>,
    attributes: AttributeChoice,
}

#[pymethods]
impl ParticleSkin {
    #[new]
    #[pyo3(signature = (radius, *, voxel_size=None, alpha=DEFAULT_ALPHA, beta=None, smooth=None, smoothing_length=DEFAULT_SMOOTHING_LENGTH, iso=None, fps=DEFAULT_FPS, velocities=true, hold_volume=true, attributes=None, first_frame=1, ignore_radii=false, volume_reference=None, velocity_grid=false))]
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

/// What a level set's distances are in, by name.
fn units_named(units: &str) -> PyResult<TargetUnits> {
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
struct Lattice {
    spacing: Option<f32>,
    origin: [f64; 3],
}

/// A target as handed to `LevelSetSkin`: a VDB file's path, or a dense `(nx, ny, nz)`
/// array of distances (or densities, `fog`) on `lattice`, with an `(nx, ny, nz, 3)`
/// velocity array beside it.
fn level_set_frame(
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
fn vdb_frame(
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
fn vdb_frame(
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
fn measure_velocity<'py>(
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
struct LevelSetSkin {
    frames: Stepper<LevelSetFrame>,
    lattice: Lattice,
    fog: bool,
    next_frame: i64,
}

#[pymethods]
impl LevelSetSkin {
    #[new]
    #[pyo3(signature = (*, voxel_size=None, alpha=DEFAULT_ALPHA, beta=None, smooth=None, volume_gain=0.0, area_gain=0.0, fps=DEFAULT_FPS, velocities=true, velocity_time="start", velocity_scale=1.0, iso=None, units="auto", first_frame=1, seed=true, init=None, spacing=None, origin=(0.0, 0.0, 0.0), grid=None, velocity_grid=false))]
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

/// Reads one particle file as the command reads it (PLY, VTK, VTU, BGEO, JSON, CSV, XYZ):
/// a dict of `positions` (n, 3), `velocities` (n, 3) or None, `ids` (n,) or None,
/// `radii` (n,) or None, and `attributes` by name.
#[pyfunction]
fn read_particles(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Bound<'_, PyDict>> {
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
fn set_memory_budget(gb: f64) -> PyResult<()> {
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
fn sequence_frames(
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
fn frame_path(pattern: std::path::PathBuf, frame: i64) -> PyResult<std::path::PathBuf> {
    let pattern = activeskin::sequence::FramePattern::parse(&pattern.to_string_lossy())
        .map_err(|e| PyValueError::new_err(said(&e)))?;
    Ok(pattern.path(frame))
}

/// The frames a farm chunk or a resumed bake warms up on before its first, as the
/// commands' `--warmup auto`: enough for the start to fade to 1/40 (ln(40)·fps/α).
#[pyfunction]
#[pyo3(signature = (alpha=DEFAULT_ALPHA, fps=DEFAULT_FPS))]
fn warmup_frames(alpha: f32, fps: f64) -> i64 {
    activeskin::frames::auto_warmup(f64::from(alpha), fps)
}

/// The most memory a frame may take, in GB ([`set_memory_budget`]).
#[pyfunction]
fn memory_budget() -> f64 {
    activeskin::budget::bytes() as f64 / 1e9
}

#[pymodule]
fn _activeskin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_particles, m)?)?;
    m.add_function(wrap_pyfunction!(set_memory_budget, m)?)?;
    m.add_function(wrap_pyfunction!(memory_budget, m)?)?;
    m.add_function(wrap_pyfunction!(sequence_frames, m)?)?;
    m.add_function(wrap_pyfunction!(frame_path, m)?)?;
    m.add_function(wrap_pyfunction!(warmup_frames, m)?)?;
    m.add("DEFAULT_ALPHA", DEFAULT_ALPHA)?;
    m.add("DEFAULT_FPS", DEFAULT_FPS)?;
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
