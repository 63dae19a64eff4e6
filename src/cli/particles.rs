//! `activeskin particles --particles PATTERN --radius R [...]`: a skin dressed on a
//! particle sequence (paper §6.1), through the same frame loop and outputs as `skin`.

use activeskin::field::Field;
use activeskin::flow::Timing;
use activeskin::frames::{AttributeChoice, OutputSpec, Outputs, ParticleInput, ParticleRun};
use activeskin::target::{fluid_iso, DEFAULT_SMOOTHING_LENGTH};
use anyhow::Context;

use super::args::{OutputArgs, PhysicsArgs, Shot};
use super::pattern_arg;
use super::skin::input_frames;

#[derive(clap::Args)]
pub struct ParticlesArgs {
    /// Particle frames: PLY (ASCII or binary), legacy VTK (.vtk), VTK XML (.vtu, .vtp,
    /// .pvtu), partio BGEO (.bgeo, .bgeo.gz), VDB point data grids (the first in each
    /// file, as Houdini's VDB from Points writes), splashsurf's JSON, XYZ or CSV text.
    /// Velocities, ids and radii are read where the file has them.
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
    // The help's figures come from the library's functions.
    #[arg(long, help = iso_help())]
    iso: Option<f32>,
    /// Also write each frame's density as a VDB fog volume (grid `density`), same patterns.
    #[arg(long)]
    density_out: Option<String>,
    /// Inclusive frame range (default: every frame the pattern finds).
    #[arg(long, allow_hyphen_values = true)]
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
    #[arg(long, value_enum, default_value_t = ParticleTiming::Mid)]
    velocity_time: ParticleTiming,
    /// Let the skin's volume follow the density's iso-surface, which swells on thin
    /// sheets and spray. By default the skin is held, on every frame, to the volume the
    /// particles stand for: the skin's volume on the sequence's first frame, per particle
    /// (per radius cubed with radii of their own).
    #[arg(long)]
    free_volume: bool,
    /// A particle attribute (scalar or vector, by its name in the files: temperature,
    /// age, density, vorticity) to carry onto the mesh's vertices with the density's own
    /// kernel weights, written as PLY vertex properties (a vector as NAME_x NAME_y
    /// NAME_z); repeat for more, `all` for every one the files hold. Needs a PLY --mesh.
    #[arg(long = "attribute", value_name = "NAME|all")]
    attributes: Vec<String>,
    #[command(flatten)]
    physics: PhysicsArgs,
    #[command(flatten)]
    outputs: OutputArgs,
}

/// `particles --velocity-time`: `skin`'s choices but `auto`, which measures on level sets.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ParticleTiming {
    /// The earlier frame's velocity (FLIP particles).
    Start,
    /// The mean of both frames' (SPH solvers, many sub-steps per frame).
    Mid,
}

/// What `farm` needs to cut this run into chunks.
/// `--iso`'s help, its figures at the default smoothing length.
fn iso_help() -> String {
    let l = DEFAULT_SMOOTHING_LENGTH;
    let (iso, rest) = (fluid_iso(l), activeskin::target::rest_density(l));
    format!(
        "Density of the surface, in kernel sums (W = (1 − q²)³) [default: the density at the boundary of a fluid at rest, particles 2 radii apart: {iso:.2} at the default smoothing length {l}, {:.3} of the fluid's density, {rest:.2}]",
        iso / rest
    )
}

pub fn shot(args: &ParticlesArgs) -> anyhow::Result<Shot<'_>> {
    let input = input_frames(Field::Particles, &args.particles, args.frames.as_deref())?;
    Ok(Shot {
        range: input.range,
        physics: &args.physics,
        outputs: &args.outputs,
        fixed: Vec::new(),
    })
}

pub fn run(args: &ParticlesArgs) -> anyhow::Result<()> {
    let l = args.smoothing_length;
    let defaults = ParticleInput::with_radius(args.radius);
    let mut particles = ParticleInput {
        ignore_radii: args.ignore_radii,
        smoothing_length: l,
        iso: args.iso.unwrap_or_else(|| fluid_iso(l)),
        dx: args.physics.voxel_size.unwrap_or(defaults.dx),
        velocity_scale: (!args.no_velocity).then_some(args.velocity_scale),
        attributes: match args.attributes.as_slice() {
            [] => AttributeChoice::None,
            names if names.iter().any(|n| n == "all") => AttributeChoice::All,
            names => AttributeChoice::Named(names.to_vec()),
        },
        ..defaults
    };
    if let Err(why) = particles.check() {
        usage!("{why}");
    }
    let timing = match args.velocity_time {
        ParticleTiming::Start => Timing::Start,
        ParticleTiming::Mid => Timing::Mid,
    };
    let mut input = input_frames(Field::Particles, &args.particles, args.frames.as_deref())?;
    let write_from = input.warm_up(args.physics.warmup_frames()?);
    let params = args
        .physics
        .particle_params(particles.radius, particles.dx)?;
    if let Some(spec) = &args.density_out {
        let out = pattern_arg(spec)?;
        let folder = out.folder();
        std::fs::create_dir_all(&folder)
            .with_context(|| format!("{}: cannot create the output folder", folder.display()))?;
        particles.density_out = Some(out);
    }
    let mut spec = OutputSpec {
        reads: vec![input.pattern.clone()],
        side_outputs: particles
            .density_out
            .iter()
            .map(|p| (activeskin::field::Field::DensityOut, p.clone()))
            .collect(),
        ..args.outputs.spec()?
    };
    spec.collider = spec.collider.map(|c| c.for_particles(particles.radius));
    let mut outputs = Outputs::new(&spec, (write_from, input.range.1))?;
    if particles.attributes != AttributeChoice::None && !outputs.vertices_hold_values() {
        usage!("--attribute writes PLY vertex properties or USD primvars: give a --mesh pattern ending in .ply, or --usd");
    }
    let quiet = args.outputs.quiet;
    let run = ParticleRun {
        input: &input,
        particles: &particles,
        params,
        fps: args.physics.fps,
        timing,
        write_from,
        hold_volume: !args.free_volume,
    };
    run.run(&mut outputs, &mut |line| {
        if !quiet {
            super::note(&line);
        }
    })?;
    Ok(())
}
