//! `activeskin particles` on a liquid in motion (issue 27): a ball of particles thrown
//! down 20 voxels a frame hits the floor and spreads, its velocities consistent with its
//! motion and its volume conserved. The skin keeps the volume on every frame, sits on each
//! frame's own density (no lag), and the motion does not set the number of sub-steps.
#![cfg(feature = "vdb")]

mod common;

use std::path::Path;

use activeskin::frames::ParticleInput;
use activeskin::skin::{Skin, SkinParams};
use activeskin::target::{fluid_iso, Target, DEFAULT_SMOOTHING_LENGTH};
use glam::Vec3;

const R: f32 = 0.01;
const BALL: f32 = 0.12;
const FPS: f32 = 24.0;
/// Thrown down at 20 voxels (of R) a frame.
const THROWN: f32 = 20.0 * R * FPS;
const G: f32 = 9.81;
/// The ball's lowest point starts this high above the floor (z = 0).
const HEIGHT: f32 = 0.6;
/// After touching, its height is divided by 1 + SPREAD·t and its radius multiplied by the
/// square root: a motion that keeps the volume.
const SPREAD: f32 = 6.0;

/// The lattice ball (spacing 2R), lowest point at `HEIGHT`.
fn ball() -> Vec<Vec3> {
    let n = (BALL / (2.0 * R)) as i32;
    let mut points = Vec::new();
    for x in -n..=n {
        for y in -n..=n {
            for z in -n..=n {
                let p = Vec3::new(x as f32, y as f32, z as f32) * 2.0 * R;
                if p.length() <= BALL {
                    points.push(p + Vec3::new(0.5, 0.5, HEIGHT + BALL));
                }
            }
        }
    }
    points
}

/// Position and velocity at time `t` of the particle that starts at `p`.
fn motion(p: Vec3, t: f32) -> (Vec3, Vec3) {
    // Falls until its lowest point meets the floor.
    let contact = (-THROWN + (THROWN * THROWN + 2.0 * G * HEIGHT).sqrt()) / G;
    if t <= contact {
        let fall = THROWN * t + 0.5 * G * t * t;
        return (p - Vec3::Z * fall, -Vec3::Z * (THROWN + G * t));
    }
    let landed = p - Vec3::Z * HEIGHT;
    let s = 1.0 + SPREAD * (t - contact);
    let centre = Vec3::new(0.5, 0.5, 0.0);
    let d = landed - centre;
    let position = centre + Vec3::new(d.x * s.sqrt(), d.y * s.sqrt(), d.z / s);
    let rate = Vec3::new(
        d.x * SPREAD / (2.0 * s.sqrt()),
        d.y * SPREAD / (2.0 * s.sqrt()),
        -d.z * SPREAD / (s * s),
    );
    (position, rate)
}

fn write_frame(path: &Path, points: &[(Vec3, Vec3)]) {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float vx\nproperty float vy\nproperty float vz\nend_header\n",
        points.len()
    )
    .into_bytes();
    for (p, v) in points {
        for c in p.to_array().into_iter().chain(v.to_array()) {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// Writes frames 1..=`frames` of the thrown ball as `dir/ball_F.ply` (unpadded).
fn write_shot(dir: &Path, frames: usize) {
    let start = ball();
    for f in 1..=frames {
        let t = (f - 1) as f32 / FPS;
        let points: Vec<(Vec3, Vec3)> = start.iter().map(|&p| motion(p, t)).collect();
        write_frame(&dir.join(format!("ball_{f}.ply")), &points);
    }
}

/// The thrown ball's run with `smooth` (`--smooth`): its volume held within 0.3 % on
/// every frame, at most `most_lag` voxels from each frame's density, in few sub-steps;
/// returns its first frame's volume.
fn thrown_ball(dir: &Path, frames: usize, smooth: &str, most_lag: f64) -> f64 {
    let pattern = dir.join("ball_$F.ply");
    let stats = dir.join(format!("stats{smooth}.jsonl"));
    let meshes = dir.join("skin.####.obj");
    let radius = R.to_string();
    let out = common::activeskin(&[
        "particles",
        "--particles",
        pattern.to_str().unwrap(),
        "--radius",
        &radius,
        "--voxel-size",
        &radius,
        "--mesh",
        meshes.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "--smooth",
        smooth,
        "-q",
    ]);
    common::assert_ok(&out);
    let lines = common::stats_lines(&stats);
    assert_eq!(lines.len(), frames);
    let density = ParticleInput {
        radius: R,
        ignore_radii: false,
        smoothing_length: DEFAULT_SMOOTHING_LENGTH,
        iso: fluid_iso(DEFAULT_SMOOTHING_LENGTH),
        density_out: None,
        dx: R,
        velocity_scale: None,

        attributes: Default::default(),
    };
    let first_volume = lines[0]["volume"].as_f64().unwrap();
    let mut report = Vec::new();
    let mut fresh_volumes = Vec::new();
    for (k, line) in lines.iter().enumerate() {
        let f = k + 1;
        let volume = line["volume"].as_f64().unwrap() / first_volume;
        let substeps = line["substeps"].as_u64().unwrap();
        let mesh = common::read_mesh(&meshes.with_file_name(format!("skin.{f:04}.obj"))).unwrap();
        let target = density
            .target(&dir.join(format!("ball_{f}.ply")), f as i64)
            .unwrap();
        let lag = mesh
            .positions
            .iter()
            .map(|&p| f64::from(target.distance(p).abs() / R))
            .sum::<f64>()
            / mesh.positions.len() as f64;
        let fresh = Skin::<f32>::new(
            &target,
            SkinParams {
                dx: R,
                ..SkinParams::default()
            },
        )
        .stats()
        .volume
            / first_volume;
        fresh_volumes.push(fresh);
        report.push(format!(
            "{f}: volume {volume:.4} (fresh {fresh:.3}), {lag:.2} voxel, {substeps} sub-steps"
        ));
        // The density's own iso-surface swells by 3 % as the ball spreads, and shrinks
        // 2 % as it thins: the skin holds the particles' volume.
        assert!((volume - 1.0).abs() <= 0.003, "frame {f}: {report:?}");
        assert!(lag <= most_lag, "frame {f}: {report:?}");
        assert!(substeps <= 3, "frame {f}: {report:?}");
        assert_eq!(line["components"].as_u64(), Some(1), "frame {f}");
    }
    println!(
        "thrown ball, --smooth {smooth}, per frame: {}",
        report.join("; ")
    );
    let fresh_range = fresh_volumes
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(
        fresh_range.1 - fresh_range.0 > 0.03,
        "the case no longer tests the hold: {report:?}"
    );
    common::assert_clean_meshes(dir);
    first_volume
}

#[test]
fn a_thrown_ball_keeps_its_volume_and_no_lag_in_few_sub_steps() {
    let dir = common::scratch();
    let frames = 12;
    write_shot(dir.path(), frames);
    let pattern = dir.path().join("ball_$F.ply");
    let radius = R.to_string();
    // Unsmoothed, the skin follows each frame's density within half a voxel; smoothed
    // (the default), within a voxel, the rim of the spreading puddle rounded.
    thrown_ball(dir.path(), frames, "0", 0.5);
    let first_volume = thrown_ball(dir.path(), frames, "1", 1.0);

    // --free-volume leaves the volume to the attraction: toward the density's, within
    // the 3 % the carry alone kept before the hold.
    let free = dir.path().join("free.jsonl");
    let out = common::activeskin(&[
        "particles",
        "--particles",
        pattern.to_str().unwrap(),
        "--radius",
        &radius,
        "--voxel-size",
        &radius,
        "--free-volume",
        "--stats",
        free.to_str().unwrap(),
        "-q",
    ]);
    common::assert_ok(&out);
    let free: Vec<f64> = common::stats_lines(&free)
        .iter()
        .map(|line| line["volume"].as_f64().unwrap() / first_volume)
        .collect();
    let worst = free.iter().map(|v| (v - 1.0).abs()).fold(0.0, f64::max);
    assert!((0.005..0.03).contains(&worst), "{free:?}");
}

#[test]
fn a_chunk_holds_the_volume_the_whole_shot_holds() {
    let dir = common::scratch();
    write_shot(dir.path(), 12);
    let pattern = dir.path().join("ball_$F.ply");
    let run = |stats: &Path, frames: &[&str]| {
        let mut args = particles_at_r(&pattern);
        args.extend_from_slice(&["--stats", stats.to_str().unwrap(), "-q"]);
        args.extend_from_slice(frames);
        common::assert_ok(&common::activeskin(&args));
        common::stats_lines(stats)
    };
    let whole = run(&dir.path().join("whole.jsonl"), &[]);
    // Warmed up from frame 5, on the spreading ball: its volume comes from frame 1.
    let chunk = run(
        &dir.path().join("chunk.jsonl"),
        &["--frames", "8-12", "--warmup", "3"],
    );
    assert_eq!(chunk.len(), 5);
    for line in &chunk {
        let frame = line["frame"].as_u64().unwrap() as usize;
        let (a, b) = (
            line["volume"].as_f64().unwrap(),
            whole[frame - 1]["volume"].as_f64().unwrap(),
        );
        assert!((a / b - 1.0).abs() < 2e-3, "frame {frame}: {a} against {b}");
    }
}

#[test]
fn a_carried_run_resumes_bit_for_bit() {
    let dir = common::scratch();
    write_shot(dir.path(), 10);
    let pattern = dir.path().join("ball_$F.ply");
    let run = |out: &Path, resume: bool| {
        let extra: &[&str] = if resume { &["--resume"] } else { &[] };
        skin_into(&pattern, out, extra);
    };
    let whole = dir.path().join("whole");
    run(&whole, false);
    // Killed after frame 5: its first five frames on disk, then resumed.
    let resumed = dir.path().join("resumed");
    std::fs::create_dir_all(&resumed).unwrap();
    for f in 1..=5 {
        for ext in ["vdb", "ply"] {
            let name = format!("s.{f:04}.{ext}");
            std::fs::copy(whole.join(&name), resumed.join(&name)).unwrap();
        }
    }
    run(&resumed, true);
    for f in 6..=10 {
        let name = format!("s.{f:04}.ply");
        assert!(
            std::fs::read(whole.join(&name)).unwrap()
                == std::fs::read(resumed.join(&name)).unwrap(),
            "{name} differs after a resume"
        );
    }
}

/// `activeskin particles` on `pattern` at r = voxel = 0.01 into `into/s.####.{vdb,ply}`
/// (PLY: with the velocities, measured against the frame before), plus `extra`.
fn skin_into(pattern: &Path, into: &Path, extra: &[&str]) {
    let (vdb, ply) = (into.join("s.####.vdb"), into.join("s.####.ply"));
    let mut args = particles_at_r(pattern);
    args.extend_from_slice(&["--out", vdb.to_str().unwrap()]);
    args.extend_from_slice(&["--mesh", ply.to_str().unwrap(), "-q"]);
    args.extend_from_slice(extra);
    common::assert_ok(&common::activeskin(&args));
}

/// `activeskin particles` on `pattern` at r = voxel = 0.01, before its outputs.
fn particles_at_r(pattern: &Path) -> Vec<&str> {
    let pattern = pattern.to_str().unwrap();
    let args = ["particles", "--particles", pattern, "--radius", "0.01"];
    [&args[..], &["--voxel-size", "0.01"]].concat()
}

/// How far each vertex of frame f's PLY mesh, moved by its velocity over a frame, lands
/// from frame f + 1's skin (its VDB), voxels, and how far it is left where it was: means
/// over the vertices and frames.
fn landing(dir: &Path, frames: std::ops::RangeInclusive<usize>) -> (f64, f64) {
    let (mut sum, mut still, mut n) = (0.0, 0.0, 0);
    for f in frames {
        let vertices = activeskin::io::particles::read(&dir.join(format!("s.{f:04}.ply"))).unwrap();
        let next = activeskin::vdb::Grid::read(&dir.join(format!("s.{:04}.vdb", f + 1)), None)
            .unwrap()
            .to_data()
            .unwrap();
        let next = activeskin::target::LevelSetTarget::new(&next);
        let velocities = vertices.velocities.expect("the meshes carry velocities");
        for (p, v) in vertices.positions.iter().zip(&velocities) {
            sum += f64::from((next.distance(*p + *v / FPS) / R).abs());
            still += f64::from((next.distance(*p) / R).abs());
        }
        n += velocities.len();
    }
    (sum / n as f64, still / n as f64)
}

#[test]
fn the_meshes_velocities_carry_their_vertices_onto_the_next_frame() {
    // A ball of particles moving 4 voxels a frame across, turning a quarter turn a
    // second; then the thrown ball, accelerating and spreading.
    let dir = common::scratch();
    let start = ball();
    let centre = Vec3::new(0.5, 0.5, HEIGHT + BALL);
    let (speed, turn) = (4.0 * R * FPS, std::f32::consts::FRAC_PI_2);
    for f in 1..=8 {
        let t = (f - 1) as f32 / FPS;
        let spin = glam::Quat::from_rotation_z(turn * t);
        let points: Vec<(Vec3, Vec3)> = start
            .iter()
            .map(|&p| {
                let arm = spin * (p - centre);
                let v = Vec3::X * speed + Vec3::Z.cross(arm) * turn;
                (centre + arm + Vec3::X * speed * t, v)
            })
            .collect();
        write_frame(&dir.path().join(format!("moving_{f}.ply")), &points);
    }
    write_shot(dir.path(), 10);
    let run = |input: &str, into: &Path| skin_into(&dir.path().join(input), into, &[]);
    let (moving, thrown) = (dir.path().join("moving"), dir.path().join("thrown"));
    run("moving_$F.ply", &moving);
    run("ball_$F.ply", &thrown);
    let ((moving, _), (thrown, left)) = (landing(&moving, 1..=7), landing(&thrown, 1..=9));
    println!(
        "vertices moved a frame by their velocity land from the next frame's skin: ball moving 4 voxels a frame {moving:.3} voxel; thrown ball {thrown:.3} (left in place {left:.3})"
    );
    assert!(moving <= 0.1, "{moving}");
    // The velocity of matched particles is their secant over the frame before: a ball
    // falling 20 voxels a frame gains g·Δt² = 1.7 voxels a frame, then lands and spreads
    // (measured 0.93 voxel; left in place 1.47, the next frame's band clamping at 3).
    assert!(thrown <= 0.75 * left, "{thrown} {left}");
}
