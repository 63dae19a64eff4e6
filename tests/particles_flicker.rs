//! The skin's reason to exist (paper §1, §6.1): on a static cloud whose particles jitter
//! from frame to frame, the skin filters the noise in time, where surfacing each frame's
//! density on its own flickers. Flicker = mean distance from one frame's surface to the
//! previous one's; accuracy = mean distance to the iso-density surface of the cloud at
//! rest. Goal (issue 6): ≥ 3× less flicker at about the same accuracy.

use activeskin::mesh::Mesh;
use activeskin::polygonize::mesh_vdb;
use activeskin::skin::{Skin, SkinParams, SpeedParams};
use activeskin::target::{iso_for_radius, Density, Target};
use activeskin::validate::mean_distance;
use glam::Vec3;

const RADIUS: f32 = 0.05;

fn lattice_ball() -> Vec<Vec3> {
    let n = (0.4 / RADIUS) as i32;
    let mut points = Vec::new();
    for x in -n..=n {
        for y in -n..=n {
            for z in -n..=n {
                let p = Vec3::new(x as f32, y as f32, z as f32) * RADIUS;
                if p.length() <= 0.4 {
                    points.push(p);
                }
            }
        }
    }
    points
}

fn jittered(points: &[Vec3], seed: u64) -> Vec<Vec3> {
    let mut state = seed.wrapping_mul(0x9E3779B97F4A7C15) | 1;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.6 * RADIUS
    };
    points
        .iter()
        .map(|&p| p + Vec3::new(next(), next(), next()))
        .collect()
}

fn accuracy(mesh: &Mesh, rest: &Density) -> f64 {
    let d: f64 = mesh
        .positions
        .iter()
        .map(|&p| f64::from(rest.distance(p).abs()))
        .sum();
    d / mesh.positions.len() as f64
}

#[test]
fn skin_flickers_three_times_less_than_per_frame_surfacing() {
    let h = 2.0 * RADIUS;
    let iso = iso_for_radius(RADIUS, h);
    let dx = 0.5 * RADIUS;
    let base = lattice_ball();
    let rest = Density::new(base.clone(), h, iso);
    let frames: Vec<Density> = (0..16)
        .map(|k| Density::new(jittered(&base, k), h, iso))
        .collect();

    let per_frame: Vec<Mesh> = frames
        .iter()
        .map(|d| mesh_vdb(&d.to_fog_volume(dx), |g| ((iso - g) / iso).clamp(-1.0, 1.0)))
        .collect();
    let params = SkinParams {
        dx,
        speed: SpeedParams {
            alpha: 4.0,
            beta: 0.0,
            ..SpeedParams::default()
        },
        ..SkinParams::default()
    };
    let mut skin: Skin<f32> = Skin::new(&frames[0], params);
    let mut skins = vec![skin.mesh().clone()];
    for frame in &frames[1..] {
        skin.advance(frame as &dyn Target, 1.0 / 24.0);
        skins.push(skin.mesh().clone());
    }

    // Frames 8–15: the skin has settled from its start.
    let flicker = |meshes: &[Mesh]| {
        (8..16)
            .map(|k| mean_distance(&meshes[k], &meshes[k - 1], dx))
            .sum::<f64>()
            / 8.0
            / f64::from(dx)
    };
    let error = |meshes: &[Mesh]| {
        (8..16).map(|k| accuracy(&meshes[k], &rest)).sum::<f64>() / 8.0 / f64::from(dx)
    };
    let (skin_flicker, frame_flicker) = (flicker(&skins), flicker(&per_frame));
    let (skin_error, frame_error) = (error(&skins), error(&per_frame));
    println!(
        "flicker: skin {skin_flicker:.4} voxel, per-frame {frame_flicker:.4} voxel ({:.1}× less); \
         distance to the rest surface: skin {skin_error:.3}, per-frame {frame_error:.3} voxel",
        frame_flicker / skin_flicker
    );
    assert!(
        skin_flicker * 3.0 <= frame_flicker,
        "{skin_flicker} vs {frame_flicker}"
    );
    assert!(
        skin_error <= 1.5 * frame_error,
        "{skin_error} vs {frame_error}"
    );
}
