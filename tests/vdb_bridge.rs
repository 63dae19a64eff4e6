//! The OpenVDB bridge: grids cross both ways without losing a bit, and OpenVDB's tools
//! (volumeToMesh, LevelSetMeasure, checkLevelSet) answer through it.
#![cfg(feature = "vdb")]

mod common;

use std::f64::consts::PI;

use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};
use activeskin::volume::{GridClass, GridData, Transform};

fn metadata() -> FileMetadata {
    FileMetadata {
        creator: "activeskin tests".into(),
        has_frame: true,
        frame: 7,
    }
}

/// A level-set sphere whose interior holds inactive tiles: OpenVDB's sphere is
/// flood-filled; pruning also collapses uniform leaves.
fn sphere_with_interior_tiles() -> Grid {
    let mut grid = Grid::level_set_sphere(1.0, [0.25, -0.5, 0.125], 0.025, 3.0).unwrap();
    grid.prune_level_set().unwrap();
    grid
}

fn assert_bit_identical(a: &GridData, b: &GridData) {
    assert_eq!(a.name, b.name);
    assert_eq!(a.class, b.class);
    assert_eq!(a.background.to_bits(), b.background.to_bits());
    assert_eq!(a.transform, b.transform);
    assert_eq!(a.uniform_linear, b.uniform_linear);
    assert_eq!(a.leaf_origins, b.leaf_origins);
    assert_eq!(a.leaf_masks, b.leaf_masks);
    assert_eq!(a.leaf_values.len(), b.leaf_values.len());
    let differing = a
        .leaf_values
        .iter()
        .zip(&b.leaf_values)
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count();
    assert_eq!(differing, 0, "values differ");
    assert_eq!(a.tiles.len(), b.tiles.len());
    for (s, t) in a.tiles.iter().zip(&b.tiles) {
        assert_eq!(
            (s.origin, s.dim, s.value.to_bits(), s.active),
            (t.origin, t.dim, t.value.to_bits(), t.active)
        );
    }
}

#[test]
fn sphere_round_trips_bit_for_bit_with_interior_tiles() {
    let dir = common::scratch();
    let original = sphere_with_interior_tiles();
    let data = original.to_data().unwrap();

    // The fixture must really exercise tiles: interior (negative) inactive ones.
    let interior = data
        .tiles
        .iter()
        .filter(|t| !t.active && t.value == -data.background)
        .count();
    assert!(interior > 50, "only {interior} interior tiles");
    assert_eq!(data.class, GridClass::LevelSet);
    assert_eq!(data.name, "surface");
    assert!(data.uniform_linear);
    assert_eq!(data.active_voxel_count(), original.active_voxel_count());

    // Rust → OpenVDB → file → OpenVDB → Rust.
    let rebuilt = Grid::from_data(&data).unwrap();
    assert_eq!(rebuilt.active_voxel_count(), original.active_voxel_count());
    let path = dir.path().join("sphere.0007.vdb");
    vdb::write_grids(&path, &[(&rebuilt, WriteOptions::default())], &metadata()).unwrap();
    let back = Grid::read(&path, Some("surface"))
        .unwrap()
        .to_data()
        .unwrap();
    assert_bit_identical(&data, &back);

    // The default grid is the first float grid.
    let first = Grid::read(&path, None).unwrap().to_data().unwrap();
    assert_bit_identical(&data, &first);
    // No temporary file left beside the output.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(names.len(), 1);
}

#[test]
fn translated_transform_and_background_survive() {
    let dir = common::scratch();
    let mut data = sphere_with_interior_tiles().to_data().unwrap();
    data.transform = Transform::uniform(0.1, [1.5, -2.25, 3.0]);
    data.name = "skin".into();
    let path = dir.path().join("moved.vdb");
    let grid = Grid::from_data(&data).unwrap();
    vdb::write_grids(&path, &[(&grid, WriteOptions::default())], &metadata()).unwrap();
    let back = Grid::read(&path, Some("skin")).unwrap().to_data().unwrap();
    assert_bit_identical(&data, &back);
    assert_eq!(
        back.transform.index_to_world([1.0, 0.0, 0.0]),
        [1.6, -2.25, 3.0]
    );
    assert!((back.transform.voxel_size() - 0.1).abs() < 1e-15);
}

#[test]
fn non_uniform_transform_is_reported() {
    let mut data = sphere_with_interior_tiles().to_data().unwrap();
    data.transform.matrix[5] = 0.05; // y scale differs from x
    let back = Grid::from_data(&data).unwrap().to_data().unwrap();
    assert!(!back.uniform_linear);
    assert_eq!(back.transform, data.transform);
}

#[test]
fn half_float_storage_rounds_to_half_precision() {
    let dir = common::scratch();
    let grid = sphere_with_interior_tiles();
    let data = grid.to_data().unwrap();
    let path = dir.path().join("half.vdb");
    let options = WriteOptions { half_float: true };
    vdb::write_grids(&path, &[(&grid, options)], &metadata()).unwrap();
    let back = Grid::read(&path, None).unwrap().to_data().unwrap();
    assert_eq!(back.leaf_masks, data.leaf_masks);
    let mut changed = 0;
    for (a, b) in data.leaf_values.iter().zip(&back.leaf_values) {
        // Half floats keep 11 significant bits.
        assert!((a - b).abs() <= a.abs() * 1e-3 + 1e-7, "{a} vs {b}");
        changed += usize::from(a != b);
    }
    assert!(changed > 0, "half-float storage did not apply");
    let full = dir.path().join("full.vdb");
    vdb::write_grids(&full, &[(&grid, WriteOptions::default())], &metadata()).unwrap();
    let size = |p: &std::path::Path| std::fs::metadata(p).unwrap().len();
    assert!(size(&path) < size(&full));
}

#[test]
fn several_grids_in_one_file() {
    let dir = common::scratch();
    let a = Grid::level_set_sphere(1.0, [0.0; 3], 0.1, 3.0).unwrap();
    let mut b_data = Grid::level_set_sphere(0.5, [2.0, 0.0, 0.0], 0.05, 3.0)
        .unwrap()
        .to_data()
        .unwrap();
    b_data.name = "second".into();
    b_data.class = GridClass::FogVolume;
    let b = Grid::from_data(&b_data).unwrap();
    let path = dir.path().join("two.vdb");
    let options = WriteOptions::default();
    vdb::write_grids(&path, &[(&a, options), (&b, options)], &metadata()).unwrap();
    let grids = vdb::list_grids(&path).unwrap();
    let names: Vec<_> = grids.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(names, ["surface", "second"]);
    assert_eq!(
        activeskin::vdb::from_bridge_class(grids[1].grid_class),
        GridClass::FogVolume
    );
    assert_eq!(grids[1].voxel_size, [0.05f32 as f64; 3]);
    let second = Grid::read(&path, Some("second"))
        .unwrap()
        .to_data()
        .unwrap();
    assert_bit_identical(&b_data, &second);
}

#[test]
fn openvdb_tools_measure_a_sphere() {
    let r = 1.0;
    let dx = 0.025;
    let sphere = Grid::level_set_sphere(r as f32, [0.0; 3], dx as f32, 3.0).unwrap();
    let m = sphere.measure_level_set().unwrap();
    let area = 4.0 * PI * r * r;
    let volume = 4.0 / 3.0 * PI * r * r * r;
    assert!((m.area - area).abs() / area < 0.005, "area {}", m.area);
    assert!(
        (m.volume - volume).abs() / volume < 0.005,
        "volume {}",
        m.volume
    );
    assert!(
        (m.mean_curvature - 1.0 / r).abs() < 0.01,
        "{}",
        m.mean_curvature
    );
    assert_eq!(m.euler_characteristic, 2);
    assert_eq!(m.genus, 0);
    assert_eq!(sphere.check_level_set().unwrap(), None);

    let mesh = sphere.volume_to_mesh(0.0, 0.0).unwrap();
    assert!(mesh.triangles.is_empty(), "adaptivity 0 gives quads only");
    assert_eq!(mesh.quads.len() % 4, 0);
    let max_index = *mesh.quads.iter().max().unwrap() as usize;
    assert!(max_index < mesh.points.len() / 3);
    for p in mesh.points.chunks(3) {
        let d = (p.iter().map(|&c| f64::from(c).powi(2)).sum::<f64>()).sqrt();
        assert!((d - r).abs() < 0.1 * dx, "mesh point {d} off the sphere");
    }
    let adaptive = sphere.volume_to_mesh(0.0, 0.5).unwrap();
    assert!(adaptive.points.len() < mesh.points.len());
}

#[test]
fn mean_curvature_flow_shrinks_a_sphere_at_its_rate() {
    // Each iteration moves the surface by (κ₁+κ₂)/2 · Δx²/3 = Δx²/(3r): 60 iterations on
    // a sphere of 20 voxels take it in by 1 voxel (r shrinks by ≈ 60/(3·20) voxels).
    let dx = 0.05f32;
    let r0 = 20.0 * f64::from(dx);
    let mut sphere = Grid::level_set_sphere(r0 as f32, [0.0; 3], dx, 3.0).unwrap();
    let timing = sphere.mean_curvature_flow(60).unwrap();
    assert_eq!(timing.iterations, 60);
    let volume = sphere.measure_level_set().unwrap().volume;
    let r = (3.0 * volume / (4.0 * PI)).cbrt();
    let shrink = (r0 - r) / f64::from(dx);
    assert!((shrink - 1.0).abs() < 0.1, "shrank by {shrink} voxels");
}

#[test]
fn check_level_set_reports_a_broken_band() {
    let mut data = Grid::level_set_sphere(1.0, [0.0; 3], 0.05, 3.0)
        .unwrap()
        .to_data()
        .unwrap();
    // Inactive values no longer equal ± the background: not a valid narrow band.
    data.background *= 2.0;
    let grid = Grid::from_data(&data).unwrap();
    let report = grid.check_level_set().unwrap().unwrap();
    assert!(!report.is_empty());
}

#[test]
fn openvdb_errors_arrive_as_err_with_their_message() {
    let mut data = Grid::level_set_sphere(1.0, [0.0; 3], 0.1, 3.0)
        .unwrap()
        .to_data()
        .unwrap();
    data.transform.matrix = [0.0; 16];
    data.transform.matrix[15] = 1.0; // singular
    let err = Grid::from_data(&data)
        .err()
        .expect("a singular map must fail");
    assert!(err.to_string().contains("Error"), "{err}");

    data.transform = Transform::uniform(0.1, [0.0; 3]);
    data.class = GridClass::FogVolume;
    let fog = Grid::from_data(&data).unwrap();
    let err = fog.measure_level_set().unwrap_err().to_string();
    assert!(err.contains("level set"), "{err}");
    let mut fog = fog;
    let err = fog.mean_curvature_flow(1).unwrap_err().to_string();
    assert!(err.contains("level set"), "{err}");

    data.leaf_values.pop();
    let err = Grid::from_data(&data).err().unwrap().to_string();
    assert!(err.contains("leaf arrays disagree"), "{err}");
}

#[test]
fn write_failure_leaves_earlier_file_intact() {
    let dir = common::scratch();
    let grid = Grid::level_set_sphere(1.0, [0.0; 3], 0.1, 3.0).unwrap();
    let missing_folder = dir.path().join("no/such/folder/x.vdb");
    let err = vdb::write_grids(
        &missing_folder,
        &[(&grid, WriteOptions::default())],
        &metadata(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("x.vdb"), "{err}");
    assert!(!err.contains('\n'));
}

#[test]
fn grid_lookup_errors_name_the_grids() {
    let dir = common::scratch();
    let path = dir.path().join("vector.vdb");
    vdb::write_vector_grid_file(&path).unwrap();
    let err = Grid::read(&path, None).err().unwrap().to_string();
    assert!(
        err.contains("no float grid") && err.contains("'v'"),
        "{err}"
    );
    let err = Grid::read(&path, Some("v")).err().unwrap().to_string();
    assert!(err.contains("not a float grid"), "{err}");
    let err = Grid::read(&path, Some("density"))
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("no grid named 'density'"), "{err}");
}

/// A grid read from a file holds every voxel in memory (its leaves are loaded on all
/// threads, then the file is closed): nothing stays mapped, so the file can be
/// overwritten, even truncated, while the grid lives, as a frame loop does to its outputs.
#[test]
fn a_read_grid_keeps_nothing_mapped_and_survives_its_file_being_overwritten() {
    let dir = common::scratch();
    let path = dir.path().join("sphere.vdb");
    let original = sphere_with_interior_tiles();
    vdb::write_grids(&path, &[(&original, WriteOptions::default())], &metadata()).unwrap();
    let expected = original.to_data().unwrap();

    let read = Grid::read(&path, None).unwrap();
    let maps = std::fs::read_to_string("/proc/self/maps").unwrap();
    let name = path.to_string_lossy();
    assert!(
        !maps.lines().any(|l| l.ends_with(&*name)),
        "{name} is still mapped"
    );
    // Overwrite the file with a much smaller one, then read the grid's voxels.
    std::fs::write(&path, b"not a VDB any more").unwrap();
    let mut got = read.to_data().unwrap();
    got.name = expected.name.clone();
    assert_bit_identical(&expected, &got);
}

#[test]
fn unnamed_and_same_named_grids_are_read() {
    // pyopenvdb names a grid "" unless told; Houdini exports may repeat a name. OpenVDB
    // tells them apart in the file by a unique name ("[N]" when printed).
    let dir = common::scratch();
    let sphere = |r: f32, name: &str| {
        let mut data = Grid::level_set_sphere(r, [0.0; 3], 0.1, 3.0)
            .unwrap()
            .to_data()
            .unwrap();
        data.name = name.into();
        data
    };
    let (a, b) = (sphere(1.0, ""), sphere(0.5, ""));
    let unnamed = dir.path().join("unnamed.vdb");
    common::write_grid(&unnamed, &a);
    assert_bit_identical(&a, &Grid::read(&unnamed, None).unwrap().to_data().unwrap());
    assert_bit_identical(
        &a,
        &Grid::read(&unnamed, Some("0")).unwrap().to_data().unwrap(),
    );

    let options = WriteOptions::default();
    let two = dir.path().join("two.vdb");
    let (ga, gb) = (Grid::from_data(&a).unwrap(), Grid::from_data(&b).unwrap());
    vdb::write_grids(&two, &[(&ga, options), (&gb, options)], &metadata()).unwrap();
    let read = |name: Option<&str>| Grid::read(&two, name).unwrap().to_data().unwrap();
    assert_bit_identical(&a, &read(None));
    assert_bit_identical(&b, &read(Some("1")));
    assert_bit_identical(&b, &read(Some("[1]")));

    let (a, b) = (sphere(1.0, "surface"), sphere(0.5, "surface"));
    let (ga, gb) = (Grid::from_data(&a).unwrap(), Grid::from_data(&b).unwrap());
    vdb::write_grids(&two, &[(&ga, options), (&gb, options)], &metadata()).unwrap();
    assert_bit_identical(&a, &read(None));
    assert_bit_identical(&a, &read(Some("surface")));
    assert_bit_identical(&b, &read(Some("surface[1]")));
    assert_bit_identical(&b, &read(Some("1")));
    let summaries = vdb::list_grids(&two).unwrap();
    let listed: Vec<&str> = summaries.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(listed, ["surface[0]", "surface[1]"]);
    // Each described from its own grid, not the first of the name twice.
    assert!(summaries[0].active_voxels > summaries[1].active_voxels);
    assert_bit_identical(&a, &read(Some("surface[0]")));
    // A name that is not there lists the grids as printed.
    let err = Grid::read(&two, Some("nope")).err().unwrap().to_string();
    assert!(err.contains("'surface[1]'"), "{err}");

    // The commands read them too, and OpenVDB has no warning to print (it printed two
    // coloured WARN lines on stdout when `info` read repeated names by name).
    let info = common::activeskin(&["info", two.to_str().unwrap()]);
    common::assert_ok(&info);
    let said = String::from_utf8_lossy(&info.stdout);
    assert!(!said.contains("WARN"), "{said}");
    assert!(said.contains("grid 'surface[1]'"), "{said}");
    let out = dir.path().join("m.obj");
    let run = common::activeskin(&["mesh", unnamed.to_str().unwrap(), out.to_str().unwrap()]);
    common::assert_ok(&run);
}
