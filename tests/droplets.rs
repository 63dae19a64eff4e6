//! A droplet leaving the liquid (issue 49): SPH spray is clumps of two or three particles
//! a few radii off the surface. Summed, our kernel joins particles up to 4.25 radii
//! apart, so the density held such a drop to the liquid by a neck, and the skin, a
//! filter in time, kept the neck for frames after it broke. Now a cluster of a few
//! particles more than the spray's link (3.25 radii) from every other particle is
//! rasterized apart and united with the rest, and the skin takes the frame's target's
//! surface around it: the drop is apart on the frame it is.

mod common;

use activeskin::particles::Particles;
use glam::Vec3;

const R: f32 = 0.005;
const FPS: f32 = 24.0;
const FRAMES: i64 = 8;
/// How far the drop rises a frame, in radii.
const RISE: f32 = 1.0;

/// A pool of 16 × 16 × 5 particles 2r apart at rest and, above its middle, a clump of
/// three particles half a radius apart whose lowest is 2r above the pool's top layer on
/// frame 1 (a particle of the pool's surface) and rises `RISE` radii a frame.
fn frame(frame: i64) -> Particles {
    let mut positions = Vec::new();
    for i in 0..16 {
        for j in 0..16 {
            for k in 0..5 {
                positions.push(Vec3::new(i as f32, j as f32, k as f32) * 2.0 * R);
            }
        }
    }
    let pool = positions.len();
    let gap = 2.0 + RISE * (frame - 1) as f32;
    let bottom = Vec3::new(8.0, 8.0, 4.0) * 2.0 * R + Vec3::Z * gap * R;
    for offset in [
        Vec3::ZERO,
        Vec3::new(0.5, 0.0, 0.2),
        Vec3::new(0.2, 0.45, 0.3),
    ] {
        positions.push(bottom + offset * R);
    }
    let speed = RISE * R * FPS;
    let velocities = (0..positions.len())
        .map(|i| {
            if i < pool {
                Vec3::ZERO
            } else {
                Vec3::Z * speed
            }
        })
        .collect();
    Particles {
        ids: Some((0..positions.len() as i64).collect()),
        velocities: Some(velocities),
        positions,
        ..Particles::default()
    }
}

/// The drop's nearest distance to the pool's particles on `frame`, in radii.
fn gap(frame: i64) -> f32 {
    2.0 + RISE * (frame - 1) as f32
}

#[test]
fn a_drop_leaving_the_liquid_is_apart_on_the_frame_it_is() {
    let dir = common::scratch();
    let meshes = common::particle_shot(dir.path(), FRAMES, frame, R, &[]);
    let share = f64::from(2.0 * R).powi(3);
    for (k, mesh) in meshes.iter().enumerate() {
        let f = k as i64 + 1;
        let check = mesh.check();
        assert!(check.is_clean(), "frame {f}: {check}");
        let found = common::mesh_pieces(mesh);
        // Part of the pool while a particle of its surface; apart past the link.
        let apart = gap(f) > 3.25;
        assert_eq!(
            found.len(),
            if apart { 2 } else { 1 },
            "frame {f}, {} radii off the pool: pieces {found:?}",
            gap(f)
        );
        if apart {
            let (volume, centre) = found[0];
            let particles = frame(f).positions;
            let drop: Vec3 = particles[particles.len() - 3..].iter().sum::<Vec3>() / 3.0;
            assert!(
                centre.distance(drop) < 0.5 * R,
                "frame {f}: the drop's surface is centred {} radii off its particles",
                centre.distance(drop) / R
            );
            // No less than a lone particle's droplet, (2r)³, no more than its three
            // particles stand for.
            assert!(
                (1.0..=3.0).contains(&(volume / share)),
                "frame {f}: the drop holds {:.2} particles' volume",
                volume / share
            );
        }
    }
}
