//! `activeskin skin --target PATTERN --out PATTERN [...]`: a skin dressed on a VDB target
//! sequence, and the frame loop `morph` shares.

use std::path::{Path, PathBuf};
use std::time::Instant;

use activeskin::sequence::{parse_range, FramePattern};
use activeskin::skin::AnySkin;
use activeskin::target::{FogTarget, LevelSetTarget, Target};
use activeskin::vdb::Grid;
use activeskin::volume::{GridClass, GridData};
use anyhow::{bail, Context};

use super::outputs::{OutputArgs, Outputs, PhysicsArgs};
use super::{bad_usage, pattern_arg};

#[derive(clap::Args)]
pub struct SkinArgs {
    /// Target VDB sequence: name.####.vdb, name.%04d.vdb, name.$F4.vdb or name.$F.vdb.
    #[arg(long)]
    target: String,
    /// Inclusive frame range, e.g. 1-96 (default: every frame the target pattern finds).
    #[arg(long)]
    frames: Option<String>,
    /// Keep the last target through missing frames instead of stopping.
    #[arg(long)]
    hold_missing: bool,
    /// Target grid name (default: the first float grid of each file).
    #[arg(long)]
    grid: Option<String>,
    /// Density of the surface, for fog volumes.
    #[arg(long)]
    iso: Option<f32>,
    /// Start the skin on this VDB level set instead of the first target.
    #[arg(long)]
    init: Option<PathBuf>,
    #[command(flatten)]
    physics: PhysicsArgs,
    #[command(flatten)]
    outputs: OutputArgs,
}

/// A target read from a VDB file, and its voxel size.
pub fn read_target(
    path: &Path,
    grid: Option<&str>,
    iso: Option<f32>,
) -> anyhow::Result<(Box<dyn Target>, f32)> {
    let data = Grid::read(path, grid)?.to_data()?;
    check_target(path, &data)?;
    let dx = data.transform.voxel_size() as f32;
    let target: Box<dyn Target> = match (data.class, iso) {
        (GridClass::LevelSet, _) => Box::new(LevelSetTarget::new(&data)),
        (_, Some(iso)) if iso.is_finite() => Box::new(FogTarget::new(&data, iso)),
        (_, Some(iso)) => usage!("--iso must be a number, got {iso}"),
        (_, None) => usage!(
            "{}: grid '{}' is not a level set: give --iso, the density of its surface",
            path.display(),
            data.name
        ),
    };
    Ok((target, dx))
}

/// What a target grid must be: usable (see [`check_usable`]) and not empty.
fn check_target(path: &Path, data: &GridData) -> anyhow::Result<()> {
    check_usable(path, data)?;
    if data.leaf_count() == 0 && data.tiles.is_empty() {
        bail!("{}: grid '{}' is empty", path.display(), data.name);
    }
    Ok(())
}

/// What any grid we sample or mesh must be: uniform voxels and finite values.
pub fn check_usable(path: &Path, data: &GridData) -> anyhow::Result<()> {
    let name = &data.name;
    if !data.uniform_linear {
        bail!(
            "{}: grid '{name}' has a non-uniform or non-linear transform; resample it to cubic voxels",
            path.display()
        );
    }
    let finite = data.background.is_finite()
        && data.leaf_values.iter().all(|v| v.is_finite())
        && data.tiles.iter().all(|t| t.value.is_finite());
    if !finite {
        bail!(
            "{}: grid '{name}' holds NaN or infinite values",
            path.display()
        );
    }
    Ok(())
}

/// `--frames` as every command reads it.
pub fn parse_frames(spec: &str) -> anyhow::Result<(i64, i64)> {
    parse_range(spec).ok_or_else(|| {
        bad_usage(format!(
            "--frames '{spec}': expected FIRST-LAST with FIRST <= LAST"
        ))
    })
}

/// An input sequence: its pattern, the frames found on disk (sorted), the range to run.
pub struct InputFrames {
    pub pattern: FramePattern,
    pub existing: Vec<i64>,
    pub range: (i64, i64),
}

/// Reads the sequence given as `flag` (e.g. `--target`); the range is `frames`, or every
/// frame found.
pub fn input_frames(flag: &str, spec: &str, frames: Option<&str>) -> anyhow::Result<InputFrames> {
    let pattern = pattern_arg(spec)?;
    let existing = pattern.existing_frames()?;
    let range = match frames {
        Some(frames) => parse_frames(frames)?,
        None => match (existing.first(), existing.last()) {
            (Some(&a), Some(&b)) => (a, b),
            _ => usage!("no file matches {flag} '{spec}'"),
        },
    };
    Ok(InputFrames {
        pattern,
        existing,
        range,
    })
}

/// Runs the frame loop from `first` to `last`: frame `first` is the starting skin, each
/// later frame advances 1/fps toward `target_at(frame)`.
pub fn run_frames<'t>(
    (first, last): (i64, i64),
    mut skin: AnySkin,
    fps: f64,
    outputs_args: &OutputArgs,
    target_at: impl Fn(i64) -> anyhow::Result<Box<dyn Target + 't>>,
) -> anyhow::Result<()> {
    let mut outputs = Outputs::new(outputs_args, (last - first + 1) as u64)?;
    let mut start = first;
    if outputs_args.resume {
        if let Some((frame, path)) = (first..=last)
            .rev()
            .find_map(|f| outputs.written_skin(f).map(|p| (f, p)))
        {
            let data = Grid::read(&path, Some("surface"))
                .and_then(|g| g.to_data())
                .with_context(|| "cannot resume from it; delete it to recompute that frame")?;
            skin.restore(&data)
                .with_context(|| format!("{}: cannot resume from it", path.display()))?;
            skin.set_time((frame - first) as f64 / fps);
            outputs.resume_stats(frame + 1)?;
            outputs.skip((frame - first + 1) as u64);
            start = frame + 1;
        }
    }
    for frame in start..=last {
        let started = Instant::now();
        let stats = if frame == first {
            skin.stats()
        } else {
            let target = target_at(frame)?;
            skin.advance(&*target, 1.0 / fps)
        };
        if let Some(written) = outputs.write_frame(frame, &skin, &stats, started)? {
            // Go on from exactly what was written, as --resume would.
            skin.restore(&written)?;
        }
    }
    outputs.finish();
    Ok(())
}

pub fn run(args: &SkinArgs) -> anyhow::Result<()> {
    let InputFrames {
        pattern,
        existing,
        range,
    } = input_frames("--target", &args.target, args.frames.as_deref())?;
    let target_file = |frame: i64| -> anyhow::Result<PathBuf> {
        let path = pattern.path(frame);
        if existing.binary_search(&frame).is_ok() {
            return Ok(path);
        }
        let held = existing.iter().rev().find(|&&f| f < frame);
        match held {
            Some(&f) if args.hold_missing => Ok(pattern.path(f)),
            _ if args.hold_missing => {
                bail!("{}: missing, and no earlier target to hold", path.display())
            }
            _ => bail!(
                "{}: frame {frame} of the target is missing (--hold-missing keeps the last target)",
                path.display()
            ),
        }
    };
    let target_at = |frame: i64| -> anyhow::Result<Box<dyn Target>> {
        let path = target_file(frame)?;
        Ok(read_target(&path, args.grid.as_deref(), args.iso)?.0)
    };
    let (first_target, dx) = read_target(&target_file(range.0)?, args.grid.as_deref(), args.iso)?;
    let params = args.physics.params(dx)?;
    let skin = match &args.init {
        Some(path) => {
            let (init, _) = read_target(path, None, None)?;
            AnySkin::new(&*init, params)
        }
        None => AnySkin::new(&*first_target, params),
    };
    drop(first_target);
    run_frames(range, skin, args.physics.fps, &args.outputs, target_at)
}
