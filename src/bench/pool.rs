//! A settled pool in `activeskin bench --particles` (issue 49): a box of liquid at rest,
//! its particles a lattice of spacing 2r jittered ±0.3 r, the same on every frame. Its
//! top is a plane, so whatever tilts the facets there is the tool's own noise; and a
//! skin at rest should stay where its particles say, frame after frame, so the top's
//! height above the liquid's is measured on the last frame, where what a frame leaves
//! to the next has added up.

use std::path::Path;

use activeskin::measure::look;
use activeskin::mesh::Mesh;
use activeskin::particles::Particles;
use anyhow::Context;
use glam::{IVec3, Vec3};
use serde_json::json;

use super::sph::{lattice_jitter, run_ours, run_splashsurf, Shot, SPLASHSURF_SMOOTHING, STEM};

/// Particles along x, y (up) and z, their radius, the frames (half a second at 24 fps).
const LATTICE: IVec3 = IVec3::new(60, 12, 30);
const R: f32 = 0.005;
const FRAMES: usize = 12;
/// How far from the pool's sides its top's middle starts, in radii: past the rims'
/// rounding.
const MARGIN_RADII: f32 = 20.0;

/// The pool's frames written into `dir`: the same particles at rest on each.
fn pool(dir: &Path) -> anyhow::Result<Shot> {
    std::fs::create_dir_all(dir)?;
    let mut positions = Vec::new();
    for i in 0..LATTICE.x {
        for j in 0..LATTICE.y {
            for k in 0..LATTICE.z {
                let jitter = |c| lattice_jitter([i, j, k], c, 0.3 * R);
                let p = Vec3::new(i as f32, j as f32, k as f32) * 2.0 * R;
                positions.push(p + Vec3::new(jitter(0), jitter(1), jitter(2)));
            }
        }
    }
    let frame = Particles {
        velocities: Some(vec![Vec3::ZERO; positions.len()]),
        ids: Some((0..positions.len() as i64).collect()),
        positions,
        radii: None,
        attributes: Vec::new(),
    };
    for f in 1..=FRAMES {
        activeskin::io::ply::write_particles(&dir.join(format!("{STEM}{f}.ply")), &frame)?;
    }
    Ok(Shot {
        name: "settled pool".to_string(),
        key: "particles_pool".to_string(),
        dir: dir.to_path_buf(),
        frames: FRAMES,
        fps: 24.0,
        r: R,
        stem: STEM.to_string(),
        run: 1..=FRAMES,
    })
}

/// The facets' tilt on the middle of the top (degrees) and the top's mean height there
/// above the liquid's (radii; the liquid is the lattice's cells, its top a radius above
/// the top layer's centres).
fn top(mesh: &Mesh) -> (f64, f64) {
    let size = (LATTICE - 1).as_vec3() * 2.0 * R;
    let margin = MARGIN_RADII * R;
    let middle = |p: Vec3| {
        p.y > size.y - 2.0 * R
            && (margin..size.x - margin).contains(&p.x)
            && (margin..size.z - margin).contains(&p.z)
    };
    let tilt = look::facet_tilt(mesh, Vec3::Y, middle);
    let heights: Vec<f64> = mesh
        .positions
        .iter()
        .filter(|p| middle(**p))
        .map(|p| f64::from((p.y - size.y - R) / R))
        .collect();
    let height = heights.iter().sum::<f64>() / heights.len().max(1) as f64;
    (tilt, height)
}

/// The settled pool raced: ours at its defaults, splashsurf raw and smoothed, on the last
/// frame; one line and `particles_pool` in the report.
pub(super) fn race(
    root: &Path,
    splashsurf: Option<&Path>,
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    let shot = pool(&root.join("pool_in"))?;
    let dir = root.join("pool");
    std::fs::create_dir_all(&dir)?;
    run_ours(&shot, &dir, "")?;
    let theirs = run_splashsurf(&shot, &dir, splashsurf, &[], "theirs")?;
    run_splashsurf(&shot, &dir, splashsurf, &SPLASHSURF_SMOOTHING, "smoothed")?;
    let read = |name: String| -> anyhow::Result<(f64, f64)> {
        let path = dir.join(name);
        let mesh = activeskin::io::obj::read(&path).with_context(|| path.display().to_string())?;
        Ok(top(&mesh))
    };
    let ours = read(format!("ours_{FRAMES:04}.obj"))?;
    let [raw, smoothed] = match theirs {
        Some(_) => ["theirs", "smoothed"].map(|p| read(format!("{p}_{FRAMES}.obj")).map(Some)),
        None => [Ok(None), Ok(None)],
    };
    let (raw, smoothed) = (raw?, smoothed?);
    let particles = LATTICE.x * LATTICE.y * LATTICE.z;
    let mut line = format!(
        "particles, {} ({particles} particles at rest, jittered ±0.3 r; frame {FRAMES}): facet tilt on the top's middle / its height above the liquid's: ours {:.2}° / {:+.2} r",
        shot.name, ours.0, ours.1
    );
    for (who, t) in [("splashsurf", raw), ("splashsurf smoothed", smoothed)] {
        if let Some(t) = t {
            line += &format!(", {who} {:.2}° / {:+.2} r", t.0, t.1);
        }
    }
    if let Some(s) = smoothed {
        line += &format!(" (tilt {:.2}× smoothed splashsurf's)", ours.0 / s.0);
    }
    lines.push(line);
    let side = |t: Option<(f64, f64)>| t.map(|t| json!({"tilt_degrees": t.0, "top_radii": t.1}));
    report.insert(
        shot.key.clone(),
        json!({"particles": particles, "frame": FRAMES, "radius": R,
               "ours": side(Some(ours)), "splashsurf": side(raw),
               "splashsurf_smoothed": side(smoothed),
               "tilt_ratio": smoothed.map(|s| ours.0 / s.0)}),
    );
    std::fs::remove_dir_all(&shot.dir)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plane over the whole pool at `height` radii above the liquid's top, tilted by
    /// `degrees` about z (its middle at that height).
    fn plane(height: f32, degrees: f32) -> Mesh {
        let size = (LATTICE - 1).as_vec3() * 2.0 * R;
        let centre = Vec3::new(size.x / 2.0, size.y + R + height * R, size.z / 2.0);
        let turn = glam::Quat::from_rotation_z(degrees.to_radians());
        let mut mesh = Mesh::default();
        let n = 60u32;
        for i in 0..=n {
            for k in 0..=n {
                let p = Vec3::new(i as f32 / n as f32 - 0.5, 0.0, k as f32 / n as f32 - 0.5);
                mesh.positions
                    .push(centre + turn * (p * Vec3::new(size.x, 0.0, size.z)));
            }
        }
        let v = |a: u32, b: u32| a * (n + 1) + b;
        for i in 0..n {
            for k in 0..n {
                mesh.triangles.push([v(i, k), v(i, k + 1), v(i + 1, k)]);
                mesh.triangles
                    .push([v(i + 1, k), v(i, k + 1), v(i + 1, k + 1)]);
            }
        }
        mesh
    }

    #[test]
    fn a_pools_top_is_measured_in_its_middle() {
        let (tilt, height) = top(&plane(0.5, 0.0));
        assert!(
            tilt.abs() < 1e-3 && (height - 0.5).abs() < 1e-3,
            "{tilt} {height}"
        );
        let (tilt, height) = top(&plane(-0.25, 1.0));
        assert!((tilt - 1.0).abs() < 1e-3, "{tilt}");
        assert!((height + 0.25).abs() < 0.01, "{height}");
    }
}
