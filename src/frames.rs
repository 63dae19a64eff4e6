//! The frame loop as a library: each frame reads its target, advances the skin 1/fps
//! toward it (§4.7 in sub-steps), settles the skin into the state a VDB file holds, writes
//! the outputs asked for, and can resume a killed run. The commands only configure it.
//!
//! **One canonical state per frame.** A frame ends with the skin exactly as its VDB level
//! set holds it (re-distanced next to the skin, quantised to what is written), whether a
//! VDB is written or not. So the skin never depends on which outputs were asked for, and a
//! run resumed from a written frame, or a farm chunk started from one, repeats an
//! uninterrupted run bit for bit.

mod collider;
mod data;
mod inputs;
mod level_set_run;
mod level_sets;
mod outputs;
mod particle_run;
pub mod scale;
mod stream;
#[cfg(feature = "vdb")]
mod targets;
mod usage;

use std::time::Instant;

pub use collider::{ColliderFiles, ColliderSpec, DEFAULT_GAP_VOXELS, PARTICLE_GAP_RADII};
pub use data::DataError;
pub use inputs::{
    auto_warmup, AttributeChoice, AttributeSource, InputFrames, ParticleFrame, ParticleInput,
    WARMUP_AUTO_FACTOR,
};
pub use level_set_run::{LevelSetPlan, LevelSetRun, LevelSetSource};
pub use level_sets::{
    background_outside, check_transform, check_usable, dense_grid, not_finite, target_from_grid,
    TargetRead, TargetUnits,
};
#[cfg(feature = "vdb")]
pub use outputs::write_skin_vdb;
pub use outputs::{
    write_usd_frame, OutputSpec, Outputs, Progress, Report, Surface, SurfaceSink, SurfaceValues,
    UsdSpec, VoxelVelocities,
};
pub use particle_run::{ParticleRun, ParticleSource};
pub use stream::{
    FrameStream, FrameSurface, LevelSetFrame, LevelSetSpec, LevelSetStream, ParticleStream,
    StreamSpec,
};
#[cfg(feature = "vdb")]
pub use targets::{
    read_level_set_frame, read_target, read_target_in, LevelSetFiles, ScaleEstimate, VelocityInput,
    VelocitySource, VELOCITY_NAMES,
};
pub use usage::UsageError;

use rayon::prelude::*;

use crate::flow::{Flow, FlowMap, Timing};
use crate::io::image::RenderError;
use crate::io::mesh::MeshError;
use crate::io::particles::ParticleError;
use crate::sequence::PatternError;
use crate::skin::velocity::{Motion, SurfaceMotion};
use crate::skin::{AnySkin, SkinError};
use crate::target::{LevelSetTarget, Target};
#[cfg(feature = "vdb")]
use crate::vdb::{Grid, VdbError};
use crate::volume::GridData;

/// Why a run stopped. Every message is one line naming the file at fault.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[cfg(feature = "vdb")]
    #[error(transparent)]
    Vdb(#[from] VdbError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Skin(#[from] SkinError),
    #[error(transparent)]
    Particles(#[from] ParticleError),
    #[error(transparent)]
    Pattern(#[from] PatternError),
    /// An input that cannot be used, or an output that cannot be written.
    #[error(transparent)]
    Data(#[from] DataError),
    /// A velocity grid that cannot carry the skin.
    #[error("{}: {source}", path.display())]
    Velocity {
        path: std::path::PathBuf,
        #[source]
        source: crate::flow::GridFlowError,
    },
    /// A file that cannot be written.
    #[error(transparent)]
    Write(#[from] crate::io::WriteError),
    /// A request that cannot be met whatever the files hold (a command-line mistake).
    #[error(transparent)]
    Usage(#[from] UsageError),
    /// A particle density that would take more memory than the budget
    /// ([`crate::budget`], bytes), refused before allocating it.
    #[error(
        "{}: the particles' density would take {} at voxels of {voxel} (kernels of {kernel} across), over the memory budget of {}: give a larger {} (or {})",
        path.display(),
        crate::budget::size(*needed),
        crate::budget::size(*budget),
        crate::field::Field::VoxelSize,
        crate::field::Field::MaxMemory
    )]
    OverBudget {
        path: std::path::PathBuf,
        needed: u64,
        voxel: f32,
        kernel: f32,
        budget: u64,
    },
}

/// The frame rate when none is given: film's.
pub const DEFAULT_FPS: f64 = 24.0;

/// A frame rate a run can advance by: finite and positive.
pub fn check_fps(fps: f64) -> Result<(), FrameError> {
    Ok(usage::positive(crate::field::Field::Fps, fps)?)
}

/// What one frame brings: its target and, when known, the material's velocity then.
pub struct FrameInput<'t> {
    /// The surface the skin is attracted to at the frame's end.
    pub target: Box<dyn Target + 't>,
    /// The material's velocity at the frame, when known (§7).
    pub flow: Option<Box<dyn Flow + 't>>,
    /// The motion over the frame interval that ends here, as a map ([`FlowMap`]: where
    /// the material was a frame before), when the input knows it (particles matched
    /// from frame to frame): the skin is carried by it in one trace, then attracted,
    /// and `flow` is not used.
    pub carried: Option<Box<dyn FlowMap + 't>>,
    /// Seed the skin where the target has material it has none near ([`AnySkin::seed`]):
    /// for simulations (an emitter, a droplet the skin missed), not for morphs.
    pub seed: bool,
    /// The volume the input holds at this frame when it conserves one (particles of an
    /// incompressible liquid): the skin is held to it once attracted, as the frame settles
    /// ([`AnySkin::settle_holding`]).
    pub volume: Option<f64>,
    /// Particle attributes to carry onto the surface's vertices (`--attribute`).
    pub attributes: Option<AttributeSource>,
    /// Spray particles, near which the skin takes the target's surface each frame.
    pub spray: Spray,
    /// The frame's particles, which the smoothed skin keeps under it.
    pub cover: Cover,
}

pub use crate::skin::{Cover, Spray};

impl<'t> FrameInput<'t> {
    /// A target alone, followed by attraction, never seeded (a morph's end shape).
    pub fn target(target: Box<dyn Target + 't>) -> Self {
        FrameInput {
            target,
            flow: None,
            carried: None,
            seed: false,
            volume: None,
            attributes: None,
            spray: Spray::default(),
            cover: Cover::default(),
        }
    }
}

/// What the frame before an interval leaves it: the velocity then and the volume its
/// target enclosed.
struct Before<'t> {
    flow: Option<Box<dyn Flow + 't>>,
    volume: Option<f64>,
}

impl<'t> Before<'t> {
    fn of(input: FrameInput<'t>) -> Self {
        Before {
            volume: input.target.volume(),
            flow: input.flow,
        }
    }
}

/// The material's motion over the frame that ends here, as the frame's input knows it
/// (its flow map, else its velocity).
fn motion_of<'a>(input: Option<&'a FrameInput>) -> Motion<'a> {
    match input {
        Some(FrameInput {
            carried: Some(map), ..
        }) => Motion::Map(&**map),
        Some(FrameInput {
            flow: Some(flow), ..
        }) => Motion::Flow(&**flow),
        _ => Motion::Still,
    }
}

/// What the outputs write beside the settled skin's surface. Its velocity
/// ([`crate::skin::velocity`], `motion`) where `(mesh, grid)` say: at the mesh's vertices,
/// and at the active voxels of `level_set` (each at its own level, along the level set's
/// gradient there). The input's particle attributes at the mesh's vertices, where
/// `wants_attributes`.
fn surface_values(
    (shown, level_set): (&crate::mesh::Mesh, &GridData),
    input: Option<&FrameInput>,
    motion: &SurfaceMotion,
    ((mesh, grid), wants_attributes): ((bool, bool), bool),
) -> SurfaceValues {
    let mesh = mesh.then(|| motion.at(&shown.positions, &shown.normals, None));
    let grid = grid.then(|| {
        let (coords, values): (Vec<[i32; 3]>, Vec<f32>) = level_set.active_voxels().unzip();
        // Normals from the voxels' own differences: sampling the level set for them took
        // 60 % of a particle frame's time.
        let normals: Vec<glam::Vec3> = level_set
            .active_gradients()
            .into_par_iter()
            .map(|g| glam::Vec3::from(g).normalize_or_zero())
            .collect();
        let points: Vec<glam::Vec3> = coords
            .par_iter()
            .map(|ijk| {
                let x = level_set.transform.index_to_world(ijk.map(f64::from));
                glam::DVec3::from(x).as_vec3()
            })
            .collect();
        let velocities = motion.at(&points, &normals, Some(&values));
        (coords, velocities.iter().map(|v| v.to_array()).collect())
    });
    // Particle attributes where the mesh holds them.
    let attributes = match (wants_attributes, input.and_then(|i| i.attributes.as_ref())) {
        (true, Some(source)) => source.at(&shown.positions),
        _ => Vec::new(),
    };
    SurfaceValues {
        mesh,
        grid,
        attributes,
    }
}

/// Runs frames `first..=last`: frame `first` is the starting skin, each later frame
/// advances 1/`fps` seconds toward `input_at(frame)`'s target, carried by the velocities
/// of the frames at the ends of the interval as `timing` says. Frames
/// before `write_from` are a warm-up (a farm chunk converging to the sequential run) and
/// write nothing. With `outputs.resume()`, starts after the last skin VDB already written
/// from `write_from` on. With `read_ahead`, each frame's input is read while the frame
/// before settles and is written (on two cores the reading fills the gaps of the
/// settling's parallel work); the frames are the same either way.
pub fn run<'t>(
    (first, last): (i64, i64),
    write_from: i64,
    mut skin: AnySkin,
    (fps, timing): (f64, Timing),
    outputs: &mut Outputs,
    (read_ahead, mut input_at): (
        bool,
        impl FnMut(i64) -> Result<FrameInput<'t>, FrameError> + Send,
    ),
) -> Result<(), FrameError> {
    check_fps(fps)?;
    skin.limit_substeps(Some(crate::skin::MAX_SUBSTEPS));
    // The topology written is counted as each frame is written (`settle_and_write`).
    skin.count_topology(false);
    outputs.frame_camera(skin.mesh());
    outputs.set_frame_rate(fps);
    let (start, restored) = match resume(&mut skin, outputs, (first, last), write_from, fps)? {
        Some((frame, data)) => (frame + 1, Some(data)),
        None => (first, None),
    };
    // The velocity at the start of the interval being advanced, and the volume its target
    // enclosed: read again after a resume (and for the first interval), as an
    // uninterrupted run has them from the frame before — even when this frame has no
    // velocity (an empty frame of a cache whose velocity the interval still uses).
    let mut previous: Option<Before<'t>> = None;
    let writing = Writing::of(outputs, write_from);
    // The frame before's settled skin, where the surface's velocity is written: its
    // motion over the frame is measured against it.
    let mut settled_before = restored.filter(|_| writing.any_velocities());
    let smooths = skin.params().smoothing > 0.0;
    // The next frame's input, read while this one settles and is written (it does not
    // depend on the skin), while the memory budget has room for two frames' inputs: its
    // error, if any, is said once this frame is written.
    let mut next: Option<Result<FrameInput<'t>, FrameError>> = None;
    for frame in start..=last {
        let started = Instant::now();
        let duration = 1.0 / fps;
        let input = if frame == first {
            // Read only for the velocity and attributes it has (the next frame reads it
            // anyway), and for the smoothing to stay near, on every run alike.
            match writing.reads_first(frame) || smooths {
                true => Some(input_at(frame)?),
                false => None,
            }
        } else {
            Some(match next.take() {
                Some(read) => read?,
                None => input_at(frame)?,
            })
        };
        let substeps = match &input {
            Some(input) if frame != first => {
                let before = || match previous.take() {
                    Some(previous) => Ok(previous),
                    None => input_at(frame - 1).map(Before::of),
                };
                advance_frame(&mut skin, input, before, (frame, fps, timing))?
            }
            _ => 0,
        };
        // The frame before's input is of no more use: dropped before the next frame is
        // read beside this one (three frames' densities would be held at once).
        previous = None;
        let this = ThisFrame {
            frame,
            first: frame == first,
            input: input.as_ref(),
            substeps,
            duration: duration as f32,
            started,
            smooths,
        };
        let settle = |skin: &mut AnySkin, outputs: &mut Outputs| {
            settle_and_write(skin, outputs, &writing, &this, settled_before.as_ref())
        };
        let ahead = read_ahead && frame < last && crate::budget::room_for_another_frame();
        let level_set = match ahead {
            true => {
                let (settled, read) =
                    rayon::join(|| settle(&mut skin, outputs), || input_at(frame + 1));
                next = Some(read);
                settled?
            }
            false => settle(&mut skin, outputs)?,
        };
        if let Some(input) = input {
            previous = Some(Before::of(input));
        }
        if writing.any_velocities() {
            settled_before = Some(level_set);
        }
    }
    outputs.finish();
    Ok(())
}

/// Where a resumed run starts: the last frame whose skin VDB `outputs` already hold
/// (from `write_from` on), restored into `skin` and returned with its level set; `None`
/// without `outputs.resume()` or such a frame.
#[cfg_attr(not(feature = "vdb"), allow(unused_variables))]
fn resume(
    skin: &mut AnySkin,
    outputs: &mut Outputs,
    (first, last): (i64, i64),
    write_from: i64,
    fps: f64,
) -> Result<Option<(i64, GridData)>, FrameError> {
    // Without OpenVDB there is no --out to resume from (Outputs refuses it).
    #[cfg(feature = "vdb")]
    if outputs.resume() {
        if let Some((frame, path)) = (write_from.max(first)..=last)
            .rev()
            .find_map(|f| outputs.written_skin(f).map(|p| (f, p)))
        {
            let data = Grid::read(&path, Some("surface"))
                .and_then(|g| g.to_data())
                .map_err(|source| DataError::ResumeUnreadable { source })?;
            skin.restore(&data)
                .map_err(|source| DataError::ResumeIncompatible {
                    path: path.clone(),
                    source,
                })?;
            skin.set_time((frame - first) as f64 / fps);
            outputs.resume_stats(frame + 1)?;
            outputs.skip((frame - write_from.max(first) + 1) as u64);
            return Ok(Some((frame, data)));
        }
    }
    Ok(None)
}

/// Advances `skin` over one frame to `input` (not the first): carried by the input's
/// flow map, or by the velocities at the interval's ends (`before`: the frame before's,
/// asked for only then) as `timing` says, attracted, then seeded where the input asks.
/// The sub-steps taken; `Err` where the advance would take more than a run allows.
fn advance_frame<'t>(
    skin: &mut AnySkin,
    input: &FrameInput<'t>,
    before: impl FnOnce() -> Result<Before<'t>, FrameError>,
    (frame, fps, timing): (i64, f64, Timing),
) -> Result<u32, FrameError> {
    let duration = 1.0 / fps;
    let stepped = match &input.carried {
        Some(map) => {
            // The flow map carries the skin; the attraction corrects the shape.
            skin.carry(&**map, duration as f32);
            skin.advance(&*input.target, duration)
        }
        None => {
            let Before {
                flow: before,
                volume: volume_before,
            } = before()?;
            let mut mean = None;
            let flow = timing.interval(before.as_deref(), input.flow.as_deref(), &mut mean);
            match flow {
                // One trace over the frame, then the attraction.
                Some(flow) => skin.follow(&*input.target, flow, duration, volume_before),
                None => skin.advance(&*input.target, duration),
            }
        }
    };
    if let Some(stopped) = stepped.stopped {
        return Err(DataError::TooManySubsteps {
            frame,
            duration,
            fps,
            stopped,
        }
        .into());
    }
    if input.seed {
        skin.seed(&*input.target);
    }
    Ok(stepped.substeps)
}

/// What a run writes beside each frame's surface, the same on every frame.
struct Writing {
    write_from: i64,
    /// The surface's velocity at the mesh's vertices, at the level set's voxels.
    velocities: (bool, bool),
    /// The velocity renderers read for motion blur.
    render_motion: bool,
    /// Particle attributes at the mesh's vertices.
    attributes: bool,
}

impl Writing {
    fn of(outputs: &Outputs, write_from: i64) -> Self {
        let (mesh, grid, render_motion) = outputs.wants_velocities();
        Writing {
            write_from,
            velocities: (mesh, grid),
            render_motion,
            attributes: outputs.vertices_hold_values(),
        }
    }

    fn any_velocities(&self) -> bool {
        self.velocities.0 || self.velocities.1 || self.render_motion
    }

    /// Whether the first frame's input is read for what is written of it.
    fn reads_first(&self, frame: i64) -> bool {
        (self.any_velocities() || self.attributes) && frame >= self.write_from
    }
}

/// The frame being settled.
struct ThisFrame<'a, 't> {
    frame: i64,
    /// The run's first frame, which the skin starts on.
    first: bool,
    input: Option<&'a FrameInput<'t>>,
    substeps: u32,
    duration: f32,
    started: Instant,
    smooths: bool,
}

/// Ends `this` frame: the skin settled (held to the volume its input holds, smoothed near
/// its target) and, from the first frame written on, written with what `writing` asks
/// (its velocity measured against the frame before's level set `before`). The settled
/// level set.
fn settle_and_write(
    skin: &mut AnySkin,
    outputs: &mut Outputs,
    writing: &Writing,
    this: &ThisFrame,
    before: Option<&GridData>,
) -> Result<GridData, FrameError> {
    let ThisFrame { frame, input, .. } = *this;
    // The volume the frame's input holds, given back as the frame ends (not on the
    // first, which the skin starts on).
    let hold = input.filter(|_| !this.first).and_then(|i| i.volume);
    // The smoothing stays near the frame's target (read on the first frame too
    // whenever the skin smooths, whatever the outputs).
    let near = input
        .filter(|_| this.smooths)
        .map(|i| &*i.target as &dyn Target);
    let particles = input.map(|i| (&*i.target as &dyn Target, &i.spray, &i.cover));
    let level_set = skin.settle_holding(hold, near, particles);
    if frame < writing.write_from {
        return Ok(level_set);
    }
    let stats = crate::skin::StepStats {
        substeps: this.substeps,
        ..skin.stats_with(outputs.reports_topology())
    };
    let dx = skin.params().dx;
    let before = before.map(|b| (LevelSetTarget::new(b), b.background - dx));
    let motion = SurfaceMotion {
        motion: motion_of(input),
        before: before.as_ref().map(|(t, reach)| (t as &dyn Target, *reach)),
        duration: this.duration,
        dx,
    };
    // Meeting a collider, the outputs mesh the met level set; the skin is untouched.
    let met = outputs.meet_collider(frame, &level_set)?.map(|grid| {
        let background = grid.background;
        crate::polygonize::mesh_vdb(grid, |v| v / background)
    });
    let shown = met.as_ref().unwrap_or(skin.mesh());
    let surface = surface_values(
        (shown, &level_set),
        input,
        &motion,
        (writing.velocities, writing.attributes),
    );
    let motion = writing.render_motion.then_some(&motion);
    outputs.write_frame(
        frame,
        (skin, shown, &level_set),
        (&surface, motion),
        &stats,
        this.started,
    )?;
    Ok(level_set)
}
