//! The cxx bridge to OpenVDB, alone in this file: editing it recompiles the C++ side.
//!
//! Every fallible function returns `Result`, so an OpenVDB exception arrives in Rust as an
//! `Err` carrying its message (`cpp/vdb_bridge.h` also catches non-standard throws).
//! Grids cross as opaque handles; voxel data crosses as flat arrays, leaf by leaf.

#[cxx::bridge(namespace = "activeskin::bridge")]
pub(crate) mod bridge {
    /// OpenVDB's `GridClass`.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    #[repr(u8)]
    enum GridClass {
        Unknown = 0,
        LevelSet = 1,
        FogVolume = 2,
        Staggered = 3,
    }

    /// One grid of a file, as `activeskin info` reports it.
    #[derive(Debug, Clone)]
    struct GridSummary {
        name: String,
        value_type: String,
        grid_class: GridClass,
        voxel_size: [f64; 3],
        /// Linear map with one scale on all axes: what activeskin can work in.
        uniform_linear: bool,
        active_voxels: u64,
        /// Points held, for a point data grid (0 otherwise).
        points: u64,
        /// False when the grid has no active voxel (then the bounding box is meaningless).
        has_bbox: bool,
        /// World-space box around the centres of the active voxels.
        bbox_min: [f64; 3],
        bbox_max: [f64; 3],
        /// The background value printed by OpenVDB's `operator<<` for the grid's type.
        background: String,
        /// Why OpenVDB could not decode the grid (then only its metadata is known), or
        /// empty.
        error: String,
    }

    /// Everything about a float grid except its voxels.
    #[derive(Debug, Clone)]
    struct GridHeader {
        name: String,
        grid_class: GridClass,
        background: f32,
        /// Index-to-world affine matrix, row-major in OpenVDB's row-vector convention
        /// (world = [i j k 1] · M, translation in the last row).
        matrix: [f64; 16],
        uniform_linear: bool,
        leaf_count: usize,
    }

    /// A constant region of the tree above leaf level: 8³ (level 1), 128³ (level 2) or
    /// 4096³ (root) voxels. Inactive tiles are what keep inside and outside apart.
    #[derive(Debug, Clone, Copy, PartialEq)]
    struct Tile {
        origin: [i32; 3],
        dim: u32,
        value: f32,
        active: bool,
    }

    /// Output of `volumeToMesh`: world points (xyz), triangles and quads (vertex indices).
    #[derive(Debug, Clone, Default)]
    struct MeshBuffers {
        points: Vec<f32>,
        triangles: Vec<u32>,
        quads: Vec<u32>,
    }

    /// Wall time of OpenVDB's `LevelSetMorphing` over an interval, measured in C++.
    #[derive(Debug, Clone, Copy)]
    struct MorphTiming {
        seconds: f64,
        /// CFL iterations (one upwind WENO5 / TVD-RK2 step each, plus band upkeep).
        iterations: u64,
        /// Active voxels of the morphed grid at the end.
        active_voxels: u64,
    }

    /// OpenVDB's `LevelSetMeasure` in world units.
    #[derive(Debug, Clone, Copy)]
    struct LevelSetMeasures {
        area: f64,
        volume: f64,
        /// Average mean curvature over the surface.
        mean_curvature: f64,
        euler_characteristic: i32,
        genus: i32,
    }

    /// The points of a point data grid, in world space.
    #[derive(Debug, Clone, Default)]
    struct PointBuffers {
        grid_name: String,
        /// x, y, z per point.
        positions: Vec<f32>,
        /// `pscale` per point when `has_radius`.
        radii: Vec<f32>,
        has_radius: bool,
        /// `v` (x, y, z) per point when `has_velocity`.
        velocities: Vec<f32>,
        has_velocity: bool,
        /// `id` and the other scalar and vector attributes.
        attributes: PointAttributes,
    }

    /// A point grid's `id` (int32 or int64; empty without) and its other attributes of
    /// one or three numbers (float, double, int32, vec3s, vec3d, vec3i), each as floats,
    /// attribute after attribute, `components[k]` per point.
    #[derive(Debug, Clone, Default)]
    struct PointAttributes {
        ids: Vec<i64>,
        names: Vec<String>,
        components: Vec<u32>,
        values: Vec<f32>,
    }

    /// A vector grid (vec3s or vec3d) copied out leaf by leaf: 512 voxels × 3 components
    /// per leaf, x y z interleaved; active tiles above leaf level apart.
    #[derive(Debug, Clone, Default)]
    struct VectorBuffers {
        name: String,
        value_type: String,
        /// OpenVDB class `staggered`: component i sits on the voxel's lower i face.
        staggered: bool,
        matrix: [f64; 16],
        uniform_linear: bool,
        background: [f32; 3],
        origins: Vec<i32>,
        values: Vec<f32>,
        masks: Vec<u64>,
        tile_origins: Vec<i32>,
        tile_dims: Vec<u32>,
        tile_values: Vec<f32>,
    }

    /// File-level metadata written with the grids.
    #[derive(Debug, Clone)]
    struct FileMetadata {
        creator: String,
        has_frame: bool,
        frame: i64,
    }

    unsafe extern "C++" {
        include!("activeskin/cpp/vdb_bridge.h");

        /// An OpenVDB `FloatGrid` behind a pimpl handle.
        type FloatGrid;
        /// Grids gathered for one file write.
        type GridWriter;

        fn list_grids(path: &str) -> Result<Vec<GridSummary>>;
        /// Logs `message` as a warning through OpenVDB's logger (false: OpenVDB has no
        /// log4cplus in this build).
        fn log_openvdb_warning(message: &str) -> bool;
        /// `name` empty: the first grid whose value type is `float`.
        fn read_float_grid(path: &str, name: &str) -> Result<UniquePtr<FloatGrid>>;
        fn new_float_grid(
            header: &GridHeader,
            origins: &[i32],
            values: &[f32],
            masks: &[u64],
            tiles: &[Tile],
        ) -> Result<UniquePtr<FloatGrid>>;
        fn make_level_set_sphere(
            radius: f32,
            center: [f32; 3],
            voxel_size: f32,
            half_width: f32,
        ) -> Result<UniquePtr<FloatGrid>>;

        fn header(self: &FloatGrid) -> GridHeader;
        fn active_voxel_count(self: &FloatGrid) -> u64;
        fn copy_leaves(
            self: &FloatGrid,
            origins: &mut [i32],
            values: &mut [f32],
            masks: &mut [u64],
        ) -> Result<()>;
        fn tiles(self: &FloatGrid) -> Vec<Tile>;
        /// `tools::pruneLevelSet`: collapses uniform leaves into inside/outside tiles.
        fn prune_level_set(self: Pin<&mut FloatGrid>) -> Result<()>;

        /// Writes a file holding one Vec3s grid named `v` (a fixture for error tests).
        fn write_vector_grid_file(path: &str) -> Result<()>;

        fn new_grid_writer() -> UniquePtr<GridWriter>;
        fn add(self: Pin<&mut GridWriter>, grid: &FloatGrid, half_float: bool) -> Result<()>;
        /// Adds a Vec3s grid named `name` with `values[i]` at voxel `coords[i]` (xyz
        /// triples each), class `staggered` or unknown, voxels of `voxel_size` at zero.
        fn add_vectors(
            self: Pin<&mut GridWriter>,
            name: &str,
            staggered: bool,
            voxel_size: f64,
            coords: &[i32],
            values: &[f32],
            half_float: bool,
        ) -> Result<()>;
        fn write(self: &GridWriter, path: &str, metadata: &FileMetadata) -> Result<()>;

        fn volume_to_mesh(grid: &FloatGrid, isovalue: f64, adaptivity: f64) -> Result<MeshBuffers>;
        fn measure_level_set(grid: &FloatGrid) -> Result<LevelSetMeasures>;
        /// `tools::meshToLevelSet` of a triangle mesh (world coordinates) on voxels of
        /// `voxel_size` with origin at world zero.
        fn mesh_to_level_set(
            points: &[f32],
            triangles: &[u32],
            voxel_size: f64,
            half_width: f32,
        ) -> Result<UniquePtr<FloatGrid>>;
        /// `tools::LevelSetMorphing` of a copy of `source` toward `target` from time 0 to
        /// `duration` (OpenVDB's default schemes), timed.
        fn morph_timing(
            source: &FloatGrid,
            target: &FloatGrid,
            duration: f64,
        ) -> Result<MorphTiming>;
        /// Advances `grid` in place by `duration` of `tools::LevelSetMorphing` toward
        /// `target` (default schemes), timed.
        fn morph_advance(
            grid: Pin<&mut FloatGrid>,
            target: &FloatGrid,
            duration: f64,
        ) -> Result<MorphTiming>;
        /// `iterations` of `tools::LevelSetFilter::meanCurvature` in place, timed: each
        /// moves the surface by (κ₁+κ₂)/2 · Δx²/3.
        fn mean_curvature_flow(grid: Pin<&mut FloatGrid>, iterations: u32) -> Result<MorphTiming>;
        /// `duration` of `tools::LevelSetAdvection` (default schemes: HJ-WENO5, TVD-RK2)
        /// in a rotation about the z axis at `omega` radians per second, in place, timed.
        fn advect_rotation(
            grid: Pin<&mut FloatGrid>,
            omega: f64,
            duration: f64,
        ) -> Result<MorphTiming>;
        /// The positions (and `pscale`, `v`, `id`, other attributes) of the point data grid
        /// `name`, or of the first one when `name` is empty.
        fn read_points(path: &str, name: &str) -> Result<PointBuffers>;
        /// Writes one point data grid (16-bit fixed-point positions, `pscale` when `radii`
        /// is not empty, `v`, `id` and float or vec3s attributes when given): a fixture
        /// for tests and the sample data.
        fn write_points(
            path: &str,
            positions: &[f32],
            radii: &[f32],
            velocities: &[f32],
            attributes: &PointAttributes,
            voxel_size: f64,
            name: &str,
        ) -> Result<()>;
        /// Writes a point data grid (positions only) after the float grid `beside`, in one
        /// file: a fixture for files mixing grids.
        fn write_points_beside(
            path: &str,
            positions: &[f32],
            voxel_size: f64,
            name: &str,
            beside: &FloatGrid,
        ) -> Result<()>;
        /// `Grid::memUsage()`, bytes.
        fn mem_usage(grid: &FloatGrid) -> u64;
        /// The vector grid `name`, or the first vec3s/vec3d grid when `name` is empty.
        fn read_vector_grid(path: &str, name: &str) -> Result<VectorBuffers>;
        /// `tools::checkLevelSet`: empty when the grid is a valid narrow-band level set.
        fn check_level_set(grid: &FloatGrid) -> Result<String>;
    }
}
