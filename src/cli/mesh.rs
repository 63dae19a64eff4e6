//! `activeskin mesh IN.vdb OUT.obj|OUT.ply`: our polygonizer on any level set, or on a fog
//! volume at `--iso`.

use std::path::PathBuf;

use rayon::prelude::*;

use activeskin::polygonize::mesh_vdb;
use activeskin::vdb::Grid;
use activeskin::volume::GridClass;

use activeskin::frames::{background_outside, check_transform, not_finite};

#[derive(clap::Args)]
pub struct MeshArgs {
    /// A VDB file.
    input: PathBuf,
    /// The mesh to write: .obj or .ply.
    output: PathBuf,
    /// Grid name, `name[1]` for a second grid of one name, or index in the file
    /// (default: `surface` or `phi`, Houdini's and Mantaflow's level sets, else the first float grid).
    #[arg(long)]
    grid: Option<String>,
    /// Surface density, for fog volumes (inside where the density is larger).
    #[arg(long)]
    iso: Option<f32>,
    /// Also measure the topology: χ, components, and whether the mesh is closed and
    /// manifold (a few sorts over the triangles; exit 1 when it is not clean).
    #[arg(long)]
    check: bool,
}

pub fn run(args: &MeshArgs) -> anyhow::Result<()> {
    if !activeskin::io::mesh::is_written(&args.output) {
        usage!(
            "'{}': meshes must end in .obj or .ply",
            args.output.display()
        );
    }
    let path = &args.input;
    let mut data = Grid::read(path, args.grid.as_deref())?.to_data()?;
    check_transform(path, &data)?;
    if !data.background.is_finite() {
        return Err(not_finite(path, &data).into());
    }
    if data.class == GridClass::LevelSet && args.iso.is_none() {
        // As `skin` reads it: liquid touching a dense domain's walls is closed there.
        if let Some(note) = background_outside(&mut data) {
            eprintln!("{note}");
        }
    }
    // Only signs and linear interpolation matter to the polygonizer: scale into [-1, 1].
    let (iso, sign) = match (data.class, args.iso) {
        (_, Some(iso)) if iso.is_finite() => (iso, -1.0f32),
        (_, Some(iso)) => usage!("--iso must be a number, got {iso}"),
        (GridClass::LevelSet, None) => (0.0, 1.0),
        (_, None) => usage!(
            "{}: grid '{}' is not a level set: give --iso, the density of its surface",
            path.display(),
            data.name
        ),
    };
    // The range, and whether every value is a number, in one pass: a NaN or an infinity
    // makes it infinite.
    let farthest = |m: f32, &v: &f32| {
        let d = (v - iso).abs();
        if d.is_nan() {
            f32::INFINITY
        } else {
            m.max(d)
        }
    };
    let range = data
        .leaf_values
        .par_iter()
        .fold(|| 0.0f32, farthest)
        .reduce(|| 0.0, f32::max)
        .max(data.tiles.iter().map(|t| &t.value).fold(0.0, farthest))
        .max(farthest(0.0, &data.background))
        .max(f32::MIN_POSITIVE);
    if !range.is_finite() {
        return Err(not_finite(path, &data).into());
    }
    let mesh = mesh_vdb(data, |v| sign * (v - iso) / range);
    // The measures while the file is written and synced.
    let (written, (area, volume)) = rayon::join(
        || activeskin::io::mesh::write(&mesh, &args.output),
        || mesh.area_and_volume(),
    );
    written?;
    let mut line = format!(
        "{}: {} vertices, {} triangles, area {area:.6}, volume {volume:.6}",
        args.output.display(),
        mesh.positions.len(),
        mesh.triangles.len(),
    );
    if args.check {
        let check = mesh.check();
        line += &format!(
            ", χ {}, {} component(s), {check}",
            mesh.euler_characteristic(),
            mesh.components()
        );
        println!("{line}");
        if !check.is_clean() {
            anyhow::bail!(
                "{}: the mesh is not clean (a level set cut at the grid's edge?)",
                args.output.display()
            );
        }
        return Ok(());
    }
    println!("{line}");
    Ok(())
}
