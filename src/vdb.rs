//! Reading and writing OpenVDB files through the C++ bridge ([`ffi`]).
//!
//! A [`Grid`] is a handle on an OpenVDB `FloatGrid` living on the C++ side; [`GridData`] is
//! its Rust copy, leaf by leaf, in OpenVDB's own layout so that the transfer is a copy of
//! 512 values and 8 mask words per leaf. Tiles above leaf level (wholly inside / outside
//! regions of a level set) travel too, so nothing is lost either way.

mod ffi;
pub mod layout;

use std::path::{Path, PathBuf};

use cxx::UniquePtr;
use glam::Vec3;

pub use ffi::bridge::{
    FileMetadata, GridClass, GridSummary, LevelSetMeasures, MeshBuffers, MorphTiming, PointBuffers,
    Tile,
};

/// Voxels per leaf (8³), in OpenVDB's order: offset = (x & 7) << 6 | (y & 7) << 3 | (z & 7).
pub const LEAF_VOXELS: usize = 512;
/// Words of a leaf's active mask; bit `offset % 64` of word `offset / 64`.
pub const MASK_WORDS: usize = 8;

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

/// OpenVDB messages may span lines; ours must not.
fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// An affine index-to-world map, row-major in OpenVDB's row-vector convention
/// (world = [i j k 1] · M).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    pub matrix: [f64; 16],
}

impl Transform {
    /// Voxels of side `voxel_size` with index (0,0,0) centred at `origin`.
    pub fn uniform(voxel_size: f64, origin: [f64; 3]) -> Self {
        let d = voxel_size;
        #[rustfmt::skip]
        let matrix = [
            d, 0.0, 0.0, 0.0,
            0.0, d, 0.0, 0.0,
            0.0, 0.0, d, 0.0,
            origin[0], origin[1], origin[2], 1.0,
        ];
        Transform { matrix }
    }

    /// Length of one index step along x, in world units.
    pub fn voxel_size(&self) -> f64 {
        let m = &self.matrix;
        (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt()
    }

    pub fn index_to_world(&self, ijk: [f64; 3]) -> [f64; 3] {
        let m = &self.matrix;
        std::array::from_fn(|c| ijk[0] * m[c] + ijk[1] * m[4 + c] + ijk[2] * m[8 + c] + m[12 + c])
    }
}

/// A float grid copied into Rust, leaf by leaf.
#[derive(Debug, Clone, PartialEq)]
pub struct GridData {
    pub name: String,
    pub class: GridClass,
    pub background: f32,
    pub transform: Transform,
    /// True when the transform is linear with one scale on all axes.
    pub uniform_linear: bool,
    pub leaf_origins: Vec<[i32; 3]>,
    /// `LEAF_VOXELS` values per leaf, leaves in the order of `leaf_origins`.
    pub leaf_values: Vec<f32>,
    pub leaf_masks: Vec<[u64; MASK_WORDS]>,
    /// Constant regions above leaf level; inactive tiles equal to the background are
    /// implied and left out.
    pub tiles: Vec<Tile>,
}

impl GridData {
    pub fn leaf_count(&self) -> usize {
        self.leaf_origins.len()
    }

    pub fn leaf_values(&self, leaf: usize) -> &[f32] {
        &self.leaf_values[leaf * LEAF_VOXELS..(leaf + 1) * LEAF_VOXELS]
    }

    pub fn active_voxel_count(&self) -> u64 {
        let in_leaves: u64 = self
            .leaf_masks
            .iter()
            .flatten()
            .map(|w| u64::from(w.count_ones()))
            .sum();
        let in_tiles: u64 = self
            .tiles
            .iter()
            .filter(|t| t.active)
            .map(|t| u64::from(t.dim).pow(3))
            .sum();
        in_leaves + in_tiles
    }
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
        let chosen = if layout.has_offsets {
            Some(
                layout
                    .choose_float_grid(name)
                    .map_err(|m| VdbError::file(path, m))?,
            )
        } else {
            // No descriptor index to look in: OpenVDB does the lookup.
            name
        };
        let ptr = ffi::bridge::read_float_grid(&path.to_string_lossy(), chosen.unwrap_or(""))
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
            grid_class: data.class,
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
            &data.tiles,
        )
        .map_err(|e| VdbError::Grid(one_line(e.what())))?;
        Grid::from_ptr(ptr)
    }

    /// Copies the grid into Rust, reusing `out`'s buffers.
    pub fn copy_into(&self, out: &mut GridData) -> Result<(), VdbError> {
        let header = self.inner.header();
        let n = header.leaf_count;
        out.name = header.name;
        out.class = header.grid_class;
        out.background = header.background;
        out.transform = Transform {
            matrix: header.matrix,
        };
        out.uniform_linear = header.uniform_linear;
        out.leaf_origins.clear();
        out.leaf_origins.resize(n, [0; 3]);
        out.leaf_values.clear();
        out.leaf_values.resize(n * LEAF_VOXELS, 0.0);
        out.leaf_masks.clear();
        out.leaf_masks.resize(n, [0; MASK_WORDS]);
        self.inner
            .copy_leaves(
                out.leaf_origins.as_flattened_mut(),
                &mut out.leaf_values,
                out.leaf_masks.as_flattened_mut(),
            )
            .map_err(|e| VdbError::Grid(one_line(e.what())))?;
        out.tiles = self.inner.tiles();
        Ok(())
    }

    pub fn to_data(&self) -> Result<GridData, VdbError> {
        let mut data = GridData {
            name: String::new(),
            class: GridClass::Unknown,
            background: 0.0,
            transform: Transform::uniform(1.0, [0.0; 3]),
            uniform_linear: true,
            leaf_origins: Vec::new(),
            leaf_values: Vec::new(),
            leaf_masks: Vec::new(),
            tiles: Vec::new(),
        };
        self.copy_into(&mut data)?;
        Ok(data)
    }

    pub fn name(&self) -> String {
        self.inner.header().name
    }

    pub fn class(&self) -> GridClass {
        self.inner.header().grid_class
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

    /// OpenVDB's `memUsage()`: bytes held by the grid.
    pub fn mem_usage(&self) -> u64 {
        ffi::bridge::mem_usage(&self.inner)
    }

    /// OpenVDB's `checkLevelSet`: `Ok(())` when valid, else its diagnostic.
    pub fn check_level_set(&self) -> Result<Result<(), String>, VdbError> {
        let report = ffi::bridge::check_level_set(&self.inner)
            .map_err(|e| VdbError::Grid(one_line(e.what())))?;
        Ok(if report.is_empty() {
            Ok(())
        } else {
            Err(one_line(&report))
        })
    }
}

/// The background of a narrow band `half_width` voxels of `voxel_size` wide: the smallest
/// f32 not below `half_width · voxel_size` computed in f64, as OpenVDB's checkLevelSet
/// compares it (an f32 product can round a hair under 3 voxels and be rejected).
pub fn narrow_band_background(half_width: f32, voxel_size: f32) -> f32 {
    let exact = f64::from(half_width) * f64::from(voxel_size);
    let mut background = exact as f32;
    while f64::from(background) < exact {
        background = f32::from_bits(background.to_bits() + 1);
    }
    background
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
    let mut writer = ffi::bridge::new_grid_writer();
    for (grid, options) in grids {
        writer
            .pin_mut()
            .add(&grid.inner, options.half_float)
            .map_err(|e| VdbError::file(path, e.what()))?;
    }
    crate::io::write_atomically(path, |tmp| {
        writer
            .write(&tmp.to_string_lossy(), metadata)
            .map_err(|e| e.what().to_string())?;
        verify_written(tmp)
    })
    .map_err(|message| VdbError::file(path, message))
}

/// OpenVDB writes through a std::ofstream whose failures it does not check: on a full
/// disk it leaves a short file and reports success. So the file is flushed to disk and
/// its layout walked before it may take its final name.
fn verify_written(tmp: &Path) -> Result<(), String> {
    let file = std::fs::File::open(tmp).map_err(|e| e.to_string())?;
    file.sync_all().map_err(|e| e.to_string())?;
    let length = file.metadata().map_err(|e| e.to_string())?.len();
    layout::check(std::io::BufReader::new(file), length).map(drop).map_err(|reason| {
        format!("the file came out incomplete ({length} bytes: {reason}); is the disk out of space?")
    })
}

/// Positions (world space) and `pscale` radii of a point data grid, as Houdini's VDB from
/// Points writes them: the grid `name`, or the first point data grid of the file.
pub fn read_points(path: &Path, name: Option<&str>) -> Result<ffi::bridge::PointBuffers, VdbError> {
    check_vdb_file(path)?;
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
    let flat: Vec<f32> = positions.iter().flatten().copied().collect();
    crate::io::write_atomically(path, |tmp| {
        ffi::bridge::write_points(
            &tmp.to_string_lossy(),
            &flat,
            radii.unwrap_or(&[]),
            voxel_size,
            name,
        )
        .map_err(|e| e.what().to_string())?;
        verify_written(tmp)
    })
    .map_err(|message| VdbError::file(path, message))
}

/// Writes a file holding only a Vec3s grid named `v`: a fixture for tests of bad input.
#[doc(hidden)]
pub fn write_vector_grid_file(path: &Path) -> Result<(), VdbError> {
    ffi::bridge::write_vector_grid_file(&path.to_string_lossy())
        .map_err(|e| VdbError::file(path, e.what()))
}

/// The grids of a file, as `activeskin info` shows them.
pub fn list_grids(path: &Path) -> Result<Vec<GridSummary>, VdbError> {
    let layout = check_vdb_file(path)?;
    let mut grids = ffi::bridge::list_grids(&path.to_string_lossy())
        .map_err(|e| openvdb_read_error(path, &e))?;
    // OpenVDB lists grids sorted by name; show them in file order.
    let position = |name: &str| layout.grids.iter().position(|(g, _)| g == name);
    grids.sort_by_key(|g| position(&g.name));
    Ok(grids)
}

/// Clear messages for every way a path is not a whole VDB file, before OpenVDB sees it
/// (see [`layout`]).
fn check_vdb_file(path: &Path) -> Result<layout::Layout, VdbError> {
    let file = std::fs::File::open(path).map_err(|e| VdbError::file(path, io_reason(&e)))?;
    let meta = file.metadata().map_err(|e| VdbError::file(path, e))?;
    if meta.is_dir() {
        return Err(VdbError::file(path, "is a directory, not a VDB file"));
    }
    layout::check(std::io::BufReader::new(file), meta.len()).map_err(|m| VdbError::file(path, m))
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
