//! `activeskin bench --outputs`: what the render-ready outputs cost at 1 M particles in
//! motion (a ball moving 4 voxels a frame at cell = r, ids in order, each particle
//! carrying a scalar `temperature` and a vector `vorticity`).
//! - The whole run, as processes alternated (best of two each): PLY meshes with the
//!   surface velocities and both attributes against PLY meshes without them.
//! - The writers, in this process on one frame's mesh (best of three): the USD frame
//!   layer against the OBJ writer, bare (the same points, normals and faces) and with the
//!   velocities and attributes.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use activeskin::io::mesh::VertexValues;
use activeskin::io::usd::Shot;
use activeskin::mesh::Mesh;
use activeskin::particles::{Attribute, Particles};
use activeskin::render::Up;
use glam::Vec3;
use serde_json::json;

use super::particles::lattice_ball;
use super::timed;

const FRAMES: i64 = 4;

pub fn run(
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    let root = std::env::temp_dir().join(format!("activeskin-outputs-{}", std::process::id()));
    let result = measure(&root, lines, report);
    // A million particles a frame: never left behind.
    let _ = std::fs::remove_dir_all(&root);
    result
}

fn measure(
    root: &Path,
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    let r = 0.005f32;
    let n = write_cloud(root, r)?;
    let run = |frames: i64, mesh: &str, extra: &[&str]| {
        timed(
            Command::new(std::env::current_exe()?)
                .arg("particles")
                .arg("--particles")
                .arg(root.join("cloud.####.ply"))
                .args(["--radius", &r.to_string(), "--voxel-size", &r.to_string()])
                .args(["--frames", &format!("1-{frames}"), "-q", "--mesh"])
                .arg(root.join(mesh))
                .args(extra),
        )
    };
    let bare = ["--velocities", "off"];
    let full = ["--attribute", "all"];
    let (mut without, mut with) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..2 {
        without = without.min(run(FRAMES, "bare.####.ply", &bare)?);
        with = with.min(run(FRAMES, "full.####.ply", &full)?);
    }
    let per_frame = |s: f64| s / FRAMES as f64 * 1e3;
    lines.push(format!(
        "outputs, {n} particles moving 4 voxels a frame, cell = r   PLY meshes {:.0} ms/frame, with velocities and 2 attributes {:.0} ms/frame ({:.2}×)",
        per_frame(without),
        per_frame(with),
        with / without
    ));

    // One frame's mesh, written by each writer.
    run(1, "one.####.obj", &bare)?;
    let mut mesh = activeskin::io::obj::read(&root.join("one.0001.obj"))?;
    let centre = mesh.positions.iter().copied().sum::<Vec3>() / mesh.positions.len() as f32;
    mesh.normals = mesh
        .positions
        .iter()
        .map(|&p| (p - centre).normalize_or_zero())
        .collect();
    let velocities: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|p| Vec3::new(p.y, p.z, p.x) * 0.3)
        .collect();
    let attributes = sample_attributes(&mesh.positions);
    let (obj, usd_bare, usd_full) = time_writers(root, &mesh, &velocities, &attributes)?;
    lines.push(format!(
        "outputs, one frame's mesh ({} vertices)   OBJ {obj:.0} ms, USD layer {usd_bare:.0} ms ({:.2}×), with velocities and 2 attributes {usd_full:.0} ms",
        mesh.positions.len(),
        usd_bare / obj
    ));
    report.insert(
        "outputs".into(),
        json!({"particles": n, "ply_ms_per_frame": per_frame(without),
               "ply_with_values_ms_per_frame": per_frame(with),
               "values_cost_ratio": with / without,
               "mesh_vertices": mesh.positions.len(), "obj_write_ms": obj,
               "usd_write_ms": usd_bare, "usd_with_values_write_ms": usd_full,
               "usd_to_obj_ratio": usd_bare / obj}),
    );
    Ok(())
}

/// A lattice ball of about a million particles of radius `r` moving 4 r a frame, with
/// ids and two attributes, written as `cloud.####.ply` for [`FRAMES`] frames; its size.
fn write_cloud(root: &Path, r: f32) -> anyhow::Result<usize> {
    std::fs::create_dir_all(root)?;
    let (lattice, _) = lattice_ball(1_000_000, r);
    let n = lattice.len();
    for frame in 1..=FRAMES {
        let shift = Vec3::X * (4.0 * r * frame as f32);
        let positions: Vec<Vec3> = lattice.iter().map(|&p| p + shift).collect();
        let particles = Particles {
            ids: Some((0..n as i64).collect()),
            attributes: sample_attributes(&positions),
            positions,
            ..Particles::default()
        };
        activeskin::io::ply::write_particles(
            &root.join(format!("cloud.{frame:04}.ply")),
            &particles,
        )?;
    }
    Ok(n)
}

/// A scalar and a vector attribute varying over `positions`.
fn sample_attributes(positions: &[Vec3]) -> Vec<Attribute> {
    vec![
        Attribute {
            name: "temperature".into(),
            components: 1,
            values: positions.iter().map(|p| 300.0 + 50.0 * p.x).collect(),
        },
        Attribute {
            name: "vorticity".into(),
            components: 3,
            values: positions.iter().flat_map(|p| [p.y, -p.x, 2.0]).collect(),
        },
    ]
}

/// The best of three writes of `mesh` (ms): OBJ, a USD layer, a USD layer with
/// `velocities` and `attributes`.
fn time_writers(
    root: &Path,
    mesh: &Mesh,
    velocities: &[Vec3],
    attributes: &[Attribute],
) -> anyhow::Result<(f64, f64, f64)> {
    let best = |write: &dyn Fn() -> anyhow::Result<()>| -> anyhow::Result<f64> {
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let start = Instant::now();
            write()?;
            best = best.min(start.elapsed().as_secs_f64() * 1e3);
        }
        Ok(best)
    };
    let obj = best(&|| Ok(activeskin::io::obj::write(mesh, &root.join("w.obj"))?))?;
    let shot = Shot::new(&root.join("w.usda"), (1, 1), 24.0, Up::Y, 1.0);
    std::fs::create_dir_all(shot.folder())?;
    let usd_bare = best(&|| Ok(shot.write_frame(1, mesh, VertexValues::default())?))?;
    let values = VertexValues {
        velocities: Some(velocities),
        attributes,
    };
    let usd_full = best(&|| Ok(shot.write_frame(1, mesh, values)?))?;
    Ok((obj, usd_bare, usd_full))
}
