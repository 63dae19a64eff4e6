//! `activeskin bench --formats`: reading one frame of 1 M particles (positions,
//! velocities, ids) in every particle format, each file written by the tool that writes
//! it in practice (`data/formats/write_frames.py`: VTK's own writers, partio's BGEO
//! layout, numpy), once, into `~/.cache/activeskin/formats`. Each read is timed as the
//! frame loop reads it (`io::particles::read`, best of three) against our PLY reader, and
//! checked to give the PLY's particles.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use activeskin::io::particles::read;
use anyhow::{bail, Context};
use serde_json::json;

/// The files timed, by what writes them.
const FILES: &[(&str, &str)] = &[
    ("frame.ply", "PLY, binary (ours, Houdini, numpy)"),
    ("frame.vtk", "legacy VTK, binary (VTK's writer)"),
    ("frame_raw.vtu", "VTU, appended raw (ParaView)"),
    ("frame_zlib.vtu", "VTU, appended zlib (ParaView's default)"),
    (
        "frame_base64_zlib.vtu",
        "VTU, inline base64 zlib (ParaView)",
    ),
    ("frame.bgeo", "BGEO, gzipped (partio)"),
    ("frame.csv", "CSV with a header (ParaView, DualSPHysics)"),
    ("frame.json", "JSON (splashsurf)"),
];

/// The frames, written now when missing; else why they cannot be.
fn frames() -> anyhow::Result<PathBuf> {
    let dir = super::cache_dir(Some("ACTIVESKIN_FORMATS_CACHE"), "formats")
        .context("no HOME to cache the frames in")?;
    if dir.join("done").is_file() {
        return Ok(dir);
    }
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/formats/write_frames.py");
    eprintln!(
        "writing a 1 M-particle frame in every format into {} (once)",
        dir.display()
    );
    let out = Command::new("python3")
        .arg(&script)
        .arg(&dir)
        .output()
        .context("cannot run python3")?;
    if !out.status.success() {
        let why = String::from_utf8_lossy(&out.stderr);
        bail!(
            "{} failed ({}): pip install vtk numpy",
            script.display(),
            why.lines().last().unwrap_or("no message")
        );
    }
    Ok(dir)
}

pub fn run(
    lines: &mut Vec<String>,
    report: &mut serde_json::Map<String, serde_json::Value>,
) -> anyhow::Result<()> {
    let dir = match frames() {
        Ok(dir) => dir,
        Err(e) => {
            lines.push(format!("formats: skipped, {e:#}"));
            return Ok(());
        }
    };
    let mut ply_seconds = None;
    let mut reference = None;
    let mut rows = Vec::new();
    for &(name, what) in FILES {
        let path = dir.join(name);
        let mut best = f64::INFINITY;
        let mut particles = None;
        for _ in 0..3 {
            let start = Instant::now();
            let read = read(&path)?;
            best = best.min(start.elapsed().as_secs_f64());
            particles = Some(read);
        }
        let particles = particles.expect("read three times");
        let reference = reference.get_or_insert_with(|| particles.clone());
        let same = particles.positions == reference.positions
            && (name.ends_with(".json") || particles.velocities == reference.velocities);
        if !same {
            bail!("{name}: not the PLY's particles");
        }
        let ply = *ply_seconds.get_or_insert(best);
        let bytes = std::fs::metadata(&path)?.len();
        lines.push(format!(
            "read 1 M particles, {what:<44} {:>6.0} ms  {:>5.1} MB  {:.2}× our PLY's time",
            best * 1e3,
            bytes as f64 / 1e6,
            best / ply
        ));
        rows.push(json!({"file": name, "format": what, "ms": best * 1e3, "bytes": bytes, "ratio_to_ply": best / ply}));
    }
    report.insert("formats".into(), json!(rows));
    Ok(())
}
