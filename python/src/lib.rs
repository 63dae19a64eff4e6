//! `activeskin` for Python: a particle skin advanced by numpy arrays frame by frame,
//! through the library's own frame loop ([`ParticleStream`]) — the surfaces the
//! `particles` command makes from the same particles, byte for byte. A thin front end:
//! arrays in and out, parameters checked by the library, its messages raised as
//! `ValueError`.

use std::time::Duration;

use activeskin::frames::{
    AttributeChoice, FrameError, FrameSurface, ParticleInput, ParticleStream, StreamSpec,
};
use activeskin::io::mesh::{write_with_values, VertexValues};
use activeskin::mesh::Mesh as SkinMesh;
use activeskin::particles::{Attribute, Particles};
use activeskin::skin::{SkinParams, SpeedParams};
use activeskin::target::fluid_iso;
use glam::Vec3;
use numpy::ndarray::{Array1, Array2};
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray2, PyArrayLike1, PyArrayLike2, PyArrayMethods,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn value_error(e: FrameError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// `n × 3` floats as points, checked.
fn points(name: &str, array: &PyArrayLike2<f32, AllowTypeChange>) -> PyResult<Vec<Vec3>> {
    let view = array.as_array();
    if view.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must be an (n, 3) array, got shape {:?}",
            view.shape()
        )));
    }
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
fn attribute_values(array: &Bound<'_, PyAny>) -> PyResult<(usize, Vec<f32>)> {
    match array.extract::<PyArrayLike2<f32, AllowTypeChange>>() {
        Ok(two) => {
            let view = two.as_array();
            Ok((view.ncols(), view.iter().copied().collect()))
        }
        Err(_) => {
            let one: PyArrayLike1<f32, AllowTypeChange> = array.extract()?;
            Ok((1, one.as_array().to_vec()))
        }
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
    fn new(py: Python<'_>, surface: FrameSurface, time: f64) -> PyResult<Self> {
        let FrameSurface {
            frame,
            mesh,
            velocities,
            attributes,
            stats,
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
        Ok(Mesh {
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
        })
    }
}

#[pymethods]
impl Mesh {
    /// Writes the mesh as OBJ or PLY by the extension (PLY with the velocities and
    /// attributes), as the command writes it.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
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
            let (components, values) = attribute_values(&array)?;
            attributes.push(Attribute {
                name: name.extract()?,
                components,
                values,
            });
        }
        let values = VertexValues {
            velocities: velocities.as_deref(),
            attributes: &attributes,
        };
        py.detach(|| write_with_values(&mesh, values, &path))
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.to_string()))
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
    /// Behind a mutex for Python's threads (`&mut self` methods reach it without locking).
    stream: std::sync::Mutex<Option<ParticleStream>>,
    fps: f64,
    first_frame: i64,
    attributes: AttributeChoice,
    /// Why the skin cannot go on (an interrupt mid-frame, an error).
    broken: Option<String>,
    /// The surface of the frame last advanced to.
    last: Option<Py<Mesh>>,
}

#[pymethods]
impl ParticleSkin {
    #[new]
    #[pyo3(signature = (radius, *, voxel_size=None, alpha=4.0, beta=None, smoothing_length=2.0, iso=None, fps=24.0, velocities=true, hold_volume=true, attributes=None, first_frame=1, ignore_radii=false, volume_reference=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        radius: f32,
        voxel_size: Option<f32>,
        alpha: f32,
        beta: Option<f32>,
        smoothing_length: f32,
        iso: Option<f32>,
        fps: f64,
        velocities: bool,
        hold_volume: bool,
        attributes: Option<Vec<String>>,
        first_frame: i64,
        ignore_radii: bool,
        volume_reference: Option<Reference>,
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
            Some((frame, positions, radii)) => Some((
                frame,
                Particles {
                    positions: points("volume_reference positions", &positions)?,
                    radii: radii.map(|r| r.as_array().to_vec()),
                    ..Particles::default()
                },
            )),
            None => None,
        };
        let dx = particles.dx;
        let speed = SpeedParams::default_for(dx, alpha);
        let spec = StreamSpec {
            params: SkinParams {
                dx,
                speed: SpeedParams {
                    alpha,
                    beta: beta.unwrap_or(speed.beta),
                    ..speed
                },
                ..SkinParams::default()
            },
            particles,
            fps,
            hold_volume,
            velocities,
            first_frame,
            reference,
        };
        let stream = ParticleStream::start(spec).map_err(value_error)?;
        Ok(ParticleSkin {
            stream: std::sync::Mutex::new(Some(stream)),
            fps,
            first_frame,
            attributes: choice,
            broken: None,
            last: None,
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
        positions: PyArrayLike2<f32, AllowTypeChange>,
        velocities: Option<PyArrayLike2<f32, AllowTypeChange>>,
        ids: Option<PyArrayLike1<i64, AllowTypeChange>>,
        attributes: Option<Bound<'_, PyDict>>,
        radii: Option<PyArrayLike1<f32, AllowTypeChange>>,
    ) -> PyResult<Py<Mesh>> {
        if let Some(why) = &self.broken {
            return Err(PyRuntimeError::new_err(why.clone()));
        }
        let positions = points("positions", &positions)?;
        let n = positions.len();
        let velocities = velocities.map(|v| points("velocities", &v)).transpose()?;
        if velocities.as_ref().is_some_and(|v| v.len() != n) {
            return Err(PyValueError::new_err(format!(
                "velocities must have one row per particle ({n})"
            )));
        }
        let ids = ids.map(|i| i.as_array().to_vec());
        if ids.as_ref().is_some_and(|i| i.len() != n) {
            return Err(PyValueError::new_err(format!(
                "ids must have one per particle ({n})"
            )));
        }
        let radii = radii.map(|r| r.as_array().to_vec());
        if radii.as_ref().is_some_and(|r| r.len() != n) {
            return Err(PyValueError::new_err(format!(
                "radii must have one per particle ({n})"
            )));
        }
        let mut carried = Vec::new();
        if let Some(dict) = attributes {
            for (name, array) in dict.iter() {
                let name: String = name.extract()?;
                let (components, values) = attribute_values(&array)?;
                if !(components == 1 || components == 3) || values.len() != components * n {
                    return Err(PyValueError::new_err(format!(
                        "attribute '{name}' must be an ({n},) or ({n}, 3) array"
                    )));
                }
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
        let stream = self
            .stream
            .get_mut()
            .map_err(|_| PyRuntimeError::new_err("the skin has stopped"))?
            .as_mut()
            .ok_or_else(|| PyRuntimeError::new_err("the skin has stopped"))?;
        if let Err(e) = stream.send(particles) {
            return Err(value_error(e));
        }
        let surface = loop {
            match py.detach(|| stream.wait(Duration::from_millis(50))) {
                Ok(Some(surface)) => break surface,
                Ok(None) => {
                    if let Err(interrupt) = py.check_signals() {
                        self.broken = Some(
                            "interrupted mid-frame: make a new ParticleSkin to start again".into(),
                        );
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
        let mesh = Py::new(py, Mesh::new(py, surface, time)?)?;
        self.last = Some(mesh.clone_ref(py));
        Ok(mesh)
    }

    /// The surface of the frame last advanced to (None before the first).
    #[getter]
    fn mesh(&self, py: Python<'_>) -> Option<Py<Mesh>> {
        self.last.as_ref().map(|m| m.clone_ref(py))
    }

    /// The last frame's measures (the `--stats` fields), None before the first.
    #[getter]
    fn stats(&self, py: Python<'_>) -> Option<Py<PyDict>> {
        self.last.as_ref().map(|m| m.get().stats.clone_ref(py))
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

/// Reads one particle file as the command reads it (PLY, VTK, VTU, BGEO, JSON, CSV, XYZ):
/// a dict of `positions` (n, 3), `velocities` (n, 3) or None, `ids` (n,) or None,
/// `radii` (n,) or None, and `attributes` by name.
#[pyfunction]
fn read_particles(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Bound<'_, PyDict>> {
    let particles = py
        .detach(|| activeskin::io::particles::read(&path))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
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

#[pymodule]
fn _activeskin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_particles, m)?)?;
    m.add_class::<ParticleSkin>()?;
    m.add_class::<Mesh>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
