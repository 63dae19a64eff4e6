//! `activeskin morph --from A --to B --frames 1-96 --out PATTERN [--mesh PATTERN]`.

use std::path::{Path, PathBuf};

use activeskin::skin::{AnySkin, SkinParams, SpeedParams};
use activeskin::target::{Blobs, LevelSetTarget, Sphere, Target, Torus, Union};
use activeskin::vdb::{self, FileMetadata, Grid, GridClass, WriteOptions};
use anyhow::{bail, Context};
use glam::Vec3;

#[derive(clap::Args)]
pub struct MorphArgs {
    /// Start shape: a VDB level-set file or a built-in shape (sphere:r=0.5,
    /// torus:R=0.6,r=0.25, blobs:fig7, blobs:fig6, spheres:fig7).
    #[arg(long)]
    from: String,
    /// Target shape, same forms as --from.
    #[arg(long)]
    to: String,
    /// Inclusive frame range, e.g. 1-96.
    #[arg(long, default_value = "1-48")]
    frames: String,
    #[arg(long, default_value_t = 24.0)]
    fps: f64,
    /// Attraction rate α (1/s).
    #[arg(long, default_value_t = 2.0)]
    alpha: f32,
    /// Surface tension β (world units²/s).
    #[arg(long, default_value_t = 0.01)]
    beta: f32,
    /// Voxel size (default: the VDB's, else 1/32).
    #[arg(long)]
    voxel_size: Option<f32>,
    /// Output VDB pattern; `####` is the zero-padded frame number.
    #[arg(long)]
    out: String,
    /// Output mesh pattern (.obj or .ply).
    #[arg(long)]
    mesh: Option<String>,
}

/// A shape from the command line and the voxel size it suggests.
fn shape(spec: &str) -> anyhow::Result<(Box<dyn Target>, Option<f32>)> {
    let (kind, args) = spec.split_once(':').unwrap_or((spec, ""));
    let value = |key: &str, default: f32| -> anyhow::Result<f32> {
        for pair in args.split(',').filter(|p| !p.is_empty()) {
            let (k, v) = pair
                .split_once('=')
                .with_context(|| format!("'{spec}': expected key=value, got '{pair}'"))?;
            if k == key {
                return v
                    .parse()
                    .with_context(|| format!("'{spec}': '{v}' is not a number"));
            }
        }
        Ok(default)
    };
    let target: Box<dyn Target> = match kind {
        "sphere" => Box::new(Sphere {
            center: Vec3::ZERO,
            radius: value("r", 0.5)?,
        }),
        "torus" => Box::new(Torus {
            center: Vec3::ZERO,
            major: value("R", 0.6)?,
            minor: value("r", 0.25)?,
        }),
        "blobs" if args == "fig7" => Box::new(Blobs::fig7_points()),
        "blobs" if args == "fig6" => Box::new(Blobs::fig6_twisted_segment()),
        "spheres" if args == "fig7" => Box::new(Union::fig7_spheres()),
        _ if Path::new(spec).extension().is_some_and(|e| e == "vdb") => {
            let path = Path::new(spec);
            let grid = Grid::read(path, None)?;
            let data = grid.to_data()?;
            if data.class != GridClass::LevelSet {
                bail!("{spec}: grid '{}' is not a level set", data.name);
            }
            if !data.uniform_linear {
                bail!("{spec}: grid '{}' has a non-uniform or non-linear transform", data.name);
            }
            let dx = data.transform.voxel_size() as f32;
            return Ok((Box::new(LevelSetTarget::new(&data)), Some(dx)));
        }
        _ => bail!("'{spec}': not a .vdb file or a built-in shape (sphere:r=R, torus:R=A,r=B, blobs:fig7, blobs:fig6, spheres:fig7)"),
    };
    Ok((target, None))
}

fn frame_range(spec: &str) -> anyhow::Result<(i64, i64)> {
    let parsed = spec
        .split_once('-')
        .and_then(|(a, b)| Some((a.trim().parse().ok()?, b.trim().parse().ok()?)));
    match parsed {
        Some((a, b)) if a <= b => Ok((a, b)),
        _ => bail!("--frames '{spec}': expected FIRST-LAST with FIRST <= LAST"),
    }
}

/// `name.####.vdb` → `name.0007.vdb`; a pattern without `#` gets `.####` before its extension.
pub fn frame_path(pattern: &str, frame: i64) -> PathBuf {
    let hashes = pattern.chars().filter(|&c| c == '#').count();
    if hashes == 0 {
        let p = Path::new(pattern);
        let stem = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let ext = p
            .extension()
            .map(|e| format!(".{}", e.to_string_lossy()))
            .unwrap_or_default();
        return p.with_file_name(format!("{stem}.{frame:04}{ext}"));
    }
    let start = pattern.find('#').unwrap_or(0);
    let run = pattern[start..].chars().take_while(|&c| c == '#').count();
    let number = format!("{frame:0run$}");
    PathBuf::from(format!(
        "{}{number}{}",
        &pattern[..start],
        &pattern[start + run..]
    ))
}

pub fn run(args: &MorphArgs) -> anyhow::Result<()> {
    let (first, last) = frame_range(&args.frames)?;
    if !args.fps.is_finite() || args.fps <= 0.0 {
        bail!("--fps must be positive");
    }
    // Rejects NaN as well as negatives.
    if !args.alpha.is_finite() || args.alpha < 0.0 || !args.beta.is_finite() || args.beta < 0.0 {
        bail!("--alpha and --beta must be non-negative");
    }
    let (from, from_dx) = shape(&args.from)?;
    let (to, to_dx) = shape(&args.to)?;
    let dx = args.voxel_size.or(from_dx).or(to_dx).unwrap_or(1.0 / 32.0);
    if !dx.is_finite() || dx <= 0.0 {
        bail!("--voxel-size must be positive");
    }
    let params = SkinParams {
        dx,
        speed: SpeedParams {
            alpha: args.alpha,
            beta: args.beta,
            ..SpeedParams::default()
        },
        ..SkinParams::default()
    };
    let mut skin = AnySkin::new(&*from, params);
    for frame in first..=last {
        let stats = if frame == first {
            skin.stats()
        } else {
            skin.advance(&*to, 1.0 / args.fps)
        };
        let out = frame_path(&args.out, frame);
        let grid = Grid::from_data(&skin.to_level_set())?;
        let meta = FileMetadata {
            creator: format!("activeskin {}", env!("CARGO_PKG_VERSION")),
            has_frame: true,
            frame,
        };
        vdb::write_grids(&out, &[(&grid, WriteOptions::default())], &meta)?;
        if let Some(pattern) = &args.mesh {
            skin.mesh().write(&frame_path(pattern, frame))?;
        }
        println!(
            "frame {frame}: {} sub-steps, {} band nodes, area {:.4}, volume {:.4}, χ {}, {} component(s) → {}",
            stats.substeps,
            stats.band_nodes,
            stats.area,
            stats.volume,
            stats.euler_characteristic,
            stats.components,
            out.display()
        );
    }
    Ok(())
}
