//! `activeskin skin --target PATTERN --out PATTERN [...]`: a skin dressed on a VDB target
//! sequence.

use std::path::PathBuf;

use activeskin::frames::{self, read_target, FrameError, InputFrames, Outputs};
use activeskin::sequence::parse_range;
use activeskin::skin::AnySkin;
use activeskin::target::Target;

use super::args::{OutputArgs, PhysicsArgs};
use super::bad_usage;

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

/// `--frames` as every command reads it.
pub fn parse_frames(spec: &str) -> anyhow::Result<(i64, i64)> {
    parse_range(spec).ok_or_else(|| {
        bad_usage(format!(
            "--frames '{spec}': expected FIRST-LAST with FIRST <= LAST"
        ))
    })
}

/// The sequence given as `flag`, over `--frames` or every frame found.
pub fn input_frames(flag: &str, spec: &str, frames: Option<&str>) -> anyhow::Result<InputFrames> {
    let range = frames.map(parse_frames).transpose()?;
    Ok(InputFrames::find(flag, spec, range)?)
}

/// Runs the library's frame loop with the command's outputs.
pub fn run_frames<'t>(
    range: (i64, i64),
    skin: AnySkin,
    fps: f64,
    outputs: &OutputArgs,
    target_at: impl FnMut(i64) -> Result<Box<dyn Target + 't>, FrameError>,
) -> anyhow::Result<()> {
    let mut outputs = Outputs::new(&outputs.spec()?, (range.1 - range.0 + 1) as u64)?;
    Ok(frames::run(range, skin, fps, &mut outputs, target_at)?)
}

pub fn run(args: &SkinArgs) -> anyhow::Result<()> {
    let input = input_frames("--target", &args.target, args.frames.as_deref())?;
    let range = input.range;
    let target_at = |frame: i64| -> Result<Box<dyn Target>, FrameError> {
        let path = input.file(frame, args.hold_missing)?;
        Ok(read_target(&path, args.grid.as_deref(), args.iso)?.0)
    };
    let first_file = input.file(range.0, args.hold_missing)?;
    let (first_target, dx) = read_target(&first_file, args.grid.as_deref(), args.iso)?;
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
