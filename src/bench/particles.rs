//! `activeskin bench --particles`: activeskin and splashsurf, the particle surfacer users
//! know, on the same clouds in one run: a real liquid in motion (`sph.rs`), then, both as
//! whole processes with the machine's threads at the same cell size (the particle
//! radius), time per frame on jittered balls of 100 k
//! and 1 M particles; on a jittered fluid at rest, each one's distance to the fluid's true
//! surface and its flicker. splashsurf runs at its usual settings (`-l 2 -c 1 -t 0.6`),
//! activeskin at its defaults.

use std::path::{Path, PathBuf};
use std::process::Command;

use activeskin::io::ply::write_ply;
use activeskin::measure::flicker::jittered;
use activeskin::mesh::{mean_distance, Mesh};

use super::timed;

use glam::{IVec3, Vec3};
use serde_json::json;

/// The splashsurf version installed when none is found.
const SPLASHSURF_VERSION: &str = "0.14.1";

/// Particles of radius `r` on a lattice of spacing 2r filling a ball of `n` particles'
/// volume around (1, 1, 1).
pub(super) fn lattice_ball(n: usize, r: f32) -> (Vec<Vec3>, f32) {
    let spacing = 2.0 * r;
    let radius = spacing * (3.0 * n as f32 / (4.0 * std::f32::consts::PI)).cbrt();
    let k = (radius / spacing).ceil() as i32;
    let points = (-k..=k)
        .flat_map(|x| (-k..=k).flat_map(move |y| (-k..=k).map(move |z| IVec3::new(x, y, z))))
        .map(|c| c.as_vec3() * spacing)
        .filter(|p| p.length() <= radius)
        .map(|p| p + Vec3::ONE)
        .collect::<Vec<_>>();
    // The fluid's true surface: the sphere of the particles' share of the lattice.
    let true_radius = spacing * (3.0 * points.len() as f32 / (4.0 * std::f32::consts::PI)).cbrt();
    (points, true_radius)
}

/// splashsurf: `given`, on the PATH, in activeskin's cache, or installed there with cargo.
pub(super) fn splashsurf(given: Option<&Path>) -> Result<PathBuf, String> {
    if let Some(path) = given {
        return Ok(path.to_path_buf());
    }
    let on_path = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("splashsurf"))
            .find(|p| p.is_file())
    });
    if let Some(path) = on_path {
        return Ok(path);
    }
    let cache = super::cache_dir(None, "splashsurf").ok_or("no HOME to cache it in")?;
    let binary = cache.join("bin/splashsurf");
    if binary.is_file() {
        return Ok(binary);
    }
    eprintln!(
        "installing splashsurf {SPLASHSURF_VERSION} into {} (cargo install, a few minutes)",
        cache.display()
    );
    let status = Command::new("cargo")
        .args([
            "install",
            "splashsurf",
            "--version",
            SPLASHSURF_VERSION,
            "--root",
        ])
        .arg(&cache)
        .status()
        .map_err(|e| format!("cannot run cargo to install it: {e}"))?;
    if status.success() && binary.is_file() {
        Ok(binary)
    } else {
        Err(format!("`cargo install splashsurf` failed ({status})"))
    }
}

/// activeskin on `dir/cloud_####.ply`, frames 1 to `frames`, meshes into
/// `dir/ours_####.obj`: wall seconds of the whole run.
fn ours(dir: &Path, frames: usize, r: f32) -> anyhow::Result<f64> {
    let radius = r.to_string();
    timed(
        Command::new(std::env::current_exe()?)
            .arg("particles")
            .arg("--particles")
            .arg(dir.join("cloud_####.ply"))
            .args(["--radius", &radius, "--voxel-size", &radius, "-q"])
            .arg("--mesh")
            .arg(dir.join("ours_####.obj"))
            .arg("--frames")
            .arg(format!("1-{frames}")),
    )
}

/// splashsurf on `dir/cloud_{}.ply`, meshes into `dir/theirs_{}.obj`: wall seconds.
fn theirs(dir: &Path, r: f32, binary: &Path) -> anyhow::Result<f64> {
    let radius = r.to_string();
    timed(
        Command::new(binary)
            .arg("reconstruct")
            .arg(dir.join("cloud_{}.ply"))
            .args(["-r", &radius, "-l", "2.0", "-c", "1.0", "-t", "0.6", "-q"])
            .args(["-n", &rayon::current_num_threads().to_string()])
            .arg("--output-dir")
            .arg(dir)
            .args(["-o", "theirs_{}.obj"]),
    )
}

/// Distance to the true sphere and flicker of one tool's meshes, in voxels.
struct Quality {
    distance: f64,
    flicker: f64,
}

fn quality(meshes: &[Mesh], centre: Vec3, radius: f32, dx: f32) -> Quality {
    let distance = meshes
        .iter()
        .map(|m| {
            m.positions
                .iter()
                .map(|p| f64::from(((*p - centre).length() - radius).abs()))
                .sum::<f64>()
                / m.positions.len().max(1) as f64
        })
        .sum::<f64>()
        / meshes.len() as f64
        / f64::from(dx);
    let flicker = meshes
        .windows(2)
        .map(|pair| mean_distance(&pair[1], &pair[0], dx))
        .sum::<f64>()
        / (meshes.len() - 1) as f64
        / f64::from(dx);
    Quality { distance, flicker }
}

fn read_meshes(
    dir: &Path,
    prefix: &str,
    frames: std::ops::RangeInclusive<usize>,
) -> anyhow::Result<Vec<Mesh>> {
    frames
        .map(|f| {
            Ok(activeskin::io::obj::read(
                &dir.join(format!("{prefix}_{f:04}.obj")),
            )?)
        })
        .collect()
}

/// Which particle races run.
pub struct Races<'a> {
    /// The races at rest (100 k and 1 M particles, the fluid at rest), after the dam break.
    pub at_rest: bool,
    /// Extra options for our run on the dam break, split at whitespace.
    pub sph_args: &'a str,
    /// The races in motion at two frame rates too ([`super::sph::race`]).
    pub frame_rates: bool,
}

pub fn run(
    given: Option<&Path>,
    which: Races,
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    let splashsurf = match splashsurf(given) {
        Ok(path) => Some(path),
        Err(why) => {
            lines.push(format!("particles: splashsurf skipped: {why}"));
            None
        }
    };
    let root = std::env::temp_dir().join(format!("activeskin-bench-{}", std::process::id()));
    let result = super::sph::race(
        &root,
        splashsurf.as_deref(),
        which.sph_args,
        which.frame_rates,
        lines,
        report,
    )
    .and_then(|()| match which.at_rest {
        true => races(&root, splashsurf.as_deref(), lines, report),
        false => Ok(()),
    });
    // The clouds and meshes are large: never left behind.
    let _ = std::fs::remove_dir_all(&root);
    result
}

fn races(
    root: &Path,
    splashsurf: Option<&Path>,
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    let r = 0.005f32;
    let mut rows = Vec::new();
    let frames = 4;
    for n in [100_000usize, 1_000_000] {
        let dir = root.join(format!("speed_{n}"));
        std::fs::create_dir_all(&dir)?;
        let (lattice, _) = lattice_ball(n, r);
        for f in 1..=frames {
            write_ply(
                &dir.join(format!("cloud_{f:04}.ply")),
                &jittered(&lattice, f as u64, 0.15 * r),
            )?;
        }
        // The first frame on its own (the skin started on it), then the whole run.
        let first = ours(&dir, 1, r)?;
        let all = ours(&dir, frames, r)?;
        let steady = (all - first) / (frames - 1) as f64;
        let theirs = splashsurf.map(|s| theirs(&dir, r, s)).transpose()?;
        let ms = |s: f64| s * 1e3;
        let per_frame = |s: f64| s / frames as f64 * 1e3;
        lines.push(format!(
            "particles, {:>9} in a ball, cell = r   ours {:.0} ms/frame (first {:.0} ms, then {:.0} ms){}",
            lattice.len(),
            per_frame(all),
            ms(first),
            ms(steady),
            match theirs {
                Some(t) => format!(
                    "   splashsurf {:.0} ms/frame   speed-up {:.2}×",
                    per_frame(t),
                    t / all
                ),
                None => String::new(),
            }
        ));
        rows.push(
            json!({"particles": lattice.len(), "ours_ms_per_frame": per_frame(all),
                         "ours_first_frame_ms": ms(first), "ours_steady_frame_ms": ms(steady),
                         "splashsurf_ms_per_frame": theirs.map(per_frame),
                         "speedup": theirs.map(|t| t / all)}),
        );
        std::fs::remove_dir_all(&dir)?;
    }
    report.insert("particles".into(), json!(rows));

    // A fluid at rest whose particles jitter every frame: the true surface is the sphere
    // holding the particles' share of the lattice; what moves from frame to frame is
    // flicker. The first two frames are left out (the skin starts there).
    let frames = 10;
    let dir = root.join("rest");
    std::fs::create_dir_all(&dir)?;
    let (lattice, true_radius) = lattice_ball(100_000, r);
    for f in 1..=frames {
        write_ply(
            &dir.join(format!("cloud_{f:04}.ply")),
            &jittered(&lattice, 100 + f as u64, 0.15 * r),
        )?;
    }
    ours(&dir, frames, r)?;
    if let Some(binary) = splashsurf {
        theirs(&dir, r, binary)?;
    }
    let ours = quality(
        &read_meshes(&dir, "ours", 3..=frames)?,
        Vec3::ONE,
        true_radius,
        r,
    );
    let theirs = match splashsurf {
        Some(_) => Some(quality(
            &read_meshes(&dir, "theirs", 3..=frames)?,
            Vec3::ONE,
            true_radius,
            r,
        )),
        None => None,
    };
    lines.push(format!(
        "particles, fluid at rest ({} jittered)   ours {:.3} voxel from the true surface, flicker {:.3} voxel/frame{}",
        lattice.len(),
        ours.distance,
        ours.flicker,
        match &theirs {
            Some(t) => format!(
                "   splashsurf {:.3} voxel, flicker {:.3}   {:.1}× less flicker",
                t.distance,
                t.flicker,
                t.flicker / ours.flicker
            ),
            None => String::new(),
        }
    ));
    report.insert(
        "particles_at_rest".into(),
        json!({"particles": lattice.len(), "ours_distance_voxels": ours.distance,
               "ours_flicker_voxels": ours.flicker,
               "splashsurf_distance_voxels": theirs.as_ref().map(|t| t.distance),
               "splashsurf_flicker_voxels": theirs.as_ref().map(|t| t.flicker),
               "flicker_ratio": theirs.as_ref().map(|t| t.flicker / ours.flicker)}),
    );
    Ok(())
}
