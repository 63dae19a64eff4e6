//! Reading and writing OpenVDB files through the C++ bridge (`vdb/ffi.rs`).
//!
//! A [`Grid`] is a handle on an OpenVDB `FloatGrid` living on the C++ side; [`crate::volume::GridData`] is
//! its Rust copy, leaf by leaf, in OpenVDB's own layout so that the transfer is a copy of
//! 512 values and 8 mask words per leaf. Tiles above leaf level (wholly inside / outside
//! regions of a level set) travel too, so nothing is lost either way.
//!
//! Files come and go through OpenVDB:
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

mod ffi;
mod layout;

use rayon::prelude::*;
use std::path::{Path, PathBuf};

use cxx::UniquePtr;
use glam::Vec3;

pub use ffi::bridge::{
    FileMetadata, GridSummary, LevelSetMeasures, MeshBuffers, MorphTiming, PointBuffers,
};

use crate::volume::{
    GridClass, GridData, Tile, Transform, VectorGrid, VectorTile, LEAF_VOXELS, MASK_WORDS,
};

/// Why reading or writing a VDB file failed. Every message fits on one line and names
/// the file.
#[derive(Debug, thiserror::Error)]
pub enum VdbError {
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    #[error("{0}")]
    Grid(String),
}

impl VdbError {
    fn file(path: &Path, message: impl std::fmt::Display) -> Self {
        VdbError::File {
            path: path.to_path_buf(),
            message: one_line(&message.to_string()),
        }
    }

    /// What went wrong, without the file name.
    pub fn reason(&self) -> String {
        match self {
            VdbError::File { message, .. } => message.clone(),
            VdbError::Grid(message) => message.clone(),
        }
    }
}

/// Why a VDB file could not be written: OpenVDB's reason, the file system's, or a file
/// that came out short.
#[derive(Debug, thiserror::Error)]
enum WriteFault {
    #[error("{0}")]
    OpenVdb(String),
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error("the file came out incomplete ({length} bytes: {reason}); is the disk out of space?")]
    Incomplete {
        length: u64,
        #[source]
        reason: layout::LayoutError,
    },
}

/// OpenVDB messages may span lines; ours must not.
fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A handle on an OpenVDB float grid.
pub struct Grid {
    inner: UniquePtr<ffi::bridge::FloatGrid>,
}

// SAFETY: the handle owns its grid (a shared_ptr no other thread holds a mutable path to);
// OpenVDB grids may be moved between threads.
unsafe impl Send for ffi::bridge::FloatGrid {}

impl Grid {
    fn from_ptr(inner: UniquePtr<ffi::bridge::FloatGrid>) -> Result<Self, VdbError> {
        if inner.is_null() {
            return Err(VdbError::Grid("the bridge returned no grid".into()));
        }
        Ok(Grid { inner })
    }

    /// Reads one float grid: `name`, or the first float grid of the file when `None`.
    pub fn read(path: &Path, name: Option<&str>) -> Result<Self, VdbError> {
        let layout = check_vdb_file(path)?;
        check_memory(path, &layout, name, "Tree_float_")?;
        let chosen = if layout.has_offsets {
            Some(
                layout
                    .choose_float_grid(name)
                    .map_err(|m| VdbError::file(path, m))?,
            )
        } else {
            // No descriptor index to look in: OpenVDB does the lookup.
            name.map(str::to_string)
        };
        let ptr =
            ffi::bridge::read_float_grid(&path.to_string_lossy(), chosen.as_deref().unwrap_or(""))
                .map_err(|e| openvdb_read_error(path, &e))?;
        Grid::from_ptr(ptr)
    }

    /// OpenVDB's `createLevelSetSphere`, named `surface` (for tests and references).
    pub fn level_set_sphere(
        radius: f32,
        center: [f32; 3],
        voxel_size: f32,
        half_width: f32,
    ) -> Result<Self, VdbError> {
        let ptr = ffi::bridge::make_level_set_sphere(radius, center, voxel_size, half_width)
            .map_err(|e| VdbError::Grid(one_line(e.what())))?;
        Grid::from_ptr(ptr)
    }

    /// OpenVDB's `meshToLevelSet` of a triangle mesh given in world coordinates, on voxels
    /// of `voxel_size` aligned with world zero, named `surface`.
    pub fn mesh_to_level_set(
        points: &[Vec3],
        triangles: &[[u32; 3]],
        voxel_size: f64,
        half_width: f32,
    ) -> Result<Self, VdbError> {
        let points: Vec<f32> = points.iter().flat_map(|p| p.to_array()).collect();
        let triangles: Vec<u32> = triangles.iter().flatten().copied().collect();
        let ptr = ffi::bridge::mesh_to_level_set(&points, &triangles, voxel_size, half_width)
            .map_err(|e| VdbError::Grid(one_line(e.what())))?;
        Grid::from_ptr(ptr)
    }

    /// Builds an OpenVDB grid from its Rust copy.
    pub fn from_data(data: &GridData) -> Result<Self, VdbError> {
        let header = ffi::bridge::GridHeader {
            name: data.name.clone(),
            grid_class: to_bridge_class(data.class),
            background: data.background,
            matrix: data.transform.matrix,
            uniform_linear: data.uniform_linear,
            leaf_count: data.leaf_count(),
        };
        let ptr = ffi::bridge::new_float_grid(
            &header,
            data.leaf_origins.as_flattened(),
            &data.leaf_values,
            data.leaf_masks.as_flattened(),
            &data
                .tiles
                .iter()
                .map(|t| ffi::bridge::Tile {
                    origin: t.origin,
                    dim: t.dim,
                    value: t.value,
                    active: t.active,
                })
                .collect::<Vec<_>>(),
        )
        .map_err(|e| VdbError::Grid(one_line(e.what())))?;
        Grid::from_ptr(ptr)
    }

    /// Copies the grid into Rust, reusing `out`'s buffers.
    pub fn copy_into(&self, out: &mut GridData) -> Result<(), VdbError> {
        let header = self.inner.header();
        let n = header.leaf_count;
        out.name = header.name;
        out.class = from_bridge_class(header.grid_class);
        out.background = header.background;
        out.transform = Transform {
            matrix: header.matrix,
        };
        out.uniform_linear = header.uniform_linear;
        out.leaf_origins.clear();
        out.leaf_origins.resize(n, [0; 3]);
        out.leaf_values.clear();
        // Zeroed on all threads: a first read's pages are faulted in here.
        out.leaf_values
            .par_extend(rayon::iter::repeat_n(0.0, n * LEAF_VOXELS));
        out.leaf_masks.clear();
        out.leaf_masks.resize(n, [0; MASK_WORDS]);
        self.inner
            .copy_leaves(
                out.leaf_origins.as_flattened_mut(),
                &mut out.leaf_values,
                out.leaf_masks.as_flattened_mut(),
            )
            .map_err(|e| VdbError::Grid(one_line(e.what())))?;
        out.tiles = self
            .inner
            .tiles()
            .into_iter()
            .map(|t| Tile {
                origin: t.origin,
                dim: t.dim,
                value: t.value,
                active: t.active,
            })
            .collect();
        Ok(())
    }

    pub fn to_data(&self) -> Result<GridData, VdbError> {
        let transform = Transform::uniform(1.0, [0.0; 3]);
        let mut data = GridData::empty("", GridClass::Unknown, 0.0, transform);
        self.copy_into(&mut data)?;
        Ok(data)
    }

    pub fn name(&self) -> String {
        self.inner.header().name
    }

    pub fn class(&self) -> GridClass {
        from_bridge_class(self.inner.header().grid_class)
    }

    pub fn active_voxel_count(&self) -> u64 {
        self.inner.active_voxel_count()
    }

    /// `tools::pruneLevelSet`: uniform leaves become inside / outside tiles.
    pub fn prune_level_set(&mut self) -> Result<(), VdbError> {
        self.inner
            .pin_mut()
            .prune_level_set()
            .map_err(|e| VdbError::Grid(one_line(e.what())))
    }

    /// OpenVDB's `volumeToMesh` (world-space points, triangles and quads).
    pub fn volume_to_mesh(&self, isovalue: f64, adaptivity: f64) -> Result<MeshBuffers, VdbError> {
        ffi::bridge::volume_to_mesh(&self.inner, isovalue, adaptivity)
            .map_err(|e| VdbError::Grid(one_line(e.what())))
    }

    /// OpenVDB's `LevelSetMeasure`: area, volume, mean curvature, Euler characteristic.
    pub fn measure_level_set(&self) -> Result<LevelSetMeasures, VdbError> {
        ffi::bridge::measure_level_set(&self.inner).map_err(|e| VdbError::Grid(one_line(e.what())))
    }

    /// OpenVDB's `LevelSetMorphing` of a copy of this grid toward `target` over
    /// `duration`, timed in C++ (for side-by-side benchmarks).
    pub fn morph_timing(&self, target: &Grid, duration: f64) -> Result<MorphTiming, VdbError> {
        ffi::bridge::morph_timing(&self.inner, &target.inner, duration)
            .map_err(|e| VdbError::Grid(one_line(e.what())))
    }

    /// Advances this grid in place by `duration` of OpenVDB's `LevelSetMorphing` toward
    /// `target`, timed in C++.
    pub fn morph_advance(&mut self, target: &Grid, duration: f64) -> Result<MorphTiming, VdbError> {
        ffi::bridge::morph_advance(self.inner.pin_mut(), &target.inner, duration)
            .map_err(|e| VdbError::Grid(one_line(e.what())))
    }

    /// `iterations` of OpenVDB's mean-curvature filter in place, timed.
    pub fn mean_curvature_flow(&mut self, iterations: u32) -> Result<MorphTiming, VdbError> {
        ffi::bridge::mean_curvature_flow(self.inner.pin_mut(), iterations)
            .map_err(|e| VdbError::Grid(one_line(e.what())))
    }

    /// `duration` of OpenVDB's `LevelSetAdvection` in a rotation about the z axis at
    /// `omega` radians per second, in place, timed in C++.
    pub fn advect_rotation(&mut self, omega: f64, duration: f64) -> Result<MorphTiming, VdbError> {
        ffi::bridge::advect_rotation(self.inner.pin_mut(), omega, duration)
            .map_err(|e| VdbError::Grid(one_line(e.what())))
    }

    /// OpenVDB's `memUsage()`: bytes held by the grid.
    pub fn mem_usage(&self) -> u64 {
        ffi::bridge::mem_usage(&self.inner)
    }

    /// OpenVDB's `checkLevelSet`: its diagnostic, `None` when the grid is a valid level
    /// set (a verdict on the grid, not a failure to check it).
    pub fn check_level_set(&self) -> Result<Option<String>, VdbError> {
        let report = ffi::bridge::check_level_set(&self.inner)
            .map_err(|e| VdbError::Grid(one_line(e.what())))?;
        Ok((!report.is_empty()).then(|| one_line(&report)))
    }
}

/// The file metadata of frame `frame` of a sequence activeskin writes.
pub fn frame_metadata(frame: i64) -> FileMetadata {
    FileMetadata {
        creator: format!("activeskin {}", env!("CARGO_PKG_VERSION")),
        has_frame: true,
        frame,
    }
}

/// A vector grid to write (fixtures, samples): `values[i]` at voxel `coords[i]`.
pub struct VectorWrite<'a> {
    /// The grid's name.
    pub name: &'a str,
    /// Whether its components sit on the voxels' faces (MAC).
    pub staggered: bool,
    /// World units.
    pub voxel_size: f64,
    /// The active voxels, index coordinates.
    pub coords: &'a [[i32; 3]],
    /// The vector at each of `coords`.
    pub values: &'a [[f32; 3]],
    /// Store values as 16-bit halves, as Houdini may write them.
    pub half_float: bool,
}

/// The vector grid `name` of a file, or its first vec3s/vec3d grid.
pub fn read_vector_grid(path: &Path, name: Option<&str>) -> Result<VectorGrid, VdbError> {
    let layout = check_vdb_file(path)?;
    check_memory(path, &layout, name, "Tree_vec3")?;
    let b = ffi::bridge::read_vector_grid(&path.to_string_lossy(), name.unwrap_or(""))
        .map_err(|e| openvdb_read_error(path, &e))?;
    let triples =
        |v: &[f32]| -> Vec<[f32; 3]> { v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect() };
    let tile_origins: Vec<[i32; 3]> = b
        .tile_origins
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let tiles = tile_origins
        .iter()
        .zip(&b.tile_dims)
        .zip(triples(&b.tile_values))
        .map(|((&origin, &dim), value)| VectorTile { origin, dim, value })
        .collect();
    Ok(VectorGrid {
        name: b.name,
        staggered: b.staggered,
        transform: Transform { matrix: b.matrix },
        uniform_linear: b.uniform_linear,
        background: b.background,
        leaf_origins: b
            .origins
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
        leaf_values: triples(&b.values),
        leaf_masks: b
            .masks
            .chunks_exact(MASK_WORDS)
            .map(|c| c.try_into().expect("eight mask words"))
            .collect(),
        tiles,
    })
}

/// How one grid is stored by [`write_grids`].
#[derive(Debug, Clone, Copy, Default)]
pub struct WriteOptions {
    /// Store values as 16-bit halves (smaller files, ~3 significant digits).
    pub half_float: bool,
}

/// Writes grids to `path`, through a temporary file renamed into place, so a reader never
/// sees a half-written file and an earlier file of that name survives a failure.
pub fn write_grids(
    path: &Path,
    grids: &[(&Grid, WriteOptions)],
    metadata: &FileMetadata,
) -> Result<(), VdbError> {
    write_grids_and_vectors(path, grids, &[], metadata)
}

/// [`write_grids`], with vector grids after the float grids.
pub fn write_grids_and_vectors(
    path: &Path,
    grids: &[(&Grid, WriteOptions)],
    vectors: &[VectorWrite],
    metadata: &FileMetadata,
) -> Result<(), VdbError> {
    let mut writer = ffi::bridge::new_grid_writer();
    for (grid, options) in grids {
        writer
            .pin_mut()
            .add(&grid.inner, options.half_float)
            .map_err(|e| VdbError::file(path, e.what()))?;
    }
    for v in vectors {
        writer
            .pin_mut()
            .add_vectors(
                v.name,
                v.staggered,
                v.voxel_size,
                v.coords.as_flattened(),
                v.values.as_flattened(),
                v.half_float,
            )
            .map_err(|e| VdbError::file(path, e.what()))?;
    }
    super::file::write_atomically(path, |tmp| {
        writer
            .write(&tmp.to_string_lossy(), metadata)
            .map_err(|e| WriteFault::OpenVdb(e.what().to_string()))?;
        verify_written(tmp)
    })
    .map_err(|fault| VdbError::file(path, fault))
}

/// OpenVDB writes through a std::ofstream whose failures it does not check: on a full
/// disk it leaves a short file and reports success. So the file is flushed to disk and
/// its layout walked before it may take its final name.
fn verify_written(tmp: &Path) -> Result<(), WriteFault> {
    let file = std::fs::File::open(tmp)?;
    file.sync_all()?;
    let length = file.metadata()?.len();
    layout::check(std::io::BufReader::new(file), length)
        .map(drop)
        .map_err(|reason| WriteFault::Incomplete { length, reason })
}

/// Positions (world space), `pscale` radii, `v`, `id` and the other attributes of a point
/// data grid, as Houdini's VDB from Points writes them: the grid `name`, or the first
/// point data grid of the file.
pub fn read_points(path: &Path, name: Option<&str>) -> Result<ffi::bridge::PointBuffers, VdbError> {
    let layout = check_vdb_file(path)?;
    check_memory(path, &layout, name, "Tree_ptdataidx")?;
    ffi::bridge::read_points(&path.to_string_lossy(), name.unwrap_or(""))
        .map_err(|e| openvdb_read_error(path, &e))
}

/// Writes one point data grid named `name` (positions in 16-bit fixed point relative to
/// their voxel, `pscale` when `radii` is given), atomically.
pub fn write_points(
    path: &Path,
    positions: &[[f32; 3]],
    radii: Option<&[f32]>,
    voxel_size: f64,
    name: &str,
) -> Result<(), VdbError> {
    write_points_with_velocities(path, positions, radii, None, voxel_size, name)
}

/// [`write_points`] with a `v` attribute (vec3s) when `velocities` is given.
pub fn write_points_with_velocities(
    path: &Path,
    positions: &[[f32; 3]],
    radii: Option<&[f32]>,
    velocities: Option<&[[f32; 3]]>,
    voxel_size: f64,
    name: &str,
) -> Result<(), VdbError> {
    let velocities = velocities.map_or(&[][..], |v| v.as_flattened());
    let none = ffi::bridge::PointAttributes::default();
    write_point_grid(
        path,
        positions,
        (radii, velocities),
        &none,
        voxel_size,
        name,
    )
}

/// Particles as one point data grid `name`, as Houdini's VDB from Points writes them:
/// `pscale`, `v`, `id` (int64) and each attribute (float or vec3s) when they have them.
pub fn write_particles(
    path: &Path,
    particles: &crate::particles::Particles,
    voxel_size: f64,
    name: &str,
) -> Result<(), VdbError> {
    let positions: Vec<[f32; 3]> = particles.positions.iter().map(|p| p.to_array()).collect();
    let velocities: Vec<f32> = particles
        .velocities
        .iter()
        .flatten()
        .flat_map(|v| v.to_array())
        .collect();
    let attributes = ffi::bridge::PointAttributes {
        ids: particles.ids.clone().unwrap_or_default(),
        names: particles
            .attributes
            .iter()
            .map(|a| a.name.clone())
            .collect(),
        components: particles
            .attributes
            .iter()
            .map(|a| a.components as u32)
            .collect(),
        values: particles
            .attributes
            .iter()
            .flat_map(|a| a.values.iter().copied())
            .collect(),
    };
    let radii = particles.radii.as_deref();
    write_point_grid(
        path,
        &positions,
        (radii, &velocities),
        &attributes,
        voxel_size,
        name,
    )
}

fn write_point_grid(
    path: &Path,
    positions: &[[f32; 3]],
    (radii, velocities): (Option<&[f32]>, &[f32]),
    attributes: &ffi::bridge::PointAttributes,
    voxel_size: f64,
    name: &str,
) -> Result<(), VdbError> {
    let flat: Vec<f32> = positions.iter().flatten().copied().collect();
    super::file::write_atomically(path, |tmp| {
        ffi::bridge::write_points(
            &tmp.to_string_lossy(),
            &flat,
            radii.unwrap_or(&[]),
            velocities,
            attributes,
            voxel_size,
            name,
        )
        .map_err(|e| WriteFault::OpenVdb(e.what().to_string()))?;
        verify_written(tmp)
    })
    .map_err(|fault| VdbError::file(path, fault))
}

/// Writes a point data grid of `positions` after the float grid `beside`, in one file: a
/// fixture for files that mix grids.
pub fn write_points_beside(
    path: &Path,
    positions: &[[f32; 3]],
    voxel_size: f64,
    name: &str,
    beside: &Grid,
) -> Result<(), VdbError> {
    let flat: Vec<f32> = positions.iter().flatten().copied().collect();
    super::file::write_atomically(path, |tmp| {
        ffi::bridge::write_points_beside(
            &tmp.to_string_lossy(),
            &flat,
            voxel_size,
            name,
            &beside.inner,
        )
        .map_err(|e| WriteFault::OpenVdb(e.what().to_string()))?;
        verify_written(tmp)
    })
    .map_err(|fault| VdbError::file(path, fault))
}

/// Writes a file holding only a Vec3s grid named `v`: a fixture for tests of bad input.
#[doc(hidden)]
pub fn write_vector_grid_file(path: &Path) -> Result<(), VdbError> {
    ffi::bridge::write_vector_grid_file(&path.to_string_lossy())
        .map_err(|e| VdbError::file(path, e.what()))
}

/// The name and value type (`float`, `vec3s`, as `info` names it) of each grid of a file, from its
/// descriptors alone (nothing is decoded: cheap enough to ask every frame).
pub fn grid_types(path: &Path) -> Result<Vec<(String, String)>, VdbError> {
    let layout = check_vdb_file(path)?;
    if layout.has_offsets {
        // Named by value type, as OpenVDB's own listing below and `info` name them.
        return Ok(layout
            .grids
            .into_iter()
            .map(|(name, tree)| {
                let kind = layout::value_type(&tree).to_string();
                (name, kind)
            })
            .collect());
    }
    // Old files without a descriptor index: OpenVDB reads them to tell.
    Ok(list_grids(path)?
        .into_iter()
        .map(|g| (g.name, g.value_type))
        .collect())
}

/// The grids of a file, as `activeskin info` shows them.
pub fn list_grids(path: &Path) -> Result<Vec<GridSummary>, VdbError> {
    let layout = check_vdb_file(path)?;
    let mut grids = ffi::bridge::list_grids(&path.to_string_lossy())
        .map_err(|e| openvdb_read_error(path, &e))?;
    // OpenVDB lists grids sorted by name; show them in file order.
    // Named as OpenVDB prints the file's unique names (`a[1]`, `[0]`), which `--grid` takes.
    let position = |name: &str| {
        layout
            .grids
            .iter()
            .position(|(g, _)| layout::printable_name(g) == name)
    };
    grids.sort_by_key(|g| position(&g.name));
    Ok(grids)
}

/// Clear messages for every way a path is not a whole VDB file, before OpenVDB sees it
/// (see [`layout`]).
fn check_vdb_file(path: &Path) -> Result<layout::Layout, VdbError> {
    // Before opening: opening a named pipe waits for a writer.
    if let Some(why) = super::file::not_a_file(path) {
        return Err(VdbError::file(path, why));
    }
    let file = std::fs::File::open(path).map_err(|e| VdbError::file(path, io_reason(&e)))?;
    let meta = file.metadata().map_err(|e| VdbError::file(path, e))?;
    layout::check(std::io::BufReader::new(file), meta.len()).map_err(|m| VdbError::file(path, m))
}

/// Logs `message` as OpenVDB logs its warnings, for a test of where they go; false when
/// this OpenVDB logs without log4cplus (to stderr already).
#[doc(hidden)]
pub fn log_openvdb_warning(message: &str) -> bool {
    ffi::bridge::log_openvdb_warning(message)
}

/// The size in memory of grid `name` (of the first float grid when `None`) as the file's
/// writer recorded it (OpenVDB's `file_mem_bytes`), when it did.
pub fn recorded_memory(path: &Path, name: Option<&str>) -> Result<Option<u64>, VdbError> {
    Ok(check_vdb_file(path)?.recorded_memory(name, "Tree_float_"))
}

/// Refuses, before OpenVDB reads it, a grid whose size in memory (as its writer recorded
/// it) is over the memory budget twice over: OpenVDB's tree and the copy made of it live
/// together while it is read.
fn check_memory(
    path: &Path,
    layout: &layout::Layout,
    name: Option<&str>,
    kind: &str,
) -> Result<(), VdbError> {
    let Some(bytes) = layout.recorded_memory(name, kind) else {
        return Ok(());
    };
    let (needed, budget) = (bytes.saturating_mul(2), crate::budget::bytes());
    if needed <= budget {
        return Ok(());
    }
    Err(VdbError::file(
        path,
        format!(
            "reading it would take {} (the grid is {} in memory as its writer recorded, and it is copied), over the memory budget of {}: give {} to allow more",
            crate::budget::size(needed),
            crate::budget::size(bytes),
            crate::budget::size(budget),
            crate::field::Field::MaxMemory
        ),
    ))
}

/// An error OpenVDB raised while reading a file that passed [`layout::check`].
fn openvdb_read_error(path: &Path, e: &cxx::Exception) -> VdbError {
    VdbError::file(path, format!("OpenVDB cannot read it: {}", e.what()))
}

fn io_reason(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".into(),
        std::io::ErrorKind::PermissionDenied => "permission denied".into(),
        _ => e.to_string(),
    }
}

/// OpenVDB's grid class as the bridge carries it, in Rust's.
pub fn from_bridge_class(class: ffi::bridge::GridClass) -> GridClass {
    match class {
        ffi::bridge::GridClass::LevelSet => GridClass::LevelSet,
        ffi::bridge::GridClass::FogVolume => GridClass::FogVolume,
        ffi::bridge::GridClass::Staggered => GridClass::Staggered,
        _ => GridClass::Unknown,
    }
}

fn to_bridge_class(class: GridClass) -> ffi::bridge::GridClass {
    match class {
        GridClass::Unknown => ffi::bridge::GridClass::Unknown,
        GridClass::LevelSet => ffi::bridge::GridClass::LevelSet,
        GridClass::FogVolume => ffi::bridge::GridClass::FogVolume,
        GridClass::Staggered => ffi::bridge::GridClass::Staggered,
    }
}
