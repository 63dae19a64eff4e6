//! `activeskin bench --particles`, on a real liquid in motion: a SPlisHSPlasH dam break
//! (`data/sph/bake_dam_break.py`, baked once into `~/.cache/activeskin/sph/dam_break`),
//! activeskin at its defaults against splashsurf, both whole processes on the machine's
//! threads at cell = particle radius, in one run. Per frame: time, enclosed volume
//! against the particles' N·(2r)³, the particles lying more than r outside the surface,
//! and the temporal noise — following each particle near the surface (the cache keeps
//! them in order), the second difference in time of its signed distance to the surface:
//! a surface that follows the liquid changes that offset smoothly, a flickering one does
//! not, and the motion itself (up to 47 voxels a frame here) cancels; and the flicker
//! along the motion ([`flicker`]), which a particle's own jitter does not enter. For
//! activeskin, also the mean distance to each frame's own density iso-surface (its lag).
//!
//! Then the same race on a shot whose true surface is smooth in time ([`twist`]): an
//! ellipsoid of particles gliding and twisting, each particle on its exact trajectory,
//! so that what the measures find there is each tool's own flicker, not the liquid's.

use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::process::Command;

use activeskin::flow::Flow;
use activeskin::frames::ParticleInput;
use activeskin::io::particles;
use activeskin::measure::look;
use activeskin::mesh::Mesh;
use activeskin::target::{fluid_iso, Density, LevelSetTarget, Target, DEFAULT_SMOOTHING_LENGTH};
use activeskin::vdb::Grid;
use anyhow::Context;
use glam::Vec3;
use rayon::prelude::*;
use serde_json::json;

use super::timed;

/// The file names of the shots the bench writes itself, frame numbers unpadded as
/// SPlisHSPlasH writes them.
pub(super) const STEM: &str = "frame_";

/// A particle shot to race on: `frames` files `{stem}{f}.ply` in `dir` at `fps`,
/// particles of radius `r`, named `name` in the lines and `key` in the JSON report.
pub(super) struct Shot {
    /// Its name in the lines.
    pub name: String,
    /// Its key in the JSON report.
    pub key: String,
    /// The folder of its frames.
    pub dir: PathBuf,
    /// How many frames, from 1.
    pub frames: usize,
    /// Frames a second.
    pub fps: f32,
    /// The particles' radius.
    pub r: f32,
    /// Its files' names before the frame number.
    pub stem: String,
    /// The frames of its fastest run, where bumps are measured apart from the last
    /// frames'.
    pub run: RangeInclusive<usize>,
}

impl Shot {
    /// Frame `f`'s file.
    pub fn file(&self, f: usize) -> PathBuf {
        self.dir.join(format!("{}{f}.ply", self.stem))
    }

    /// The frames' files with `token` for the frame number.
    pub fn pattern(&self, token: &str) -> PathBuf {
        self.dir.join(format!("{}{token}.ply", self.stem))
    }
}

/// A SPlisHSPlasH scene of `data/sph/bake_dam_break.py`.
struct Scene {
    /// Its `--scene`, its cache's folder and its files' names before `_{frame}.ply`.
    scene: &'static str,
    /// Its name in the lines and its key in the report at 24 fps.
    name: &'static str,
    key: &'static str,
    /// The variable naming its 24 fps cache's folder.
    variable: &'static str,
    /// The frames of its fastest run at 24 fps.
    run: RangeInclusive<usize>,
}

/// The dam break: a column collapsing, its wave running along the floor in frames
/// 8–12, climbing the far wall and sloshing back.
const DAM_BREAK: Scene = Scene {
    scene: "dam_break",
    name: "SPH dam break",
    key: "particles_sph",
    variable: "ACTIVESKIN_SPH_CACHE",
    run: 8..=12,
};

/// The double dam break: two columns in opposite corners, meeting along the diagonal
/// and throwing up a sheet that tears into droplets: the fronts run in frames 6–10.
const DOUBLE_DAM_BREAK: Scene = Scene {
    scene: "double_dam_break",
    name: "SPH double dam break",
    key: "particles_sph_double",
    variable: "ACTIVESKIN_SPH_DOUBLE_CACHE",
    run: 6..=10,
};

/// `scene`'s baked cache at `fps` (`frames` frames: 36 at 24 fps, 1.46 s), baked now
/// when missing and the bake can run; else why not. The 24 fps cache is the scene's
/// variable's folder when set, another rate's sits next to it.
fn cache(scene: &Scene, fps: f32, frames: usize) -> Result<Shot, String> {
    let mut dir = super::cache_dir(Some(scene.variable), &format!("sph/{}", scene.scene))
        .ok_or("no HOME to cache it in")?;
    let mut name = scene.name.to_string();
    let mut key = scene.key.to_string();
    let run = at_rate(&scene.run, fps / BAKE_FPS);
    if fps != BAKE_FPS {
        let suffix = format!("_{fps}fps");
        dir.as_mut_os_string().push(&suffix);
        name += &format!(" at {fps} fps");
        key += &suffix;
    }
    let done = dir.join("done");
    if !done.is_file() {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/sph/bake_dam_break.py");
        if !script.is_file() {
            return Err(format!("no cache in {} and no bake script", dir.display()));
        }
        eprintln!(
            "baking the SPlisHSPlasH {} into {} (once, a few minutes)",
            scene.scene.replace('_', " "),
            dir.display()
        );
        let out = Command::new("python3")
            .arg(&script)
            .arg(&dir)
            .args(["--fps", &fps.to_string(), "--frames", &frames.to_string()])
            .args(["--scene", scene.scene])
            .output()
            .map_err(|e| format!("cannot run python3: {e}"))?;
        if !out.status.success() || !done.is_file() {
            let why = String::from_utf8_lossy(&out.stderr);
            let last = why.lines().last().unwrap_or("failed");
            return Err(format!(
                "the bake failed ({last}): pip install pysplishsplash numpy"
            ));
        }
    }
    let meta: serde_json::Value = std::fs::read(&done)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .ok_or(format!("{}: unreadable", done.display()))?;
    let frames = meta["frames"].as_u64().ok_or("no frame count")? as usize;
    let r = meta["radius"].as_f64().ok_or("no radius")? as f32;
    // Caches baked before the rate was written are at 24 fps.
    let fps = meta["fps"].as_f64().map_or(BAKE_FPS, |f| f as f32);
    Ok(Shot {
        name,
        key,
        dir,
        frames,
        fps,
        r,
        stem: format!("{}_", scene.scene),
        run,
    })
}

/// The frames `run` (from 1) at `scale` times the frame rate: the same times.
fn at_rate(run: &RangeInclusive<usize>, scale: f32) -> RangeInclusive<usize> {
    let at = |f: usize| ((f - 1) as f32 * scale).round() as usize + 1;
    at(*run.start())..=at(*run.end())
}

/// The scenes' frame rate and frame count as baked for the race (1.46 s).
const BAKE_FPS: f32 = 24.0;
const BAKE_FRAMES: usize = 36;

/// Every `every`-th frame of `shot` from its first, as a shot of its own (hard links, or
/// copies where the file system has none, in `dir`): the same simulation at a lower rate.
fn thinned(shot: &Shot, every: usize, dir: &Path) -> anyhow::Result<Shot> {
    std::fs::create_dir_all(dir)?;
    let frames = (shot.frames - 1) / every + 1;
    for k in 1..=frames {
        let from = shot.file((k - 1) * every + 1);
        let to = dir.join(format!("{}{k}.ply", shot.stem));
        let _ = std::fs::remove_file(&to);
        if std::fs::hard_link(&from, &to).is_err() {
            std::fs::copy(&from, &to)?;
        }
    }
    Ok(Shot {
        name: format!("{}, every {every} frames", shot.name),
        key: format!("{}_thinned", shot.key),
        dir: dir.to_path_buf(),
        frames,
        fps: shot.fps / every as f32,
        r: shot.r,
        stem: shot.stem.clone(),
        run: at_rate(&shot.run, 1.0 / every as f32),
    })
}

/// One tool's meshes of the shot, frame by frame, and what they are measured as.
struct Measured {
    volume: Vec<f64>,
    outside: Vec<f64>,
    noise: Vec<f64>,
    flicker: Vec<f64>,
    /// Per frame: the flicker's part that moves the whole surface in or out at once (the
    /// median of the vertices' second differences, unsigned), and what is left with it
    /// taken away (the flicker of each place on its own).
    flicker_uniform: Vec<f64>,
    flicker_local: Vec<f64>,
    /// Per frame: particle-scale bumps (degrees, [`look::bumps`]), pieces holding liquid
    /// ([`look::pieces`]), and
    /// the median thickness of single-layer sheets in particle radii (NaN without any).
    bumps: Vec<f64>,
    pieces: Vec<f64>,
    sheets: Vec<f64>,
}

/// Signed distances to `mesh`, through OpenVDB's meshToLevelSet with a band of
/// `half_width` voxels (beyond it, ± the band).
fn signed_distance(mesh: &Mesh, dx: f32, half_width: f32) -> anyhow::Result<LevelSetTarget> {
    let grid =
        Grid::mesh_to_level_set(&mesh.positions, &mesh.triangles, f64::from(dx), half_width)?;
    Ok(LevelSetTarget::new(&grid.to_data()?))
}

fn measure(meshes: &[Mesh], clouds: &[Vec<Vec3>], r: f32, dx: f32) -> anyhow::Result<Measured> {
    let sets: Vec<LevelSetTarget> = meshes
        .par_iter()
        .map(|m| signed_distance(m, dx, 6.0))
        .collect::<anyhow::Result<_>>()?;
    // Each particle's signed distance to its frame's surface.
    let offsets: Vec<Vec<f32>> = sets
        .iter()
        .zip(clouds)
        .map(|(s, c)| c.par_iter().map(|&p| s.distance(p)).collect())
        .collect();
    let volume = meshes
        .iter()
        .zip(clouds)
        .map(|(m, c)| m.volume() / (c.len() as f64 * f64::from(2.0 * r).powi(3)))
        .collect();
    let outside = offsets
        .iter()
        .map(|e| e.iter().filter(|&&d| d > r).count() as f64 / e.len().max(1) as f64)
        .collect();
    // Followed along the material (the particles keep their order here), the surface's
    // offset from the liquid changes smoothly when the surface follows it: its second
    // difference in time is the noise, the motion itself cancels.
    let near = 3.0 * dx;
    let noise = (1..meshes.len().saturating_sub(1))
        .map(|n| {
            let (a, b, c) = (&offsets[n - 1], &offsets[n], &offsets[n + 1]);
            let (sum, count) = (0..b.len().min(a.len()).min(c.len()))
                .filter(|&i| a[i].abs() < near && b[i].abs() < near && c[i].abs() < near)
                .fold((0.0f64, 0usize), |(s, k), i| {
                    (s + f64::from(0.5 * (a[i] - 2.0 * b[i] + c[i])).abs(), k + 1)
                });
            sum / count.max(1) as f64 / f64::from(dx)
        })
        .collect();
    let flickers: Vec<Flicker> = (1..meshes.len().saturating_sub(1))
        .map(|n| {
            flicker(
                &meshes[n],
                [&sets[n - 1], &sets[n + 1]],
                &clouds[n - 1..=n + 1],
                r,
                dx,
            )
        })
        .collect();
    let bumps = meshes.par_iter().map(|m| look::bumps(m, r)).collect();
    let pieces = meshes.iter().map(|m| look::pieces(m, r) as f64).collect();
    // A single-layer sheet's particles lie on its mid-surface: twice their depth is its
    // thickness.
    let sheets = clouds
        .iter()
        .zip(&offsets)
        .map(|(cloud, offsets)| {
            let depths: Vec<f64> = look::single_layer(cloud, r)
                .iter()
                .zip(offsets)
                .filter(|(sheet, _)| **sheet)
                .map(|(_, d)| f64::from(-2.0 * d / r))
                .collect();
            // A few particles that happen to lie in a plane are no sheet.
            match depths.len() < MIN_SHEET_PARTICLES {
                true => f64::NAN,
                false => median(&depths),
            }
        })
        .collect();
    Ok(Measured {
        volume,
        outside,
        noise,
        flicker: flickers.iter().map(|f| f.all).collect(),
        flicker_uniform: flickers.iter().map(|f| f.uniform).collect(),
        flicker_local: flickers.iter().map(|f| f.local).collect(),
        bumps,
        pieces,
        sheets,
    })
}

/// One frame's flicker (voxels): the mean of its vertices' unsigned second differences,
/// the median of the signed ones unsigned (the whole surface moved in or out at once),
/// and the mean of what each differs from that median by.
#[derive(Clone, Copy, Debug, Default)]
struct Flicker {
    all: f64,
    uniform: f64,
    local: f64,
}

/// The surface's own flicker at frame n, followed along the liquid (voxels): each vertex
/// of `mesh` carried to the frames before and after by the particles' mean displacement
/// around it (Shepard, over the kernel's support), where it meets those frames' surfaces
/// (`around`); half the sum of its two signed distances there is the surface's second
/// difference in time along the motion. The motion itself, accelerations included,
/// cancels, and so does a particle's own jitter, which the particle offsets (`noise`)
/// see in full even under a surface perfectly smooth in time.
fn flicker(
    mesh: &Mesh,
    around: [&LevelSetTarget; 2],
    clouds: &[Vec<Vec3>],
    r: f32,
    dx: f32,
) -> Flicker {
    let [before, now, after] = clouds else {
        return Flicker::default();
    };
    let k = before.len().min(now.len()).min(after.len());
    let support = 2.0 * DEFAULT_SMOOTHING_LENGTH * r;
    let moved = |to: &[Vec3]| {
        let steps: Vec<Vec3> = (0..k).map(|i| to[i] - now[i]).collect();
        Density::new(now[..k].to_vec(), support, 0.0).with_velocities(&steps)
    };
    let (back, ahead) = (moved(before), moved(after));
    let signed: Vec<f64> = mesh
        .positions
        .par_iter()
        .filter(|&&x| back.density(x) > 0.0)
        .map(|&x| {
            let d = around[0].distance(x + back.velocity(x))
                + around[1].distance(x + ahead.velocity(x));
            f64::from(0.5 * d / dx)
        })
        .collect();
    let shift = median(&signed);
    let unsigned =
        |by: f64| signed.iter().map(|d| (d - by).abs()).sum::<f64>() / signed.len().max(1) as f64;
    Flicker {
        all: unsigned(0.0),
        uniform: shift.abs(),
        local: unsigned(shift),
    }
}

fn range(values: &[f64]) -> (f64, f64) {
    values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        })
}

/// The middle value (the upper one of an even count); 0 for none.
fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted.get(sorted.len() / 2).copied().unwrap_or(0.0)
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

/// The races in motion: the SPlisHSPlasH dam break (when it can be had), then the
/// twisting ellipsoid; with `frame_rates`, each again at twice the rate ([`rates`]).
pub fn race(
    root: &Path,
    splashsurf: Option<&Path>,
    extra: &str,
    frame_rates: bool,
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    for scene in [&DAM_BREAK, &DOUBLE_DAM_BREAK] {
        match cache(scene, BAKE_FPS, BAKE_FRAMES) {
            Ok(shot) => {
                race_on(&shot, root, splashsurf, extra, lines, report)?;
            }
            Err(why) => lines.push(format!("particles, {}: skipped: {why}", scene.name)),
        }
    }
    let rates_raced: &[f32] = if frame_rates { &[24.0, 48.0] } else { &[24.0] };
    let mut twists = Vec::new();
    for &fps in rates_raced {
        let shot = twist(&root.join("twist_in"), fps)?;
        twists.push(race_on(&shot, root, splashsurf, extra, lines, report)?);
        std::fs::remove_dir_all(&shot.dir)?;
    }
    super::pool::race(root, splashsurf, lines, report)?;
    let [slow, fast] = &twists[..] else {
        return Ok(());
    };
    rates(
        "smooth twist",
        "particles_twist",
        [slow, fast],
        lines,
        report,
    );
    // The 24 fps cache's simulation lands its steps on other times (its chaos, a
    // splash's details, differs): the slower shot is the faster one's every other frame.
    match cache(&DAM_BREAK, 2.0 * BAKE_FPS, 2 * BAKE_FRAMES - 1) {
        Ok(shot) => {
            let fast = race_on(&shot, root, splashsurf, extra, lines, report)?;
            let every_other = thinned(&shot, 2, &root.join("thinned_in"))?;
            let slow = race_on(&every_other, root, splashsurf, extra, lines, report)?;
            std::fs::remove_dir_all(&every_other.dir)?;
            rates(
                "SPH dam break",
                "particles_sph",
                [&slow, &fast],
                lines,
                report,
            );
        }
        Err(why) => lines.push(format!(
            "particles, SPH dam break at 48 fps: skipped: {why}"
        )),
    }
    Ok(())
}

/// splashsurf's surface post-processing as its README recommends it for a smooth
/// surface: the look artists compare with.
pub(super) const SPLASHSURF_SMOOTHING: [&str; 5] = [
    "--mesh-cleanup=on",
    "--mesh-smoothing-weights=on",
    "--mesh-smoothing-iters=25",
    "--normals=on",
    "--normals-smoothing-iters=10",
];

/// The fewest single-layer particles a frame's sheets are measured on.
const MIN_SHEET_PARTICLES: usize = 50;

/// How many frames at the end of a shot are its sloshing.
const SLOSH_FRAMES: usize = 7;

/// What a tool's surface looks like over a shot: bumps on its fastest run (`run`) and
/// on the last frames (degrees), pieces on the last frames, the median single-layer
/// sheet (radii), the worst frame's particles more than r outside, and the time.
fn look_of(m: &Measured, run: &RangeInclusive<usize>, seconds: f64) -> serde_json::Value {
    let frames = m.bumps.len();
    let wave: Vec<f64> = run
        .clone()
        .filter(|f| *f <= frames)
        .map(|f| m.bumps[f - 1])
        .collect();
    let last = frames.saturating_sub(SLOSH_FRAMES);
    let sheets: Vec<f64> = m.sheets.iter().copied().filter(|t| t.is_finite()).collect();
    json!({"bumps_wave_degrees": mean(&wave), "bumps_slosh_degrees": mean(&m.bumps[last..]),
           "pieces_slosh": mean(&m.pieces[last..]),
           "sheet_radii": (!sheets.is_empty()).then(|| median(&sheets)),
           "outside_fraction": range(&m.outside).1,
           "flicker_voxels": mean(&m.flicker), "noise_voxels": mean(&m.noise),
           "flicker_uniform_voxels": mean(&m.flicker_uniform),
           "flicker_local_voxels": mean(&m.flicker_local),
           "seconds": seconds, "bumps_degrees": m.bumps, "pieces": m.pieces})
}

/// The look of ours, splashsurf raw and splashsurf smoothed on `shot`, in one line and
/// in the report (`{key}_look`); ratios against smoothed splashsurf, the look to beat.
fn looks(
    shot: &Shot,
    [ours, raw, smoothed]: [Option<(&Measured, f64)>; 3],
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) {
    let [ours, raw, smoothed] =
        [ours, raw, smoothed].map(|t| t.map(|(m, s)| look_of(m, &shot.run, s)));
    let say = |who: &str, l: &serde_json::Value| {
        format!(
            "{who} bumps {:.2}° / {:.2}°, pieces {:.1}, sheets {}, {:.2} % > r outside, flicker {:.3} (uniform {:.3}, local {:.3}), noise {:.3}, {:.1} s",
            l["bumps_wave_degrees"].as_f64().unwrap_or(f64::NAN),
            l["bumps_slosh_degrees"].as_f64().unwrap_or(f64::NAN),
            l["pieces_slosh"].as_f64().unwrap_or(f64::NAN),
            l["sheet_radii"]
                .as_f64()
                .map_or("none".to_string(), |t| format!("{t:.2} r")),
            100.0 * l["outside_fraction"].as_f64().unwrap_or(f64::NAN),
            l["flicker_voxels"].as_f64().unwrap_or(f64::NAN),
            l["flicker_uniform_voxels"].as_f64().unwrap_or(f64::NAN),
            l["flicker_local_voxels"].as_f64().unwrap_or(f64::NAN),
            l["noise_voxels"].as_f64().unwrap_or(f64::NAN),
            l["seconds"].as_f64().unwrap_or(f64::NAN),
        )
    };
    let mut line = format!(
        "particles, {}: the look (bumps on the fastest run, frames {}–{} / the last {SLOSH_FRAMES} frames; pieces there; median single-layer sheet)",
        shot.name,
        shot.run.start(),
        shot.run.end()
    );
    for (who, l) in [
        ("ours", &ours),
        ("splashsurf", &raw),
        ("splashsurf smoothed", &smoothed),
    ] {
        if let Some(l) = l {
            line += &format!("   {}", say(who, l));
        }
    }
    let ratio = |key: &str| {
        ours.as_ref()
            .zip(smoothed.as_ref())
            .and_then(|(a, b)| Some(a[key].as_f64()? / b[key].as_f64()?))
    };
    if let (Some(w), Some(s), Some(p), Some(t)) = (
        ratio("bumps_wave_degrees"),
        ratio("bumps_slosh_degrees"),
        ratio("pieces_slosh"),
        ratio("seconds"),
    ) {
        line += &format!(
            "   against smoothed splashsurf: bumps {w:.2}× / {s:.2}×, pieces {p:.2}×, flicker {:.2}× (local {:.2}×), noise {:.2}×, time {t:.2}×",
            ratio("flicker_voxels").unwrap_or(f64::NAN),
            ratio("flicker_local_voxels").unwrap_or(f64::NAN),
            ratio("noise_voxels").unwrap_or(f64::NAN),
        );
    }
    lines.push(line);
    report.insert(
        format!("{}_look", shot.key),
        json!({"ours": ours, "splashsurf": raw, "splashsurf_smoothed": smoothed}),
    );
}

/// One tool's mean flicker and particle-offset noise over a shot (voxels).
#[derive(Clone, Copy)]
struct Means {
    flicker: f64,
    noise: f64,
}

impl Means {
    fn of(m: &Measured) -> Self {
        Means {
            flicker: mean(&m.flicker),
            noise: mean(&m.noise),
        }
    }
}

/// Each tool's means on a shot: ours, splashsurf's when it ran.
struct Raced {
    ours: Means,
    theirs: Option<Means>,
}

/// The measures of one motion at a frame rate and at twice it (`[slow, fast]`). A
/// surface's own flicker — what differs from frame to frame however close the frames —
/// is the same at both rates; what the motion adds to the measures (a liquid's surface
/// is not material where it rolls over a front or tears, and the measures follow the
/// particles) shrinks with the frame interval, by half or more. The ratio fast/slow says
/// which of the two a tool's figure is.
fn rates(
    name: &str,
    key: &str,
    [slow, fast]: [&Raced; 2],
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) {
    let pair = |a: Means, b: Means| {
        json!({"flicker_voxels": [a.flicker, b.flicker], "flicker_ratio": b.flicker / a.flicker,
               "noise_voxels": [a.noise, b.noise], "noise_ratio": b.noise / a.noise})
    };
    let says = |who: &str, a: Means, b: Means| {
        format!(
            "{who} flicker {:.3} → {:.3} (×{:.2}), noise {:.3} → {:.3} (×{:.2})",
            a.flicker,
            b.flicker,
            b.flicker / a.flicker,
            a.noise,
            b.noise,
            b.noise / a.noise
        )
    };
    let theirs = slow.theirs.zip(fast.theirs);
    lines.push(format!(
        "particles, {name} at twice the frame rate (the same motion, voxels)   {}{}",
        says("ours", slow.ours, fast.ours),
        theirs.map_or(String::new(), |(a, b)| format!(
            "   {}",
            says("splashsurf", a, b)
        ))
    ));
    report.insert(
        format!("{key}_frame_rates"),
        json!({"ours": pair(slow.ours, fast.ours),
               "splashsurf": theirs.map(|(a, b)| pair(a, b))}),
    );
}

/// A fixed jitter in ±`amount` of lattice point `ijk`'s coordinate `c`, from a hash of
/// both: the same particles on every run.
pub(super) fn lattice_jitter([i, j, k]: [i32; 3], c: u32, amount: f32) -> f32 {
    let mut h = (i as u32).wrapping_mul(73_856_093)
        ^ (j as u32).wrapping_mul(19_349_663)
        ^ (k as u32).wrapping_mul(83_492_791)
        ^ c.wrapping_mul(2_654_435_761);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h as f32 / u32::MAX as f32 - 0.5) * 2.0 * amount
}

/// An ellipsoid of particles (semi-axes 0.2, 0.14, 0.1 m; a jittered lattice of spacing
/// 2r, r = 0.005) gliding 8 voxels a 24th of a second while twisting about its vertical
/// axis (each height turning at its own rate, 1 + 15 z rad/s: a smooth motion, not a
/// rigid one), 23/24 s at `fps` (24 frames at 24 fps) with exact velocities and ids,
/// written into `dir`.
fn twist(dir: &Path, fps: f32) -> anyhow::Result<Shot> {
    let r = 0.005f32;
    let frames = (23.0 * fps / 24.0).round() as usize + 1;
    std::fs::create_dir_all(dir)?;
    let axes = Vec3::new(0.2, 0.14, 0.1);
    let n = (axes.x / (2.0 * r)).round() as i32;
    // A fixed jitter of ±0.3 r.
    let jitter = |i, j, k, c| lattice_jitter([i, j, k], c, 0.3 * r);
    let mut start = Vec::new();
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                let p = Vec3::new(i as f32, j as f32, k as f32) * (2.0 * r);
                if (p / axes).length_squared() <= 1.0 {
                    start.push(
                        p + Vec3::new(jitter(i, j, k, 0), jitter(i, j, k, 1), jitter(i, j, k, 2)),
                    );
                }
            }
        }
    }
    let glide = Vec3::new(1.0, 0.4, 0.2).normalize() * 8.0 * r * 24.0;
    for f in 1..=frames {
        let t = (f - 1) as f32 / fps;
        let (positions, velocities): (Vec<Vec3>, Vec<Vec3>) = start
            .iter()
            .map(|&p| {
                let rate = 1.0 + 15.0 * p.z;
                let turned = glam::Quat::from_rotation_z(rate * t) * p;
                let spin = Vec3::new(-turned.y, turned.x, 0.0) * rate;
                (turned + glide * t, spin + glide)
            })
            .unzip();
        let frame = activeskin::particles::Particles {
            positions,
            radii: None,
            velocities: Some(velocities),
            ids: Some((0..start.len() as i64).collect()),
            attributes: Vec::new(),
        };
        activeskin::io::ply::write_particles(&dir.join(format!("{STEM}{f}.ply")), &frame)?;
    }
    // Where it turns fastest, as the dam break's wave runs.
    let run = at_rate(&DAM_BREAK.run, fps / BAKE_FPS);
    let (name, key) = match fps == 24.0 {
        true => ("smooth twist".to_string(), "particles_twist".to_string()),
        false => (
            format!("smooth twist at {fps} fps"),
            format!("particles_twist_{fps}fps"),
        ),
    };
    Ok(Shot {
        name,
        key,
        dir: dir.to_path_buf(),
        frames,
        fps,
        r,
        stem: STEM.to_string(),
        run,
    })
}

/// Our run on `shot` at its defaults (and `extra`), meshes into `dir`: timed as
/// splashsurf is, meshes only; then again with --stats (`ours.jsonl`) for the sub-steps
/// and each frame's time (its mesh checks cost a quarter of a frame), the same meshes.
/// The first run's wall seconds.
pub(super) fn run_ours(shot: &Shot, dir: &Path, extra: &str) -> anyhow::Result<f64> {
    let input = shot.pattern("$F");
    let radius = shot.r.to_string();
    let ours = |stats: bool| {
        let mut command = Command::new(std::env::current_exe()?);
        command
            .arg("particles")
            .arg("--particles")
            .arg(&input)
            .args(["--radius", &radius, "--voxel-size", &radius, "-q"])
            .args(["--fps", &shot.fps.to_string()])
            .arg("--mesh")
            .arg(dir.join("ours_####.obj"))
            .arg("--frames")
            .arg(format!("1-{}", shot.frames));
        if stats {
            command.arg("--stats").arg(dir.join("ours.jsonl"));
        }
        command.args(extra.split_whitespace());
        timed(&mut command)
    };
    let seconds = ours(false)?;
    ours(true)?;
    Ok(seconds)
}

/// splashsurf on `shot` (raw, or with `extra`, the post-processing its README recommends
/// for a smooth surface), meshes `{prefix}_{frame}.obj` into `dir`: its wall seconds,
/// `None` without it.
pub(super) fn run_splashsurf(
    shot: &Shot,
    dir: &Path,
    splashsurf: Option<&Path>,
    extra: &[&str],
    prefix: &str,
) -> anyhow::Result<Option<f64>> {
    let (frames, radius) = (shot.frames, shot.r.to_string());
    let Some(binary) = splashsurf else {
        return Ok(None);
    };
    Ok(Some(timed(
        Command::new(binary)
            .arg("reconstruct")
            .arg(shot.pattern("{}"))
            .args(["-r", &radius, "-l", "2.0", "-c", "1.0", "-t", "0.6", "-q"])
            .args(extra)
            .args(["-n", &rayon::current_num_threads().to_string()])
            .args(["-s", "1", "-e", &frames.to_string()])
            .arg("--output-dir")
            .arg(dir)
            .args(["-o", &format!("{prefix}_{{}}.obj")]),
    )?))
}

/// The frames' lines of our run's `--stats` file.
pub(super) fn read_stats(path: &Path) -> anyhow::Result<Vec<serde_json::Value>> {
    Ok(std::fs::read_to_string(path)?
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect())
}

/// `key`'s number on each frame's line of `stats` that has one.
pub(super) fn column(stats: &[serde_json::Value], key: &str) -> Vec<f64> {
    stats.iter().filter_map(|v| v[key].as_f64()).collect()
}

/// Lag: each frame's skin against that frame's own density iso-surface, mean voxels.
fn lag(shot: &Shot, meshes: &[Mesh]) -> anyhow::Result<Vec<f64>> {
    let r = shot.r;
    let density = ParticleInput {
        radius: r,
        ignore_radii: false,
        smoothing_length: DEFAULT_SMOOTHING_LENGTH,
        iso: fluid_iso(DEFAULT_SMOOTHING_LENGTH),
        density_out: None,
        dx: r,
        velocity_scale: None,
        attributes: Default::default(),
    };
    meshes
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let target = density.target(&shot.file(k + 1), k as i64 + 1)?;
            let sum: f64 = m
                .positions
                .par_iter()
                .map(|&p| f64::from(target.distance(p).abs()))
                .sum();
            Ok(sum / m.positions.len().max(1) as f64 / f64::from(r))
        })
        .collect()
}

/// The race's line: ours (`measured`, wall seconds, lag, sub-steps) and splashsurf raw's.
fn summary_line(
    shot: &Shot,
    (particles, extra): (usize, &str),
    (ours, ours_s, lag, substeps): (&Measured, f64, &[f64], &[u64]),
    theirs: Option<(&Measured, f64)>,
) -> String {
    let frames = shot.frames;
    let per_frame = |s: f64| s / frames as f64 * 1e3;
    let (v_lo, v_hi) = range(&ours.volume);
    format!(
        "particles, {} ({} particles, {frames} frames, cell = r)   ours{} {:.0} ms/frame, volume/N(2r)³ {v_lo:.3}–{v_hi:.3}, {:.2} % of particles > r outside, noise {:.3} voxel, flicker {:.3} voxel (median {:.3}), {:.3} voxel from each frame's density, sub-steps {}–{}{}",
        shot.name,
        particles,
        match extra.trim() {
            "" => String::new(),
            given => format!(" ({given})"),
        },
        per_frame(ours_s),
        100.0 * range(&ours.outside).1,
        mean(&ours.noise),
        mean(&ours.flicker),
        median(&ours.flicker),
        mean(lag),
        substeps.iter().min().unwrap_or(&0),
        substeps.iter().max().unwrap_or(&0),
        match theirs {
            Some((t, s)) => {
                let (lo, hi) = range(&t.volume);
                format!(
                    "   splashsurf {:.0} ms/frame, volume {lo:.3}–{hi:.3}, {:.2} % outside, noise {:.3}, flicker {:.3} (median {:.3})   time ratio {:.2}, noise ratio {:.2}, flicker ratio {:.2}",
                    per_frame(s),
                    100.0 * range(&t.outside).1,
                    mean(&t.noise),
                    mean(&t.flicker),
                    median(&t.flicker),
                    ours_s / s,
                    mean(&ours.noise) / mean(&t.noise),
                    mean(&ours.flicker) / mean(&t.flicker),
                )
            }
            _ => String::new(),
        }
    )
}

/// Races activeskin at its defaults (and `extra`) against splashsurf on `shot`.
fn race_on(
    shot: &Shot,
    root: &Path,
    splashsurf: Option<&Path>,
    extra: &str,
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<Raced> {
    let (frames, r) = (shot.frames, shot.r);
    let dir = root.join("sph");
    std::fs::create_dir_all(&dir)?;
    let ours_s = run_ours(shot, &dir, extra)?;
    let theirs_s = run_splashsurf(shot, &dir, splashsurf, &[], "theirs")?;
    let smoothed_s = run_splashsurf(shot, &dir, splashsurf, &SPLASHSURF_SMOOTHING, "smoothed")?;
    let clouds: Vec<Vec<Vec3>> = (1..=frames)
        .map(|f| Ok(particles::read(&shot.file(f))?.positions))
        .collect::<anyhow::Result<_>>()?;
    let read = |name: &dyn Fn(usize) -> String| -> anyhow::Result<Vec<Mesh>> {
        (1..=frames)
            .map(|f| {
                let path = dir.join(name(f));
                activeskin::io::obj::read(&path).with_context(|| format!("{}", path.display()))
            })
            .collect()
    };
    let ours_meshes = read(&|f| format!("ours_{f:04}.obj"))?;
    let ours = measure(&ours_meshes, &clouds, r, r)?;
    let lag = lag(shot, &ours_meshes)?;
    let measured = |prefix: &str| -> anyhow::Result<Option<Measured>> {
        match splashsurf {
            Some(_) => Ok(Some(measure(
                &read(&|f| format!("{prefix}_{f}.obj"))?,
                &clouds,
                r,
                r,
            )?)),
            None => Ok(None),
        }
    };
    let (theirs, smoothed) = (measured("theirs")?, measured("smoothed")?);
    looks(
        shot,
        [
            Some((&ours, ours_s)),
            theirs.as_ref().zip(theirs_s),
            smoothed.as_ref().zip(smoothed_s),
        ],
        lines,
        report,
    );
    let stats = read_stats(&dir.join("ours.jsonl"))?;
    let substeps: Vec<u64> = column(&stats, "substeps")
        .iter()
        .map(|&s| s as u64)
        .collect();
    // Each frame's own time, as the run measured it (reading, solving, writing).
    let frame_ms = column(&stats, "milliseconds");

    let per_frame = |s: f64| s / frames as f64 * 1e3;
    lines.push(summary_line(
        shot,
        (clouds[0].len(), extra),
        (&ours, ours_s, &lag, &substeps),
        theirs.as_ref().zip(theirs_s),
    ));
    let side = |m: &Measured, seconds: f64| {
        json!({"ms_per_frame": per_frame(seconds), "volume_ratio": m.volume,
               "outside_fraction": m.outside, "noise_voxels": m.noise,
               "noise_mean_voxels": mean(&m.noise), "flicker_voxels": m.flicker,
               "flicker_mean_voxels": mean(&m.flicker),
               "flicker_uniform_voxels": m.flicker_uniform, "flicker_local_voxels": m.flicker_local})
    };
    report.insert(
        shot.key.clone(),
        json!({"particles": clouds[0].len(), "frames": frames, "fps": shot.fps, "radius": r, "ours_args": extra,
               "ours": side(&ours, ours_s), "ours_lag_voxels": lag, "ours_substeps": substeps,
               "ours_frame_ms": frame_ms,
               "splashsurf": theirs.as_ref().zip(theirs_s).map(|(t, s)| side(t, s)),
               "time_ratio": theirs_s.map(|s| ours_s / s),
               "noise_ratio": theirs.as_ref().map(|t| mean(&ours.noise) / mean(&t.noise)),
               "flicker_ratio": theirs.as_ref().map(|t| mean(&ours.flicker) / mean(&t.flicker))}),
    );
    std::fs::remove_dir_all(&dir)?;
    Ok(Raced {
        ours: Means::of(&ours),
        theirs: theirs.as_ref().map(Means::of),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use activeskin::polygonize::mesh_vdb;
    use activeskin::target::{sample, Sphere};

    /// Spheres moving 5 voxels a frame, their radius off by `wobble` voxels every other
    /// frame, with particles half a voxel inside the unwobbled surface and 2 voxels
    /// outside it.
    fn shot(wobble: f32) -> (Vec<Mesh>, Vec<Vec<Vec3>>) {
        let dx = 0.02;
        let (radius, step) = (0.3, Vec3::new(5.0 * dx, 0.0, 0.0));
        let directions: Vec<Vec3> = (0..400)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f32 + 0.5) / 400.0;
                let a = k as f32 * 2.399_963;
                let s = (1.0 - z * z).sqrt();
                Vec3::new(s * a.cos(), s * a.sin(), z)
            })
            .collect();
        (0..6)
            .map(|f| {
                let center = Vec3::splat(1.0) + step * f as f32;
                let off = if f % 2 == 1 { wobble * dx } else { 0.0 };
                let sphere = Sphere {
                    center,
                    radius: radius + off,
                };
                let mesh = mesh_vdb(sample::level_set(&sphere, dx, 3.0), |v| v);
                let mut cloud: Vec<Vec3> = directions
                    .iter()
                    .map(|d| center + *d * (radius - 0.5 * dx))
                    .collect();
                cloud.push(center + Vec3::X * (radius + 2.0 * dx));
                (mesh, cloud)
            })
            .unzip()
    }

    /// The twist's particles keep their ids and move as their velocities say: the
    /// displacement over a frame is the mean of its two ends' velocities (a turn's
    /// chord) within a hundredth of a voxel.
    #[test]
    fn the_twist_moves_its_particles_as_their_velocities_say() {
        let dir = tempfile::tempdir().unwrap();
        let shot = twist(dir.path(), 24.0).unwrap();
        let read = |f: usize| particles::read(&shot.file(f)).unwrap();
        let (a, b) = (read(12), read(13));
        assert!(a.positions.len() > 10_000);
        assert_eq!(a.ids, b.ids);
        let (va, vb) = (a.velocities.unwrap(), b.velocities.unwrap());
        let dt = 1.0 / 24.0;
        let worst = (0..a.positions.len())
            .map(|i| {
                let moved = b.positions[i] - a.positions[i];
                ((va[i] + vb[i]) * 0.5 * dt - moved).length() / shot.r
            })
            .fold(0.0f32, f32::max);
        // Measured 0.0016 voxel, a float's rounding at 0.5 m.
        assert!(worst < 0.01, "{worst} voxel");
        let mean_speed = va.iter().map(|v| v.length()).sum::<f32>() / va.len() as f32;
        assert!(mean_speed * dt / shot.r > 7.0, "{mean_speed}");
    }

    /// Twice the rate is the same motion: the twist at 48 fps, every other frame, is the
    /// twist at 24 fps, byte for byte.
    #[test]
    fn every_other_frame_at_twice_the_rate_is_the_same_shot() {
        let dir = tempfile::tempdir().unwrap();
        let slow = twist(&dir.path().join("24"), 24.0).unwrap();
        let fast = twist(&dir.path().join("48"), 48.0).unwrap();
        assert_eq!((slow.frames, fast.frames), (24, 47));
        let thin = thinned(&fast, 2, &dir.path().join("thin")).unwrap();
        assert_eq!((thin.frames, thin.fps), (24, 24.0));
        // The fastest run is at the same times at either rate.
        assert_eq!((slow.run.clone(), fast.run.clone()), (8..=12, 15..=23));
        assert_eq!(thin.run, slow.run);
        assert_eq!(at_rate(&DOUBLE_DAM_BREAK.run, 2.0), 11..=19);
        for f in 1..=24 {
            let a = std::fs::read(slow.file(f)).unwrap();
            assert_eq!(a, std::fs::read(thin.file(f)).unwrap(), "frame {f}");
        }
        // Frame 2 at 48 fps is half way to frame 2 at 24 fps.
        let read = |s: &Shot, f: usize| particles::read(&s.file(f)).unwrap().positions;
        let (a, half, b) = (read(&slow, 1), read(&fast, 2), read(&slow, 2));
        let step = |x: &[Vec3], y: &[Vec3]| (x[0] - y[0]).length();
        let ratio = step(&half, &a) / step(&b, &a);
        assert!((ratio - 0.5).abs() < 0.01, "{ratio}");
    }

    #[test]
    fn the_measures_see_volume_particles_outside_and_flicker_not_motion() {
        let dx = 0.02;
        let (meshes, clouds) = shot(0.0);
        let steady = measure(&meshes, &clouds, dx, dx).unwrap();
        // Steady motion of 5 voxels a frame is no noise, no flicker.
        assert!(mean(&steady.noise) < 0.02, "{:?}", steady.noise);
        assert!(mean(&steady.flicker) < 0.02, "{:?}", steady.flicker);
        // One particle of 401 lies 2 voxels out: more than r = 1 voxel.
        for f in &steady.outside {
            assert!((f - 1.0 / 401.0).abs() < 1e-9, "{f}");
        }
        // Volume against N·(2r)³, as the mesh encloses it.
        let expected = meshes[0].volume() / (401.0 * f64::from(2.0 * dx).powi(3));
        assert!((steady.volume[0] - expected).abs() < 1e-9);
        // A radius off by 0.4 voxel every other frame: the second difference sees 0.4.
        let (meshes, clouds) = shot(0.4);
        let wobbly = measure(&meshes, &clouds, dx, dx).unwrap();
        let noise = mean(&wobbly.noise);
        assert!((0.3..0.5).contains(&noise), "{:?}", wobbly.noise);
        let flicker = mean(&wobbly.flicker);
        assert!((0.3..0.5).contains(&flicker), "{:?}", wobbly.flicker);
        // All of it moves the whole sphere in and out: uniform, none of it local.
        let uniform = mean(&wobbly.flicker_uniform);
        assert!(
            (0.3..0.5).contains(&uniform),
            "{:?}",
            wobbly.flicker_uniform
        );
        let local = mean(&wobbly.flicker_local);
        assert!(local < 0.25 * flicker, "{:?}", wobbly.flicker_local);
        assert!(mean(&steady.flicker_uniform) < 0.02);
    }
}
