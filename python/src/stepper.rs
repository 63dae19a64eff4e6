//! A skin's frame loop on a thread of its own, the GIL released while it computes.

use super::*;

/// A frame's number, settled skin and the surface's velocity at its voxels (when asked
/// for): what its VDB holds.
pub(crate) type SettledSkin = (i64, GridData, Option<VoxelVelocities>);

/// A skin's frame loop on its thread, and what Python sees of it.
pub(crate) struct Stepper<T> {
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
    pub(crate) fn new(stream: FrameStream<T>, fps: f64, first_frame: i64) -> Self {
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
    pub(crate) fn check(&self) -> PyResult<()> {
        match &self.broken {
            Some(why) => Err(PyRuntimeError::new_err(why.clone())),
            None => Ok(()),
        }
    }

    /// Hands `frame` over and waits for its surface with the GIL released, checking for
    /// Ctrl-C every 50 ms.
    pub(crate) fn advance(&mut self, py: Python<'_>, frame: T) -> PyResult<Py<Mesh>> {
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

    pub(crate) fn mesh(&self, py: Python<'_>) -> Option<Py<Mesh>> {
        self.last.as_ref().map(|m| m.clone_ref(py))
    }

    pub(crate) fn stats(&self, py: Python<'_>) -> Option<Py<PyDict>> {
        self.last.as_ref().map(|m| m.get().stats.clone_ref(py))
    }

    #[cfg(feature = "vdb")]
    pub(crate) fn save_vdb(&self, py: Python<'_>, path: &std::path::Path) -> PyResult<()> {
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
    pub(crate) fn save_vdb(&self, _py: Python<'_>, _path: &std::path::Path) -> PyResult<()> {
        Err(no_vdb())
    }
}
