//! Topology from the target: material the skin has nothing near — an emitter starting,
//! a target that ran away — is seeded, so no target component stays missing.

use activeskin::skin::{Skin, SkinParams, SpeedParams};
use activeskin::target::{Sphere, Target, Union};
use glam::Vec3;

const DX: f32 = 1.0 / 32.0;

fn params() -> SkinParams {
    SkinParams {
        dx: DX,
        speed: SpeedParams::default_for(DX, 4.0),
        ..SkinParams::default()
    }
}

fn sphere(x: f32) -> Sphere {
    Sphere {
        center: Vec3::new(x, 0.0, 0.0),
        radius: 0.25,
    }
}

#[test]
fn an_emitter_starting_far_from_the_skin_is_seeded_at_once() {
    let first = sphere(0.0);
    let both = Union(vec![Box::new(sphere(0.0)), Box::new(sphere(1.2))]);
    for seeding in [true, false] {
        let mut skin: Skin<f32> = Skin::new(&first, params());
        for frame in 1..=6 {
            let target: &dyn Target = if frame < 4 { &first } else { &both };
            skin.advance(target, 1.0 / 24.0);
            if seeding {
                skin.seed(target);
            }
            let components = skin.stats().components;
            let expected = if seeding && frame >= 4 { 2 } else { 1 };
            assert_eq!(components, expected, "seeding {seeding}, frame {frame}");
        }
        let check = skin.mesh().check();
        assert!(check.is_clean(), "{check}");
    }
}

#[test]
fn a_target_that_outruns_the_skin_is_never_lost() {
    // 5 voxels a frame, α = 4, no velocity: the skin falls behind and, unseeded, loses it
    // (empty frames from then on).
    let mut seeded: Skin<f32> = Skin::new(&sphere(0.0), params());
    let mut plain: Skin<f32> = Skin::new(&sphere(0.0), params());
    let mut lost = None;
    for frame in 1..=24 {
        let target = sphere(5.0 * DX * frame as f32);
        seeded.advance(&target, 1.0 / 24.0);
        seeded.seed(&target);
        plain.advance(&target, 1.0 / 24.0);
        // Behind (α = 4 lags), but within a block of the target on every frame.
        let nearest = seeded
            .mesh()
            .positions
            .iter()
            .map(|&p| target.distance(p).abs() / DX)
            .fold(f32::INFINITY, f32::min);
        assert!(
            nearest < 8.0,
            "frame {frame}: the seeded skin is {nearest} voxels off"
        );
        if lost.is_none() && plain.mesh().triangles.is_empty() {
            lost = Some(frame);
        }
    }
    assert!(
        lost.is_some(),
        "unseeded, the skin was expected to lose the target"
    );
}

/// A droplet torn off within a block of the skin — too near for the block rule, too small
/// and too far for the attraction to grow it — is seeded as its own piece; target
/// material that the skin only lags behind, or a droplet nearer than 1 voxel, is left to
/// the attraction.
#[test]
fn a_droplet_the_skin_lost_nearby_is_seeded_and_nothing_joined_to_it() {
    let body = sphere(0.0);
    let droplet = |gap: f32| Sphere {
        center: Vec3::new(0.25 + (gap + 1.5) * DX, 0.0, 0.0),
        radius: 1.5 * DX,
    };
    let with = |gap: f32| Union(vec![Box::new(sphere(0.0)), Box::new(droplet(gap))]);
    for (gap, pieces) in [(3.0, 2), (1.8, 2), (0.6, 1)] {
        let mut skin: Skin<f32> = Skin::new(&body, params());
        let target = with(gap);
        let seeded = skin.seed(&target);
        assert_eq!(
            (seeded > 0, skin.stats().components),
            (pieces == 2, pieces),
            "a droplet {gap} voxels off"
        );
        let check = skin.mesh().check();
        assert!(check.is_clean(), "{check}");
        if pieces == 2 {
            // The droplet as the target has it: the seed is the target's own surface.
            let far = skin
                .mesh()
                .positions
                .iter()
                .filter(|p| p.x > 0.25 + 0.5 * gap * DX)
                .map(|&p| droplet(gap).distance(p).abs() / DX)
                .fold(0.0f32, f32::max);
            assert!(
                far < 0.3,
                "the seeded droplet is {far} voxels off its sphere"
            );
        }
    }
    // The target grown 2 voxels all round: its material lies outside the skin, joined to
    // it everywhere, and no piece of it is lost.
    let mut skin: Skin<f32> = Skin::new(&body, params());
    let grown = Sphere {
        radius: 0.25 + 2.0 * DX,
        ..sphere(0.0)
    };
    assert_eq!(skin.seed(&grown), 0);
    assert_eq!(skin.stats().components, 1);
}
