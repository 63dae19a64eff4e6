//! Temporal quality on particles (issue 6, paper §6.1): on a static cloud whose particles
//! jitter from frame to frame, how much the surface moves that the particles' own motion
//! does not explain. Flicker = mean distance from one frame's surface to the previous
//! one's; error = mean distance to the iso-density surface of the cloud at rest. The skin
//! is compared with surfacing each frame's density on its own (our marching cubes on G).

use glam::Vec3;

use crate::mesh::mean_distance;
use crate::mesh::Mesh;
use crate::polygonize::mesh_vdb;
use crate::skin::{Skin, SkinParams, SpeedParams};
use crate::target::{iso_for_radius, Density, Target};

/// Flicker and error of both surfaces, in voxels, over the settled frames.
#[derive(Debug, Clone, Copy)]
pub struct Flicker {
    /// The skin's surface: its mean motion from frame to frame.
    pub skin: f64,
    /// Marching cubes on each frame's density alone: the same.
    pub per_frame: f64,
    /// The skin's mean distance to the cloud's surface at rest.
    pub skin_error: f64,
    /// The per-frame surface's, the same.
    pub per_frame_error: f64,
}

/// A ball of radius 0.4 filled with particles of radius `radius` on a lattice of that
/// spacing, each moved by up to ±`jitter`·radius per axis every frame (repeatably), over
/// `frames` frames at 24 fps, voxel radius/2; the skin with attraction `alpha`, no
/// tension. The second half of the frames is measured (the skin has settled).
pub fn jittered_ball(radius: f32, jitter: f32, frames: usize, alpha: f32) -> Flicker {
    let h = 2.0 * radius;
    let iso = iso_for_radius(radius, h);
    let dx = 0.5 * radius;
    let base = lattice_ball(radius);
    let rest = Density::new(base.clone(), h, iso);
    let clouds: Vec<Density> = (0..frames as u64)
        .map(|k| Density::new(jittered(&base, k, jitter * radius), h, iso))
        .collect();

    let per_frame: Vec<Mesh> = clouds
        .iter()
        .map(|d| mesh_vdb(d.to_fog_volume(dx), |g| ((iso - g) / iso).clamp(-1.0, 1.0)))
        .collect();
    let params = SkinParams {
        dx,
        speed: SpeedParams {
            alpha,
            beta: 0.0,
            ..SpeedParams::default()
        },
        ..SkinParams::default()
    };
    let mut skin: Skin<f32> = Skin::new(&clouds[0], params);
    let mut skins = vec![skin.mesh().clone()];
    for cloud in &clouds[1..] {
        skin.advance(cloud as &dyn Target, 1.0 / 24.0);
        skins.push(skin.mesh().clone());
    }

    let settled = frames / 2..frames;
    let count = settled.len() as f64;
    let voxels = f64::from(dx);
    let flicker = |meshes: &[Mesh]| {
        settled
            .clone()
            .map(|k| mean_distance(&meshes[k], &meshes[k - 1], dx))
            .sum::<f64>()
            / count
            / voxels
    };
    let error = |meshes: &[Mesh]| {
        settled
            .clone()
            .map(|k| mean_surface_distance(&meshes[k], &rest))
            .sum::<f64>()
            / count
            / voxels
    };
    Flicker {
        skin: flicker(&skins),
        per_frame: flicker(&per_frame),
        skin_error: error(&skins),
        per_frame_error: error(&per_frame),
    }
}

fn lattice_ball(spacing: f32) -> Vec<Vec3> {
    let n = (0.4 / spacing) as i32;
    (-n..=n)
        .flat_map(|x| {
            (-n..=n)
                .flat_map(move |y| (-n..=n).map(move |z| Vec3::new(x as f32, y as f32, z as f32)))
        })
        .map(|c| c * spacing)
        .filter(|p| p.length() <= 0.4)
        .collect()
}

/// Each point moved by up to ±`amplitude` per axis, repeatably for a given `seed`.
pub fn jittered(points: &[Vec3], seed: u64, amplitude: f32) -> Vec<Vec3> {
    let mut state = seed.wrapping_mul(0x9E3779B97F4A7C15) | 1;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 2.0 * amplitude
    };
    points
        .iter()
        .map(|&p| p + Vec3::new(next(), next(), next()))
        .collect()
}

/// Mean distance of the mesh's vertices to the density's iso surface.
fn mean_surface_distance(mesh: &Mesh, density: &Density) -> f64 {
    let d: f64 = mesh
        .positions
        .iter()
        .map(|&p| f64::from(density.distance(p).abs()))
        .sum();
    d / mesh.positions.len() as f64
}
