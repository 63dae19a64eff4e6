//! `activeskin bench --scale` (issue 53): production-sized moving liquids, ours against
//! splashsurf in one run, both whole processes on the machine's threads at cell = r.
//! Each shot is generated at N particles: a slab 1 × 1 m, 0.25 m deep, whose top is a
//! wave travelling along x (each particle rising and falling with it, its velocity
//! given), and a ball of 0.1 m thrown down at it; the particles a lattice of spacing 2r
//! (r from N) jittered ±0.3 r, with ids. Ours reads `x y z vx vy vz` and `int id`;
//! splashsurf reads its best input, float `x y z` only (an `int` property slows its PLY
//! reader down by half). Reported: the whole process's time and peak memory, each of
//! our frames' time and band nodes, and the bytes our peak holds a band node beyond the
//! particles themselves.

use std::path::Path;
use std::process::{Command, Stdio};

use activeskin::particles::Particles;
use anyhow::Context;
use glam::Vec3;
use serde_json::json;

use super::sph::{column, lattice_jitter, read_stats};

/// The frames of each shot (the first a skin's start, the others in motion), at 24 fps.
const FRAMES: usize = 3;
const FPS: f32 = 24.0;
/// The slab's depth, the wave's amplitude, length and speed, the ball's radius (m, m/s).
const DEPTH: f32 = 0.25;
const AMPLITUDE: f32 = 0.03;
const WAVELENGTH: f32 = 0.25;
const WAVE_SPEED: f32 = 0.5;
const BALL: f32 = 0.1;
/// What a particle holds in our memory as read: position, velocity, id.
const PARTICLE_BYTES: f64 = 32.0;

/// A shot's particles on `frame` (1-based) and their radius, for about `n` particles.
fn shot_frame(n: usize, frame: usize) -> (Particles, f32) {
    let volume = DEPTH + 4.0 / 3.0 * std::f32::consts::PI * BALL.powi(3);
    let spacing = (volume / n as f32).cbrt();
    let r = 0.5 * spacing;
    let t = (frame - 1) as f32 / FPS;
    let k = std::f32::consts::TAU / WAVELENGTH;
    let omega = k * WAVE_SPEED;
    let (across, deep) = (
        (1.0 / spacing).round() as i32,
        (DEPTH / spacing).round() as i32,
    );
    let mut positions = Vec::with_capacity(n + n / 16);
    let mut velocities = Vec::with_capacity(n + n / 16);
    let jittered = |i: i32, j: i32, k: i32| {
        let jitter = |c| lattice_jitter([i, j, k], c, 0.3 * r);
        (Vec3::new(i as f32, j as f32, k as f32) + 0.5) * spacing
            + Vec3::new(jitter(0), jitter(1), jitter(2))
    };
    for i in 0..across {
        for j in 0..deep {
            for l in 0..across {
                // Each particle's height scaled by the column's over the slab's depth.
                let p = jittered(i, j, l);
                let phase = k * p.x - omega * t;
                let scale = 1.0 + AMPLITUDE / DEPTH * phase.sin();
                let rate = -AMPLITUDE / DEPTH * omega * phase.cos();
                positions.push(Vec3::new(p.x, p.y * scale, p.z));
                velocities.push(Vec3::new(0.0, p.y * rate, 0.0));
            }
        }
    }
    let start = Vec3::new(0.5, DEPTH + AMPLITUDE + 2.5 * BALL, 0.5);
    let thrown = Vec3::new(0.4, -2.0, 0.0);
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let centre = start + thrown * t + 0.5 * gravity * t * t;
    let reach = (BALL / spacing) as i32 + 1;
    for i in -reach..=reach {
        for j in -reach..=reach {
            for l in -reach..=reach {
                // Lattice indices apart from the slab's, for their own jitter.
                let q = jittered(i, j + 10_000, l) - Vec3::new(0.5, 10_000.5, 0.5) * spacing;
                if q.length() <= BALL {
                    positions.push(centre + q);
                    velocities.push(thrown + gravity * t);
                }
            }
        }
    }
    let ids = Some((0..positions.len() as i64).collect());
    let particles = Particles {
        positions,
        velocities: Some(velocities),
        ids,
        radii: None,
        attributes: Vec::new(),
    };
    (particles, r)
}

/// Runs `command` (stdout dropped, stderr into `log`), failing with its stderr: its wall
/// seconds and peak resident memory (bytes).
fn measured(command: &mut Command, log: &Path) -> anyhow::Result<(f64, f64)> {
    let err = std::fs::File::create(log)?;
    let start = std::time::Instant::now();
    let child = command
        .stdout(Stdio::null())
        .stderr(err)
        .spawn()
        .with_context(|| format!("cannot run {command:?}"))?;
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: rusage is plain data, for which all zeroes is a valid value.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our own child, not waited for yet (the `Child` is never waited
    // on: dropping it neither waits nor kills); both out-pointers are valid.
    let got = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let seconds = start.elapsed().as_secs_f64();
    drop(child);
    if got != pid {
        anyhow::bail!(
            "waiting for {command:?}: {}",
            std::io::Error::last_os_error()
        );
    }
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        let why = std::fs::read_to_string(log).unwrap_or_default();
        anyhow::bail!("{command:?} failed: {}", why.trim());
    }
    // ru_maxrss is in KiB on Linux.
    Ok((seconds, usage.ru_maxrss as f64 * 1024.0))
}

/// One size raced: `millions` of particles, in `dir` (removed after).
fn race(
    millions: f64,
    dir: &Path,
    splashsurf: Option<&Path>,
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    let n = (millions * 1e6) as usize;
    std::fs::create_dir_all(dir)?;
    let (mut count, mut radius) = (0, 0.0);
    for f in 1..=FRAMES {
        let (particles, r) = shot_frame(n, f);
        activeskin::io::ply::write_particles(&dir.join(format!("ours_{f}.ply")), &particles)?;
        let bare = Particles {
            positions: particles.positions,
            ..Particles::default()
        };
        activeskin::io::ply::write_particles(&dir.join(format!("theirs_{f}.ply")), &bare)?;
        (count, radius) = (bare.positions.len(), r);
    }
    let r = radius.to_string();
    let threads = rayon::current_num_threads().to_string();
    let ours = |stats: bool| -> anyhow::Result<(f64, f64)> {
        let mut command = Command::new(std::env::current_exe()?);
        command
            .arg("particles")
            .arg("--particles")
            .arg(dir.join("ours_$F.ply"))
            .args(["--radius", &r, "--voxel-size", &r, "-q"])
            .args([
                "--fps",
                &FPS.to_string(),
                "--frames",
                &format!("1-{FRAMES}"),
            ])
            .arg("--mesh")
            .arg(dir.join("ours_mesh_####.ply"));
        if stats {
            command.arg("--stats").arg(dir.join("ours.jsonl"));
        }
        measured(&mut command, &dir.join("ours.log"))
    };
    let (ours_s, ours_peak) = ours(false)?;
    ours(true)?;
    let stats = read_stats(&dir.join("ours.jsonl"))?;
    let (frame_ms, band) = (column(&stats, "milliseconds"), column(&stats, "band_nodes"));
    let most_band = band.iter().copied().fold(0.0, f64::max);
    let per_node = (ours_peak - PARTICLE_BYTES * count as f64) / most_band.max(1.0);
    let moving = frame_ms[1..].iter().sum::<f64>() / (frame_ms.len() - 1).max(1) as f64;
    let moving_over_first = moving / frame_ms.first().copied().unwrap_or(f64::NAN);
    let theirs = match splashsurf {
        Some(binary) => Some(measured(
            Command::new(binary)
                .arg("reconstruct")
                .arg(dir.join("theirs_{}.ply"))
                .args(["-r", &r, "-l", "2.0", "-c", "1.0", "-t", "0.6", "-q"])
                .args(["-n", &threads, "-s", "1", "-e", &FRAMES.to_string()])
                .arg("--output-dir")
                .arg(dir)
                .args(["-o", "theirs_mesh_{}.ply"]),
            &dir.join("theirs.log"),
        )?),
        None => None,
    };
    let gb = |b: f64| b / 1e9;
    let mut line = format!(
        "scale, {count} moving particles, {FRAMES} frames, cell = r: ours {ours_s:.1} s, peak {:.2} GB (frames {} ms, the moving ones {moving_over_first:.1}× the first; band nodes {}; {per_node:.0} bytes a band node beyond the particles)",
        gb(ours_peak),
        frame_ms.iter().map(|m| format!("{m:.0}")).collect::<Vec<_>>().join(", "),
        band.iter().map(|b| format!("{:.2} M", b / 1e6)).collect::<Vec<_>>().join(", "),
    );
    if let Some((s, peak)) = theirs {
        line += &format!(
            "   splashsurf (float x y z) {s:.1} s, peak {:.2} GB   time {:.2}×, memory {:.2}×",
            gb(peak),
            ours_s / s,
            ours_peak / peak
        );
    }
    lines.push(line);
    report.insert(
        format!("scale_{millions}M"),
        json!({"particles": count, "frames": FRAMES, "radius": radius,
               "ours_seconds": ours_s, "ours_peak_bytes": ours_peak, "ours_frame_ms": frame_ms,
               "ours_band_nodes": band, "ours_bytes_per_band_node": per_node,
               "ours_moving_over_first": moving_over_first,
               "splashsurf_seconds": theirs.map(|t| t.0), "splashsurf_peak_bytes": theirs.map(|t| t.1),
               "time_ratio": theirs.map(|t| ours_s / t.0), "memory_ratio": theirs.map(|t| ours_peak / t.1)}),
    );
    std::fs::remove_dir_all(dir)?;
    Ok(())
}

/// The scale race at each of `millions` of particles.
pub fn run(
    splashsurf: Option<&Path>,
    millions: &[f64],
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    let splashsurf = match super::particles::splashsurf(splashsurf) {
        Ok(path) => Some(path),
        Err(why) => {
            lines.push(format!("scale: splashsurf skipped: {why}"));
            None
        }
    };
    let root = std::env::temp_dir().join(format!("activeskin-scale-{}", std::process::id()));
    let mut result = Ok(());
    for &m in millions {
        result = race(
            m,
            &root.join(format!("{m}M")),
            splashsurf.as_deref(),
            lines,
            report,
        );
        if result.is_err() {
            break;
        }
    }
    // Gigabytes of particles and meshes: never left behind.
    let _ = std::fs::remove_dir_all(&root);
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shot holds about the particles asked for, their velocities are their motion
    /// (a frame's step over the frame's time, to first order), and the ids follow them.
    #[test]
    fn a_generated_shot_moves_as_its_velocities_say() {
        let n = 20_000;
        let (a, r) = shot_frame(n, 1);
        let (b, _) = shot_frame(n, 2);
        let count = a.positions.len();
        assert!((count as f64 / n as f64 - 1.0).abs() < 0.1, "{count}");
        assert_eq!(b.positions.len(), count);
        assert_eq!(a.ids.as_ref().map(Vec::len), Some(count));
        let (va, vb) = (a.velocities.unwrap(), b.velocities.unwrap());
        let dt = 1.0 / FPS;
        let worst = (0..count)
            .map(|i| {
                let moved = b.positions[i] - a.positions[i];
                (moved - 0.5 * (va[i] + vb[i]) * dt).length()
            })
            .fold(0.0f32, f32::max);
        // The trapezoid's error over a 24th of a second: well under a radius.
        assert!(worst < 0.1 * r, "{worst} against r = {r}");
        let fastest = va.iter().map(|v| v.length()).fold(0.0f32, f32::max);
        assert!(fastest > 1.0, "the ball is thrown: {fastest} m/s");
    }
}
