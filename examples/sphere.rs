//! Writes OpenVDB's level-set sphere through activeskin's bridge, after a round trip
//! through Rust: `cargo run --example sphere -- out/sphere.vdb`.

use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};

fn main() -> Result<(), activeskin::Error> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "sphere.vdb".into());
    let sphere = Grid::level_set_sphere(1.0, [0.0; 3], 0.02, 3.0)?;
    let data = sphere.to_data()?;
    println!(
        "sphere: {} leaves, {} tiles, {} active voxels",
        data.leaf_count(),
        data.tiles.len(),
        data.active_voxel_count()
    );
    let grid = Grid::from_data(&data)?;
    let meta = FileMetadata {
        creator: format!("activeskin {}", env!("CARGO_PKG_VERSION")),
        has_frame: true,
        frame: 1,
    };
    vdb::write_grids(path.as_ref(), &[(&grid, WriteOptions::default())], &meta)?;
    println!("wrote {path}");
    Ok(())
}
