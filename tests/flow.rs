//! Skins carried by the material's velocity (paper §7): no lag on moving, noisy targets,
//! and pure advection that keeps shape and volume.

use std::f32::consts::PI;

use activeskin::flow::{Flow, Rigid, Traced};
use activeskin::mesh::{hausdorff, Mesh};
use activeskin::polygonize::mesh_vdb;
use activeskin::skin::{Skin, SkinParams, SpeedParams};
use activeskin::target::{sample, Aabb, BoxShape, Sphere, Target};
use glam::Vec3;

const DX: f32 = 1.0 / 32.0;
const FPS: f32 = 24.0;

fn params(alpha: f32, beta: f32) -> SkinParams {
    SkinParams {
        dx: DX,
        speed: SpeedParams {
            alpha,
            beta,
            ..SpeedParams::default()
        },
        ..SkinParams::default()
    }
}

/// A sphere carried by a rigid motion whose surface carries smooth bumps of about
/// `amplitude` that change every frame, as a simulation's surface does.
struct Noisy {
    clean: Sphere,
    amplitude: f32,
    seed: f32,
}

impl Target for Noisy {
    fn distance(&self, p: Vec3) -> f32 {
        let n = (p - self.clean.center).normalize_or_zero();
        let s = self.seed;
        let bumps = (3.0 * n.x + 1.7 * s).sin() * (2.0 * n.y + 2.3 * s).cos()
            + (4.0 * n.z + 0.9 * s).sin() * 0.5;
        self.clean.distance(p) - self.amplitude * bumps
    }
    fn bounds(&self) -> Aabb {
        self.clean.bounds().padded(2.0 * self.amplitude)
    }
}

/// Mean and worst distance of the mesh's vertices to `clean`, voxels; infinite if empty.
fn error(mesh: &Mesh, clean: &dyn Target) -> (f64, f64) {
    if mesh.positions.is_empty() {
        return (f64::INFINITY, f64::INFINITY);
    }
    let d: Vec<f64> = mesh
        .positions
        .iter()
        .map(|&p| f64::from(clean.distance(p).abs() / DX))
        .collect();
    (
        d.iter().sum::<f64>() / d.len() as f64,
        d.iter().copied().fold(0.0, f64::max),
    )
}

struct Run {
    mean: f64,
    worst_frame: f64,
    per_frame_meshing: f64,
}

/// Dresses `frames` frames of a noisy sphere of radius `radius` moved by `motion`, with
/// the motion given to the skin or not; errors over the second half (settled).
fn follow(motion: Rigid, radius: f32, frames: usize, alpha: f32, with_flow: bool) -> Run {
    let start = Vec3::splat(0.0);
    // Where the rigid motion takes a point after `t` seconds (exact: rotation about the
    // centre's axis, then translation).
    let carry = |p: Vec3, t: f32| {
        let angle = motion.angular.length() * t;
        let axis = motion.angular.normalize_or_zero();
        let rotated = if angle > 0.0 {
            glam::Quat::from_axis_angle(axis, angle) * (p - motion.center) + motion.center
        } else {
            p
        };
        rotated + motion.linear * t
    };
    let clean_at = |frame: usize| Sphere {
        center: carry(start + Vec3::new(0.2, 0.0, 0.0), frame as f32 / FPS),
        radius,
    };
    let noisy_at = |frame: usize| Noisy {
        clean: clean_at(frame),
        amplitude: DX,
        seed: frame as f32 * 1.37,
    };
    // β whose rest offset 2β/(αr) is under 0.02 voxel.
    let beta = 0.01 * DX * alpha * radius;
    let mut skin: Skin<f32> = Skin::new(&noisy_at(0), params(alpha, beta));
    let (mut sum, mut n, mut worst, mut meshing) = (0.0, 0, 0.0f64, 0.0);
    for frame in 1..frames {
        let target = noisy_at(frame);
        let flow: Option<&dyn Flow> = with_flow.then_some(&motion as &dyn Flow);
        skin.advance_in_flow(&target, flow, 1.0 / f64::from(FPS));
        let (mean, _) = error(skin.mesh(), &clean_at(frame));
        if frame >= frames / 2 {
            sum += mean;
            n += 1;
            worst = worst.max(mean);
            let fresh = mesh_vdb(sample::level_set(&target, DX, 3.0), |v| v / (3.0 * DX));
            meshing += error(&fresh, &clean_at(frame)).0;
        }
    }
    Run {
        mean: sum / f64::from(n),
        worst_frame: worst,
        per_frame_meshing: meshing / f64::from(n),
    }
}

#[test]
fn a_gliding_noisy_sphere_is_followed_without_lag() {
    // 5 voxels a frame along x.
    let motion = Rigid {
        center: Vec3::ZERO,
        linear: Vec3::new(5.0 * DX * FPS, 0.0, 0.0),
        angular: Vec3::ZERO,
    };
    let with = follow(motion, 0.3, 24, 4.0, true);
    let without = follow(motion, 0.3, 24, 4.0, false);
    println!(
        "gliding sphere: with velocity mean {:.3} voxel (worst frame {:.3}), without {:.3} ({:.3}), per-frame meshing of the noisy target {:.3}",
        with.mean, with.worst_frame, without.mean, without.worst_frame, with.per_frame_meshing
    );
    assert!(
        with.mean <= 0.5 * with.per_frame_meshing,
        "{:.3}",
        with.mean
    );
    assert!(with.worst_frame <= 2.0);
    assert!(
        without.mean > 4.0 * with.mean,
        "without velocity the skin lags"
    );
}

#[test]
fn a_spinning_noisy_shape_is_followed_without_lag() {
    // Half a turn a second about an axis through the origin; the sphere sits off it.
    let motion = Rigid {
        center: Vec3::ZERO,
        linear: Vec3::ZERO,
        angular: Vec3::new(0.0, 0.0, PI),
    };
    let with = follow(motion, 0.25, 36, 4.0, true);
    let without = follow(motion, 0.25, 36, 4.0, false);
    println!(
        "spinning shape: with velocity mean {:.3} voxel (worst frame {:.3}), without {:.3} ({:.3}), per-frame meshing {:.3}",
        with.mean, with.worst_frame, without.mean, without.worst_frame, with.per_frame_meshing
    );
    assert!(
        with.mean <= 0.5 * with.per_frame_meshing,
        "{:.3}",
        with.mean
    );
    assert!(with.worst_frame <= 2.0);
    assert!(
        without.mean > 4.0 * with.mean,
        "without velocity the skin lags"
    );
}

/// Carries `start` through one full turn about the z axis (2 s, α = β = 0) at voxel
/// `dx`; returns the volume change (fraction) and the Hausdorff distance between the start
/// and end meshes (voxels).
fn one_turn(start: &dyn Target, dx: f32) -> (f64, f64) {
    let motion = Rigid {
        center: Vec3::ZERO,
        linear: Vec3::ZERO,
        angular: Vec3::new(0.0, 0.0, PI),
    };
    let params = SkinParams {
        dx,
        ..params(0.0, 0.0)
    };
    let mut skin: Skin<f32> = Skin::new(start, params);
    let first = skin.mesh().clone();
    let volume0 = skin.stats().volume;
    for _ in 0..48 {
        skin.advance_in_flow(start, Some(&motion), 1.0 / f64::from(FPS));
    }
    let volume = (skin.stats().volume - volume0) / volume0;
    let shape = hausdorff(&first, skin.mesh(), dx) / f64::from(dx);
    (volume, shape)
}

#[test]
fn pure_advection_through_a_full_turn_keeps_shape_and_volume() {
    // α = 0, β = 0: the skin is only carried. A sphere of 8 voxels, 0.3 off the axis.
    let sphere = Sphere {
        center: Vec3::new(0.3, 0.0, 0.0),
        radius: 0.25,
    };
    let (volume, shape) = one_turn(&sphere, DX);
    println!(
        "pure advection of a sphere (8 voxels), one turn: volume {:+.2} %, start to end {shape:.3} voxel",
        100.0 * volume
    );
    assert!(volume.abs() < 0.01, "{volume}");
    assert!(shape < 0.5, "{shape}");
}

/// A glide fast and diagonal: the flow moves the skin up to 0.9 voxel a sub-step, which a
/// tube of face neighbours covers only along the axes (a front along (1, 1, 1) gains
/// 1/√3 voxel a step there). With it this sphere broke into 800 droplets in a second.
#[test]
fn a_fast_diagonal_glide_keeps_the_sphere_whole() {
    for (direction, speed) in [(Vec3::new(1.0, 1.0, 0.0), 6.0), (Vec3::ONE, 3.3)] {
        let start = Sphere {
            center: Vec3::new(0.013, 0.007, 0.011),
            radius: 0.25,
        };
        let velocity = direction.normalize() * speed * DX * FPS; // voxels a frame
        let motion = Rigid {
            center: Vec3::ZERO,
            linear: velocity,
            angular: Vec3::ZERO,
        };
        let mut skin: Skin<f32> = Skin::new(&start, params(0.0, 0.0));
        let (volume0, area0) = (skin.stats().volume, skin.stats().area);
        let frames = 24;
        for _ in 0..frames {
            skin.advance_in_flow(&start, Some(&motion), 1.0 / f64::from(FPS));
        }
        let end = Sphere {
            center: start.center + velocity * (frames as f32 / FPS),
            ..start
        };
        let stats = skin.stats();
        let (off, _) = error(skin.mesh(), &end);
        let volume = stats.volume / volume0 - 1.0;
        println!(
            "glide {speed} voxels a frame along {direction}: {} component(s), volume {:+.1} %, area {:+.1} %, {off:.3} voxel off",
            stats.components,
            100.0 * volume,
            100.0 * (stats.area / area0 - 1.0)
        );
        assert_eq!(stats.components, 1);
        assert!(skin.mesh().check().is_clean());
        assert!(volume.abs() < 0.06, "{volume}");
        assert!(off < 0.5, "{off}");
    }
}

/// Zalesak's slotted sphere: a sphere with a slot cut into it, whose sharp edges show
/// what the advection smears.
struct Slotted {
    sphere: Sphere,
    slot: BoxShape,
}

impl Target for Slotted {
    fn distance(&self, p: Vec3) -> f32 {
        self.sphere.distance(p).max(-self.slot.distance(p))
    }
    fn bounds(&self) -> Aabb {
        self.sphere.bounds()
    }
}

impl Slotted {
    /// Zalesak's disc in 3-D: radius 15 voxels, slot 5 voxels wide and 25 deep, 0.3 off the
    /// axis.
    fn zalesak(dx: f32) -> Self {
        let center = Vec3::new(0.3, 0.0, 0.0);
        Slotted {
            sphere: Sphere {
                center,
                radius: 15.0 * dx,
            },
            slot: BoxShape {
                center: center + Vec3::new(0.0, 5.0 * dx, 0.0),
                half_size: Vec3::new(2.5 * dx, 12.5 * dx, 1.0),
            },
        }
    }
}

#[test]
fn zalesaks_slotted_sphere_through_a_full_turn() {
    // Radius 15 voxels, slot 5 voxels wide and 25 deep, 0.3 off the axis at Δx = 1/50.
    let dx = 1.0 / 50.0;
    let slotted = Slotted::zalesak(dx);
    let (volume, shape) = one_turn(&slotted, dx);
    println!(
        "Zalesak's slotted sphere, one turn: volume {:+.2} %, start to end {shape:.3} voxel (Hausdorff, sharp edges included)",
        100.0 * volume
    );
    assert!(volume.abs() < 0.05, "{volume}");
    assert!(shape < 3.0, "{shape}");
}

/// Enright's deformation field, its sign reversing over `period` so that the shape comes
/// back: held fixed through each frame at its mid-frame value.
struct Enright {
    period: f32,
    time: f32,
}

impl Flow for Enright {
    fn velocity(&self, p: Vec3) -> Vec3 {
        let s = |v: f32| (PI * v).sin();
        let s2 = |v: f32| (2.0 * PI * v).sin();
        let fade = (PI * self.time / self.period).cos();
        Vec3::new(
            2.0 * s(p.x).powi(2) * s2(p.y) * s2(p.z),
            -s2(p.x) * s(p.y).powi(2) * s2(p.z),
            -s2(p.x) * s2(p.y) * s(p.z).powi(2),
        ) * fade
    }
}

#[test]
fn enrights_deformation_comes_back() {
    // A sphere of radius 0.15 at (0.35, 0.35, 0.35), Δx = 1/64 (9.6 voxels), stretched
    // into a sheet and brought back over 3 s.
    let dx = 1.0 / 64.0;
    let sphere = Sphere {
        center: Vec3::splat(0.35),
        radius: 0.15,
    };
    let params = SkinParams {
        dx,
        ..params(0.0, 0.0)
    };
    let mut skin: Skin<f32> = Skin::new(&sphere, params);
    let first = skin.mesh().clone();
    let volume0 = skin.stats().volume;
    let frames = 72;
    let mut halfway = 0.0;
    for frame in 0..frames {
        let flow = Enright {
            period: 3.0,
            time: (frame as f32 + 0.5) / FPS,
        };
        skin.advance_in_flow(&sphere, Some(&flow), 1.0 / f64::from(FPS));
        if frame == frames / 2 - 1 {
            halfway = skin.stats().volume;
        }
    }
    let volume = (skin.stats().volume - volume0) / volume0;
    let shape = hausdorff(&first, skin.mesh(), 4.0 * dx) / f64::from(dx);
    println!(
        "Enright's deformation (3 s, Δx = 1/64): volume at the most stretched {:+.1} %, at the end {:+.2} %, start to end {shape:.2} voxel",
        100.0 * (halfway - volume0) / volume0,
        100.0 * volume
    );
    assert!(volume.abs() < 0.2, "{volume}");
    assert!(skin.mesh().check().is_clean());
}

/// The skin carried by a frame's flow map ([`Skin::carry`], one trace a frame) instead of
/// sub-steps of a velocity: `frames` frames of `motion` (α = β = 0: carried only).
fn carried(start: &dyn Target, motion: Rigid, frames: usize, dx: f32) -> (Skin<f32>, Mesh) {
    let params = SkinParams {
        dx,
        ..params(0.0, 0.0)
    };
    let mut skin: Skin<f32> = Skin::new(start, params);
    let first = skin.mesh().clone();
    let bounds = Aabb {
        min: Vec3::splat(-4.0),
        max: Vec3::splat(4.0),
    };
    for _ in 0..frames {
        let map = Traced {
            flow: &motion,
            bounds,
            step: dx / 4.0,
        };
        skin.carry(&map, 1.0 / FPS);
    }
    (skin, first)
}

#[test]
fn a_flow_map_carries_the_skin_twenty_voxels_a_frame_in_one_trace() {
    // A sphere of 8 voxels gliding 20 voxels a frame along a diagonal, 8 frames.
    let sphere = Sphere {
        center: Vec3::new(-2.0, -1.0, 0.2),
        radius: 0.25,
    };
    let linear = Vec3::new(1.0, 0.5, 0.25).normalize() * 20.0 * DX * FPS;
    let motion = Rigid {
        center: Vec3::ZERO,
        linear,
        angular: Vec3::ZERO,
    };
    let (skin, first) = carried(&sphere, motion, 8, DX);
    let moved = Sphere {
        center: sphere.center + linear * 8.0 / FPS,
        ..sphere
    };
    let (mean, worst) = error(skin.mesh(), &moved);
    // Against the start's own mesh (marching cubes of an 8-voxel sphere is 1.4 % under).
    let volume = skin.stats().volume / first.area_and_volume().1 - 1.0;
    println!(
        "flow map, sphere (8 voxels) 20 voxels a frame, 8 frames: {mean:.3} voxel off (worst {worst:.3}), volume {:+.2} %, {} component(s)",
        100.0 * volume,
        skin.stats().components
    );
    assert_eq!(skin.stats().components, 1);
    assert!(mean < 0.05 && worst < 0.15, "{mean} {worst}");
    assert!(volume.abs() < 0.002, "{volume}");
}

#[test]
fn a_flow_map_turns_zalesaks_sphere_with_its_edges() {
    // The same disc as the advection's full turn, in 48 traces of 7.5°.
    let dx = 1.0 / 50.0;
    let slotted = Slotted::zalesak(dx);
    let motion = Rigid {
        center: Vec3::ZERO,
        linear: Vec3::ZERO,
        angular: Vec3::new(0.0, 0.0, PI),
    };
    let (skin, first) = carried(&slotted, motion, 48, dx);
    let volume = skin.stats().volume / first.area_and_volume().1 - 1.0;
    let shape = hausdorff(&first, skin.mesh(), dx) / f64::from(dx);
    println!(
        "flow map, Zalesak's slotted sphere, one turn in 48 traces: volume {:+.2} %, start to end {shape:.3} voxel (Hausdorff)",
        100.0 * volume
    );
    assert!(volume.abs() < 0.005, "{volume}");
    assert!(shape < 1.5, "{shape}");
}
