//! `activeskin particles --particles PATTERN --radius R [...]`: a skin dressed on a
//! particle sequence (paper §6.1), through the same frame loop and outputs as `skin`.

use activeskin::frames::{FrameError, FrameInput, ParticleFrame, ParticleInput};
use activeskin::particles::Particles;
use activeskin::skin::AnySkin;
use std::sync::Arc;

use activeskin::flow::{Flow, FlowMap, Timing};
use activeskin::target::{fluid_iso, DensityGrid, DEFAULT_SMOOTHING_LENGTH};
use anyhow::Context;

use super::args::{OutputArgs, PhysicsArgs, VelocityTime};
use super::farm::Shot;
use super::pattern_arg;
use super::skin::{input_frames, run_frames, warm_up};

#[derive(clap::Args)]
pub struct ParticlesArgs {
    /// Particle frames: PLY (ASCII or binary; x y z, optional radius), VDB point data
    /// grids (the first in each file, as Houdini's VDB from Points writes), XYZ or CSV text.
    #[arg(long)]
    particles: String,
    /// Particle radius: half the rest spacing of the simulation's particles. Particles
    /// with their own radius (PLY `radius`/`pscale`, VDB `pscale`) use theirs, unless
    /// --ignore-radii. Also sets the default voxel size, radius/2.
    #[arg(long)]
    radius: f32,
    /// Half the kernel's support, in particle radii: the kernel reaches 2 × this × radius
    /// (splashsurf's convention). Larger smooths more and costs more.
    #[arg(long, default_value_t = DEFAULT_SMOOTHING_LENGTH)]
    smoothing_length: f32,
    /// Use --radius for every particle, whatever radii the files hold.
    #[arg(long)]
    ignore_radii: bool,
    /// Density of the surface, in kernel sums (W = (1 − q²)³) [default: the density at
    /// the boundary of a fluid at rest, particles 2 radii apart, about 32π l³/315 for a
    /// smoothing length l].
    #[arg(long)]
    iso: Option<f32>,
    /// Also write each frame's density as a VDB fog volume (grid `density`), same patterns.
    #[arg(long)]
    density_out: Option<String>,
    /// Inclusive frame range (default: every frame the pattern finds).
    #[arg(long)]
    frames: Option<String>,
    /// Ignore the particles' motion — their displacements from frame to frame (matched by
    /// id or order) and their velocities (PLY vx vy vz): follow by attraction alone.
    #[arg(long)]
    no_velocity: bool,
    /// Multiplies the particles' velocities into world units per second (not their
    /// displacements between matched frames, which are in world units already).
    #[arg(long, default_value_t = 1.0)]
    velocity_scale: f32,
    /// Which frames' velocities carry the liquid from one frame to the next: `mid` (the
    /// mean of both: SPH, many sub-steps per frame) or `start` (the earlier frame's: FLIP
    /// particles). Particles carry no distance to measure it on, so no `auto`.
    #[arg(long, value_enum, default_value_t = VelocityTime::Mid)]
    velocity_time: VelocityTime,
    #[command(flatten)]
    physics: PhysicsArgs,
    #[command(flatten)]
    outputs: OutputArgs,
}

/// What `farm` needs to cut this run into chunks.
pub fn shot(args: &ParticlesArgs) -> anyhow::Result<Shot<'_>> {
    let input = input_frames("--particles", &args.particles, args.frames.as_deref())?;
    Ok(Shot {
        range: input.range,
        physics: &args.physics,
        outputs: &args.outputs,
        fixed: Vec::new(),
    })
}

pub fn run(args: &ParticlesArgs) -> anyhow::Result<()> {
    if !(args.radius.is_finite() && args.radius > 0.0) {
        usage!("--radius must be a positive number, got {}", args.radius);
    }
    let l = args.smoothing_length;
    if !(l.is_finite() && l > 0.0) {
        usage!("--smoothing-length must be a positive number, got {l}");
    }
    let iso = args.iso.unwrap_or_else(|| fluid_iso(l));
    if !(iso.is_finite() && iso > 0.0) {
        usage!("--iso must be a positive number, got {iso}");
    }
    let mut input = input_frames("--particles", &args.particles, args.frames.as_deref())?;
    let write_from = warm_up(&mut input, args.physics.warmup_frames()?);
    let params = args.physics.params(0.5 * args.radius)?;
    let density_out = match &args.density_out {
        Some(spec) => {
            let out = pattern_arg(spec)?;
            let folder = out.folder();
            std::fs::create_dir_all(&folder).with_context(|| {
                format!("{}: cannot create the output folder", folder.display())
            })?;
            Some(out)
        }
        None => None,
    };
    let particles = ParticleInput {
        radius: args.radius,
        ignore_radii: args.ignore_radii,
        smoothing_length: l,
        iso,
        density_out,
        dx: params.dx,
        velocity_scale: (!args.no_velocity).then_some(args.velocity_scale),
    };
    if args.velocity_time == VelocityTime::Auto {
        usage!("--velocity-time auto needs level sets to measure on: give start or mid");
    }
    let timing = args.velocity_time.or(Timing::Mid);
    if !args.velocity_scale.is_finite() {
        usage!(
            "--velocity-scale must be a number, got {}",
            args.velocity_scale
        );
    }
    let quiet_particles = ParticleInput {
        density_out: None,
        ..particles.clone()
    };
    let range = input.range;
    let duration = (1.0 / args.physics.fps) as f32;
    // The particles of the frame read last, matched with the next frame's: their motion
    // over the frame carries the skin (§7) when the simulation keeps its particles.
    let mut last: Option<(i64, Particles)> = None;
    // Each frame is read once (its density is the skin's target and, with
    // --density-out, written as a fog volume on the way); the density comes back with
    // whether it carries the frame's motion.
    let mut frame_at = |frame: i64| -> Result<(DensityGrid, bool), FrameError> {
        let path = input.pattern.path(frame);
        let exists = |f: i64| input.pattern.is_held() || input.existing.binary_search(&f).is_ok();
        if !exists(frame) {
            return Err(FrameError::Data(format!(
                "{}: frame {frame} of the particles is missing",
                path.display()
            )));
        }
        let before = match last.take() {
            Some((f, particles)) if f == frame - 1 => Some(particles),
            // After a resume, or in a chunk: read as an uninterrupted run has it.
            _ if frame > range.0 && exists(frame - 1) => {
                Some(activeskin::particles::read(&input.pattern.path(frame - 1))?)
            }
            _ => None,
        };
        // A warm-up frame writes nothing, its density neither.
        let reader = match frame < write_from {
            true => &quiet_particles,
            false => &particles,
        };
        let ParticleFrame {
            density,
            particles,
            carried,
        } = reader.frame(&path, frame, before.as_ref(), duration)?;
        last = Some((frame, particles));
        Ok((density, carried))
    };
    // The skin starts on the first frame's density, one solid: the small voids of a
    // density whose kernel barely spans the spacing would each become a skin to remove.
    let mut first = frame_at(range.0)?.0;
    first.fill_voids(particles.void_volume());
    let skin = AnySkin::new(&first, params);
    // The loop asks for the first frame once more, for its velocity.
    let mut first = Some(Arc::new(first));
    run_frames(
        range,
        write_from,
        skin,
        (args.physics.fps, timing),
        &args.outputs,
        vec![input.pattern.clone()],
        |frame| {
            let (density, carried) = match first.take() {
                Some(grid) if frame == range.0 => (grid, false),
                _ => {
                    let (density, carried) = frame_at(frame)?;
                    (Arc::new(density), carried)
                }
            };
            // Particles matched from the frame before carry the skin by their own motion;
            // particles that carry velocities only, by those (§7).
            let flow = (!carried && density.has_velocities())
                .then(|| Box::new(density.clone()) as Box<dyn Flow>);
            let map = carried.then(|| Box::new(density.clone()) as Box<dyn FlowMap>);
            Ok(FrameInput {
                target: Box::new(density),
                flow,
                carried: map,
                seed: true,
            })
        },
    )
}
