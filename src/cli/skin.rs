//! `activeskin skin --target PATTERN --out PATTERN [...]`: a skin dressed on a VDB target
//! sequence.

use activeskin::field::Field;
use std::path::PathBuf;

use activeskin::flow::Timing;
use activeskin::frames::{
    self, FrameError, FrameInput, InputFrames, LevelSetFiles, LevelSetPlan, LevelSetRun,
    OutputSpec, Outputs, ScaleEstimate, TargetUnits, VelocityInput, VelocitySource,
};
use activeskin::sequence::{parse_range, FramePattern};
use activeskin::skin::AnySkin;

use super::args::{OutputArgs, PhysicsArgs, Shot, VelocityTime};
use super::{bad_usage, pattern_arg};

#[derive(clap::Args)]
pub struct SkinArgs {
    /// Target VDB sequence: name.####.vdb, name.%04d.vdb, name.$F4.vdb or name.$F.vdb.
    #[arg(long)]
    target: String,
    /// Inclusive frame range, e.g. 1-96 (default: every frame the target pattern finds).
    #[arg(long, allow_hyphen_values = true)]
    frames: Option<String>,
    /// Keep the last target through missing frames instead of stopping.
    #[arg(long)]
    hold_missing: bool,
    /// Target grid name, `name[1]` for a second grid of one name, or index in the file
    /// (default: `surface` or `phi`, Houdini's and Mantaflow's level sets, else the first float grid of each file).
    #[arg(long)]
    grid: Option<String>,
    /// Density of the surface, for fog volumes.
    #[arg(long)]
    iso: Option<f32>,
    /// What the level set's distances are in: `auto` measures |∇φ| across the surface and
    /// rescales (e.g. Mantaflow's `phi`, in voxels), saying so; `world` or `voxel`.
    #[arg(long, value_enum, default_value_t = Units::Auto)]
    target_units: Units,
    /// Start the skin on this VDB level set instead of the first target (its --grid when
    /// it has one of that name, e.g. another frame of the same cache; else its first
    /// float grid).
    #[arg(long)]
    init: Option<PathBuf>,
    #[command(flatten)]
    velocity: VelocityArgs,
    #[command(flatten)]
    physics: PhysicsArgs,
    #[command(flatten)]
    outputs: OutputArgs,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Units {
    Auto,
    World,
    Voxel,
}

impl From<Units> for TargetUnits {
    fn from(units: Units) -> Self {
        match units {
            Units::Auto => TargetUnits::Auto,
            Units::World => TargetUnits::World,
            Units::Voxel => TargetUnits::Voxel,
        }
    }
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
pub fn input_frames(flag: Field, spec: &str, frames: Option<&str>) -> anyhow::Result<InputFrames> {
    let range = frames.map(parse_frames).transpose()?;
    Ok(InputFrames::find(flag, spec, range)?)
}

/// Runs the library's frame loop with the command's outputs, writing from `write_from`.
pub fn run_frames<'t>(
    range: (i64, i64),
    write_from: i64,
    skin: AnySkin,
    motion: (f64, Timing),
    outputs: &OutputArgs,
    reads: Vec<FramePattern>,
    input_at: impl FnMut(i64) -> Result<FrameInput<'t>, FrameError> + Send,
) -> anyhow::Result<()> {
    let spec = OutputSpec {
        reads,
        ..outputs.spec()?
    };
    let mut outputs = Outputs::new(&spec, (write_from, range.1))?;
    Ok(frames::run(
        range,
        write_from,
        skin,
        motion,
        &mut outputs,
        (true, input_at),
    )?)
}

/// The velocity options of `skin`.
#[derive(clap::Args)]
pub struct VelocityArgs {
    /// Velocity grid (vec3) in the target's files [default: `vel`, `v` or `velocity`
    /// when present, with a note].
    #[arg(long, conflicts_with = "no_velocity")]
    velocity: Option<String>,
    /// Follow the target by attraction alone, even when its files hold a velocity.
    #[arg(long)]
    no_velocity: bool,
    /// Velocity files of their own (same patterns as --target), when not in the target's.
    #[arg(long)]
    velocity_file: Option<String>,
    /// Turns the velocities into world units per second: a number, or `auto` to measure
    /// it from the surface's own motion between the first frames (warns and leaves the
    /// velocity out when it does not explain that motion).
    #[arg(long, default_value = "auto")]
    velocity_scale: String,
    /// Which frames' velocities carry the liquid from one frame to the next: `start` (the
    /// earlier frame's: Houdini FLIP, Mantaflow), `mid` (the mean of both: SPH), or `auto`,
    /// measured with an `auto` scale (the timing that gives every frame pair the same
    /// scale; `start` when the scale is given).
    #[arg(long, value_enum, default_value_t = VelocityTime::Auto)]
    velocity_time: VelocityTime,
}

impl VelocityArgs {
    /// The velocity input, and whether its scale is to be measured.
    fn input(&self) -> anyhow::Result<(VelocityInput, bool)> {
        let auto = self.velocity_scale.eq_ignore_ascii_case("auto");
        let scale = if auto {
            1.0
        } else {
            match self.velocity_scale.parse::<f32>() {
                Ok(k) if k.is_finite() => k,
                _ => usage!(
                    "--velocity-scale must be a number or auto, got '{}'",
                    self.velocity_scale
                ),
            }
        };
        let source = match (&self.velocity, self.no_velocity) {
            (_, true) => VelocitySource::Off,
            (Some(name), false) => VelocitySource::Named(name.clone()),
            (None, false) => VelocitySource::Auto,
        };
        let files = self.velocity_file.as_deref().map(pattern_arg).transpose()?;
        let input = VelocityInput {
            source,
            files,
            scale,
        };
        Ok((input, auto))
    }
}

/// Settles `--velocity-scale auto` ([`VelocityInput::settle_scale`]), saying how in one
/// line unless quiet. Returns the estimate for the stats.
fn settle_scale(
    velocity: &mut VelocityInput,
    input: &InputFrames,
    args: &SkinArgs,
) -> anyhow::Result<Option<ScaleEstimate>> {
    let timing = match args.velocity.velocity_time {
        VelocityTime::Auto => None,
        given => Some(given.or(Timing::Start)),
    };
    let target = (args.grid.as_deref(), args.target_units.into());
    let settled = velocity.settle_scale(input, target, args.physics.fps, timing)?;
    Ok(settled.map(|(estimate, note)| {
        if !args.outputs.quiet {
            super::note(&note);
        }
        estimate
    }))
}

/// What `farm` needs to cut this run into chunks: the shot's frames, and the options that
/// make every chunk read the shot alike (the velocity scale measured once, on the shot's
/// first frames, not on each chunk's).
pub fn shot(args: &SkinArgs) -> anyhow::Result<Shot<'_>> {
    let input = input_frames(Field::Target, &args.target, args.frames.as_deref())?;
    let (mut velocity, auto_scale) = args.velocity.input()?;
    let mut fixed = Vec::new();
    let estimate = if auto_scale {
        settle_scale(&mut velocity, &input, args)?
    } else {
        None
    };
    let timing = velocity_timing(args, estimate.as_ref());
    if estimate.is_some() {
        fixed = match velocity.source {
            VelocitySource::Off => vec!["--no-velocity".into()],
            _ => vec!["--velocity-scale".into(), velocity.scale.to_string()],
        };
        if args.velocity.velocity_time == VelocityTime::Auto {
            fixed.extend(["--velocity-time".into(), timing.name().into()]);
        }
    }
    Ok(Shot {
        range: input.range,
        physics: &args.physics,
        outputs: &args.outputs,
        fixed,
    })
}

/// The timing given, or measured with the scale, or [`Timing::Start`].
fn velocity_timing(args: &SkinArgs, estimate: Option<&ScaleEstimate>) -> Timing {
    args.velocity
        .velocity_time
        .or(estimate.map_or(Timing::Start, |e| e.timing))
}

pub fn run(args: &SkinArgs) -> anyhow::Result<()> {
    let mut input = input_frames(Field::Target, &args.target, args.frames.as_deref())?;
    let write_from = input.warm_up(args.physics.warmup_frames()?);
    let range = input.range;
    let (mut velocity, auto_scale) = args.velocity.input()?;
    let estimate = if auto_scale {
        settle_scale(&mut velocity, &input, args)?
    } else {
        None
    };
    let quiet = args.outputs.quiet;
    let files = LevelSetFiles {
        input: &input,
        grid: args.grid.as_deref(),
        iso: args.iso,
        units: args.target_units.into(),
        hold_missing: args.hold_missing,
        velocity: &velocity,
        fps: args.physics.fps,
        init: args.init.as_deref(),
        note: Box::new(|line: String| {
            if !quiet {
                super::note(&line);
            }
        }),
        noted: (false, false),
    };
    // Before the first frame's velocity is extended over a frame of 1/fps seconds.
    frames::check_fps(args.physics.fps)?;
    let run = LevelSetRun::start(files, range.0)?;
    let params = args.physics.params(run.voxel_size())?;
    let mut spec = args.outputs.spec()?;
    spec.reads = std::iter::once(input.pattern.clone())
        .chain(velocity.files.clone())
        .chain(
            args.init
                .iter()
                .map(|p| FramePattern::held(&p.to_string_lossy())),
        )
        .collect();
    if let Some(estimate) = &estimate {
        spec.stats_fields
            .insert("velocity_scale".into(), estimate.to_json());
    }
    let mut outputs = Outputs::new(&spec, (write_from, range.1))?;
    let plan = LevelSetPlan {
        range,
        write_from,
        fps: args.physics.fps,
        timing: velocity_timing(args, estimate.as_ref()),
        seed: true,
    };
    Ok(run.run(params, &plan, &mut outputs)?)
}
