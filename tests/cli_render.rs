//! `activeskin render`: a multi-layer EXR whose layers say what they should about a sphere,
//! and a PNG.
#![cfg(feature = "vdb")]

mod common;

use std::process::Command;

use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};

#[test]
fn renders_a_sphere_to_exr_layers_and_png() {
    let dir = common::scratch();
    let input = dir.path().join("sphere.vdb");
    let grid = Grid::level_set_sphere(1.0, [0.0; 3], 0.05, 3.0).unwrap();
    let meta = FileMetadata {
        creator: "test".into(),
        has_frame: false,
        frame: 0,
    };
    vdb::write_grids(&input, &[(&grid, WriteOptions::default())], &meta).unwrap();
    let exr_path = dir.path().join("sphere.exr");
    let run = |out: &std::path::Path, extra: &[&str]| {
        let mut args = vec!["render", input.to_str().unwrap(), out.to_str().unwrap()];
        args.extend_from_slice(extra);
        let result = Command::new(env!("CARGO_BIN_EXE_activeskin"))
            .args(&args)
            .output()
            .unwrap();
        assert!(
            result.status.success(),
            "{}",
            String::from_utf8_lossy(&result.stderr)
        );
    };
    run(&exr_path, &["--size", "64x48", "--view", "front"]);
    // The same image is the same file, byte for byte, however the threads ran (its tiles
    // were once stored in the order their compression finished). 320x240: many tiles.
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    run(&a, &["--size", "320x240"]);
    run(&b, &["--size", "320x240"]);
    assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap());

    let (size, channels) = common::exr_channels(&exr_path);
    assert_eq!(size, (64, 48));
    let channel = |name: &str| -> Vec<f32> {
        channels
            .get(name)
            .unwrap_or_else(|| panic!("no channel {name}"))
            .clone()
    };
    let (a, z, nz) = (channel("A"), channel("Z"), channel("N.Z"));
    for name in ["R", "G", "B", "N.X", "N.Y"] {
        channel(name);
    }
    let centre = 24 * 64 + 32;
    assert_eq!(a[centre], 1.0, "the sphere fills the centre");
    assert_eq!(a[0], 0.0, "a corner sees the background");
    assert!(
        nz[centre] > 0.99,
        "front view: the normal faces +z, got {}",
        nz[centre]
    );
    // Depth grows toward the sphere's rim.
    let edge = (0..64).map(|x| 24 * 64 + x).find(|&i| a[i] == 1.0).unwrap();
    assert!(z[edge] > z[centre], "{} vs {}", z[edge], z[centre]);

    let png_path = dir.path().join("sphere.png");
    run(&png_path, &["--size", "40x30"]);
    // A z-up scene (Blender's), through the same command.
    let z_up = dir.path().join("z_up.png");
    run(&z_up, &["--size", "40x30", "--up", "z"]);
    assert!(z_up.is_file());
    let decoder = png::Decoder::new(std::fs::File::open(&png_path).unwrap());
    let reader = decoder.read_info().unwrap();
    assert_eq!((reader.info().width, reader.info().height), (40, 30));
}
