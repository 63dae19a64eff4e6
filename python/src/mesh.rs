//! `Mesh`: a frame's surface as numpy arrays, saved as the commands write it.

use super::*;

/// The surface of one frame: numpy arrays handed over without a copy.
#[pyclass(module = "activeskin", frozen)]
pub(crate) struct Mesh {
    /// Vertex positions, `(n, 3)` float32, world units.
    #[pyo3(get)]
    pub(crate) vertices: Py<PyArray2<f32>>,
    /// Triangles as vertex indices, `(m, 3)` uint32, counter-clockwise seen from outside.
    #[pyo3(get)]
    pub(crate) triangles: Py<PyArray2<u32>>,
    /// Unit outward normals, `(n, 3)` float32.
    #[pyo3(get)]
    pub(crate) normals: Py<PyArray2<f32>>,
    /// The surface's velocity at each vertex, `(n, 3)` float32, world units per second
    /// (None when the skin was made with `velocities=False`).
    #[pyo3(get)]
    pub(crate) velocities: Option<Py<PyArray2<f32>>>,
    /// The particles' attributes at each vertex, by name: `(n,)` or `(n, 3)` float32.
    #[pyo3(get)]
    pub(crate) attributes: Py<PyDict>,
    /// The frame's number.
    #[pyo3(get)]
    pub(crate) frame: i64,
    /// The frame's measures: the fields of the command's `--stats` lines.
    #[pyo3(get)]
    pub(crate) stats: Py<PyDict>,
}

impl Mesh {
    /// The mesh, its velocities and attributes back as the library's, to write.
    pub(crate) fn contents(
        &self,
        py: Python<'_>,
    ) -> PyResult<(SkinMesh, Option<Vec<Vec3>>, Vec<Attribute>)> {
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
    pub(crate) fn new(
        py: Python<'_>,
        surface: FrameSurface,
        time: f64,
    ) -> PyResult<(Self, SettledSkin)> {
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
    pub(crate) fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
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
    pub(crate) fn save_usd(
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

    pub(crate) fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Mesh(frame={}, vertices={}, triangles={})",
            self.frame,
            self.vertices.bind(py).len(),
            self.triangles.bind(py).len()
        )
    }
}
