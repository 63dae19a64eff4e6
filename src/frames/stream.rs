//! Frames handed over one by one (the Python API, a solver coupled in memory) through the
//! same frame loops as the commands on files: the loop runs on a thread of its own, asking
//! for each frame in turn and handing each frame's surface back ([`SurfaceSink`]).
//! Particles go through `particles`' loop ([`ParticleStream`]); level sets and fog
//! volumes through `skin`'s and `morph`'s ([`LevelSetStream`]). Same inputs and
//! parameters, same surfaces as the commands, byte for byte.

use std::path::PathBuf;
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use glam::Vec3;

use super::outputs::check_region;
use super::ColliderSpec;
use super::{
    target_from_grid, DataError, FrameError, InputFrames, OutputSpec, Outputs, ParticleInput,
    ParticleRun, ParticleSource, Surface, SurfaceSink, TargetRead, TargetUnits, UsageError,
    VoxelVelocities,
};
use crate::flow::{GridFlow, Timing};
use crate::grid::Aabb;
use crate::mesh::Mesh;
use crate::particles::{Attribute, Particles};
use crate::sequence::FramePattern;
use crate::skin::{Physics, SkinParams, StepStats};
use crate::volume::{GridData, VectorGrid};

/// One frame's surface, owned: what the outputs were handed.
#[derive(Debug, Clone)]
pub struct FrameSurface {
    /// The frame number.
    pub frame: i64,
    /// The settled skin's mesh (world units, outward).
    pub mesh: Mesh,
    /// The surface's velocity at each vertex (world units per second), when asked for.
    pub velocities: Option<Vec<Vec3>>,
    /// The particles' attributes at each vertex.
    pub attributes: Vec<Attribute>,
    /// The frame's measures.
    pub stats: StepStats,
    /// The settled skin, as its VDB holds it.
    pub level_set: GridData,
    /// The surface's velocity at the settled skin's voxels, when asked for
    /// (`velocity_grid`): what `--out` writes beside it as grid `v`.
    pub voxel_velocities: Option<VoxelVelocities>,
}

/// How a stream is set up: what a `particles` run is given besides its files.
#[derive(Clone)]
pub struct StreamSpec {
    /// How the particles handed over become targets.
    pub particles: ParticleInput,
    /// The skin's parameters.
    pub params: SkinParams,
    /// Frames per second: a frame advances the skin 1/fps seconds.
    pub fps: f64,
    /// Hold the skin to the volume the particles stand for (the command's default).
    pub hold_volume: bool,
    /// The surface's velocity at the vertices.
    pub velocities: bool,
    /// With `velocities`, at the settled skin's voxels too ([`FrameSurface::voxel_velocities`]).
    pub velocity_grid: bool,
    /// The number of the first frame handed over.
    pub first_frame: i64,
    /// The particles of the sequence's first frame and its number, when the stream
    /// starts later: the volume they stand for is held, as the command holds it on a
    /// run of later frames (none: the first frame handed over's).
    pub reference: Option<(i64, Particles)>,
    /// The box the surfaces handed back are cut to ([`OutputSpec::region`]).
    pub region: Option<Aabb>,
    /// What the surfaces handed back meet ([`OutputSpec::collider`]).
    pub collider: Option<ColliderSpec>,
}

/// A skin advanced by frames of `T` handed over one at a time.
pub struct FrameStream<T> {
    frames: SyncSender<T>,
    surfaces: Receiver<Result<FrameSurface, FrameError>>,
    worker: Option<JoinHandle<()>>,
    /// Why the loop ended, once it has.
    ended: Option<Ended>,
}

/// The frames the loop asks for, received from the caller in order.
struct Handed {
    frames: Receiver<Particles>,
    /// The sequence's first frame, before the frames handed over.
    reference: Option<(i64, Particles)>,
}

impl ParticleSource for Handed {
    fn particles(&mut self, frame: i64) -> Result<Option<(Particles, PathBuf)>, FrameError> {
        if let Some((f, particles)) = &self.reference {
            if *f == frame {
                return Ok(Some((
                    particles.clone(),
                    PathBuf::from(format!("frame {frame}")),
                )));
            }
        }
        match self.frames.recv() {
            Ok(particles) => Ok(Some((particles, PathBuf::from(format!("frame {frame}"))))),
            // The caller is gone: the loop ends.
            Err(_) => Err(DataError::NoMoreFrames.into()),
        }
    }

    fn missing(&self, frame: i64) -> FrameError {
        DataError::NoParticlesHanded { frame }.into()
    }

    /// The caller hands the next frame once it has this one's surface.
    fn reads_ahead(&self) -> bool {
        false
    }
}

/// A particle skin advanced by particles handed over one frame at a time.
pub type ParticleStream = FrameStream<Particles>;

impl FrameStream<Particles> {
    /// Checks `spec` and starts the loop, waiting for the first frame's particles.
    pub fn start(spec: StreamSpec) -> Result<Self, FrameError> {
        spec.particles.check()?;
        super::check_fps(spec.fps)?;
        if let Some((f, _)) = &spec.reference {
            if *f >= spec.first_frame {
                return Err(UsageError::ReferenceAfterFirst {
                    reference: *f,
                    first: spec.first_frame,
                }
                .into());
            }
        }
        spec.params.check()?;
        spec.region.map(check_region).transpose()?;
        spec.collider
            .as_ref()
            .map(ColliderSpec::check)
            .transpose()?;
        FrameStream::spawn(spec.velocity_grid, move |handed, sink| {
            let source = Handed {
                frames: handed,
                reference: spec.reference.clone(),
            };
            run(spec, source, sink)
        })
    }
}

impl<T: Send + 'static> FrameStream<T> {
    /// Runs `body` on a thread of its own, handed the frames sent and a sink for their
    /// surfaces.
    fn spawn(
        velocity_grid: bool,
        body: impl FnOnce(Receiver<T>, SurfaceSink) -> Result<(), FrameError> + Send + 'static,
    ) -> Result<Self, FrameError> {
        let (frames, handed) = sync_channel::<T>(1);
        let (send_surface, surfaces) = sync_channel::<Result<FrameSurface, FrameError>>(1);
        let worker = std::thread::Builder::new()
            .name("activeskin frames".into())
            .spawn(move || {
                let errors = send_surface.clone();
                let each = Arc::new(move |s: &Surface| {
                    let _ = send_surface.send(Ok(FrameSurface {
                        frame: s.frame,
                        mesh: s.mesh.clone(),
                        velocities: s.values.velocities.map(<[Vec3]>::to_vec),
                        attributes: s.values.attributes.to_vec(),
                        stats: *s.stats,
                        level_set: s.level_set.clone(),
                        voxel_velocities: s.voxel_velocities.cloned(),
                    }));
                });
                let sink = SurfaceSink {
                    each,
                    voxel_velocities: velocity_grid,
                };
                if let Err(e) = body(handed, sink) {
                    let _ = errors.send(Err(e));
                }
            })
            .map_err(|source| DataError::LoopNotStarted { source })?;
        Ok(FrameStream {
            frames,
            surfaces,
            worker: Some(worker),
            ended: None,
        })
    }

    /// Hands over the next frame; its surface comes from [`FrameStream::wait`].
    pub fn send(&mut self, frame: T) -> Result<(), FrameError> {
        if let Some(ended) = &self.ended {
            return Err(ended.error());
        }
        self.frames.send(frame).map_err(|_| self.end())
    }

    /// The surface of the frame last handed over, waiting up to `timeout` (`Ok(None)`
    /// when it is not ready yet: a caller checks for an interrupt and waits again).
    pub fn wait(&mut self, timeout: Duration) -> Result<Option<FrameSurface>, FrameError> {
        if let Some(ended) = &self.ended {
            return Err(ended.error());
        }
        match self.surfaces.recv_timeout(timeout) {
            Ok(Ok(surface)) => Ok(Some(surface)),
            Ok(Err(e)) => {
                self.ended = Some(Ended::Skin(e.to_string()));
                Err(e)
            }
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(self.end()),
        }
    }

    /// [`FrameStream::send`], then [`FrameStream::wait`] until the surface is ready.
    pub fn advance(&mut self, frame: T) -> Result<FrameSurface, FrameError> {
        self.send(frame)?;
        loop {
            if let Some(surface) = self.wait(Duration::from_secs(3600))? {
                return Ok(surface);
            }
        }
    }

    fn end(&mut self) -> FrameError {
        self.ended = Some(Ended::Loop);
        Ended::Loop.error()
    }
}

/// How a stream ended: the frame loop gone, or the skin stopped on an error (said).
enum Ended {
    Loop,
    Skin(String),
}

impl Ended {
    /// The error each later call gives.
    fn error(&self) -> FrameError {
        match self {
            Ended::Loop => DataError::LoopStopped,
            Ended::Skin(why) => DataError::SkinStopped { why: why.clone() },
        }
        .into()
    }
}

impl<T> Drop for FrameStream<T> {
    fn drop(&mut self) {
        // Closing the frames' channel ends the loop at its next frame.
        let (closed, _) = sync_channel(0);
        self.frames = closed;
        if let Some(worker) = self.worker.take() {
            // Whatever it was computing is dropped with it.
            while self.surfaces.recv().is_ok() {}
            let _ = worker.join();
        }
    }
}

/// The loop of [`ParticleStream`]: `particles`' run on the handed frames, writing to `sink`.
fn run(spec: StreamSpec, mut source: Handed, sink: SurfaceSink) -> Result<(), FrameError> {
    let first = spec.first_frame;
    let input = InputFrames {
        pattern: FramePattern::numbered("frame ", 1, ""),
        // The reference frame, when given, is the sequence's first.
        existing: spec.reference.iter().map(|(f, _)| *f).collect(),
        // Open-ended: the loop ends when the caller hands no more frames.
        range: (first, i64::MAX),
    };
    let collider = (spec.collider.clone()).map(|c| c.for_particles(spec.particles.radius));
    let mut outputs = sink_outputs(sink, (spec.velocities, spec.region, collider), first)?;
    let run = ParticleRun {
        input: &input,
        particles: &spec.particles,
        params: spec.params,
        fps: spec.fps,
        timing: Timing::Mid,
        write_from: first,
        hold_volume: spec.hold_volume,
    };
    run.run_from(&mut source, &mut outputs, &mut |_| {})
}

/// Outputs that hand each frame's surface to `sink` (with the surface's velocity where
/// `velocities`; cut to `region` and meeting `collider` when given), from frame `first` on,
/// and write nothing.
fn sink_outputs(
    sink: SurfaceSink,
    (velocities, region, collider): (bool, Option<Aabb>, Option<ColliderSpec>),
    first: i64,
) -> Result<Outputs, FrameError> {
    let spec = OutputSpec {
        out: None,
        mesh: None,
        render: None,
        up: Default::default(),
        stats: None,
        resume: false,
        progress: None,
        stats_fields: Default::default(),
        reads: Vec::new(),
        side_outputs: Vec::new(),
        velocities,
        usd: None,
        surfaces: Some(sink),
        region,
        collider,
    };
    Outputs::new(&spec, (first, i64::MAX))
}

/// One frame of a level-set (or fog) target, as `skin` reads it from a file.
#[derive(Debug, Clone)]
pub struct LevelSetFrame {
    /// The target: a level set, or a fog volume read at [`LevelSetSpec::iso`].
    pub grid: GridData,
    /// The material's velocity then, in world units per second.
    pub velocity: Option<VectorGrid>,
    /// Names the frame in messages (its file, or "frame N").
    pub label: PathBuf,
}

/// How a [`LevelSetStream`] is set up: what `skin` (or `morph`) is given besides its
/// files.
#[derive(Debug, Clone)]
pub struct LevelSetSpec {
    /// The voxel size, when not given, is the first target's.
    pub physics: Physics,
    /// Frames per second: a frame advances the skin 1/fps seconds.
    pub fps: f64,
    /// Which frames' velocities carry the skin over an interval.
    pub timing: Timing,
    /// What turns the velocities handed over into world units per second.
    pub velocity_scale: f32,
    /// The density of a fog volume's surface.
    pub iso: Option<f32>,
    /// What the level sets' distances are in.
    pub units: TargetUnits,
    /// The surface's velocity at the vertices.
    pub velocities: bool,
    /// With `velocities`, at the settled skin's voxels too ([`FrameSurface::voxel_velocities`]).
    pub velocity_grid: bool,
    /// The number of the first frame handed over.
    pub first_frame: i64,
    /// Seed the skin where the target has material it has none near (`skin`: a
    /// simulation); `false` follows by attraction alone (`morph`).
    pub seed: bool,
    /// The shape the skin starts on (`skin --init`, `morph --from`), instead of the first
    /// frame's target.
    pub init: Option<LevelSetFrame>,
    /// The box the surfaces handed back are cut to ([`OutputSpec::region`]).
    pub region: Option<Aabb>,
    /// What the surfaces handed back meet ([`OutputSpec::collider`]).
    pub collider: Option<ColliderSpec>,
}

/// A skin advanced by level sets (or fog volumes) handed over one frame at a time.
pub type LevelSetStream = FrameStream<LevelSetFrame>;

impl FrameStream<LevelSetFrame> {
    /// Checks `spec` and starts the loop, waiting for the first frame's target.
    pub fn start(spec: LevelSetSpec) -> Result<Self, FrameError> {
        super::check_fps(spec.fps)?;
        super::usage::finite(
            crate::field::Field::VelocityScale,
            f64::from(spec.velocity_scale),
        )?;
        // Checked now, on any voxel size, so that a bad α fails here, not at frame 1.
        spec.physics
            .params(spec.physics.voxel_size.unwrap_or(1.0))
            .check()?;
        spec.region.map(check_region).transpose()?;
        spec.collider
            .as_ref()
            .map(ColliderSpec::check)
            .transpose()?;
        FrameStream::spawn(spec.velocity_grid, move |handed, sink| {
            run_level_sets(spec, handed, sink)
        })
    }
}

/// The loop of [`LevelSetStream`]: `skin`'s on the handed frames, writing to `sink`.
fn run_level_sets(
    spec: LevelSetSpec,
    handed: Receiver<LevelSetFrame>,
    sink: SurfaceSink,
) -> Result<(), FrameError> {
    let first = spec.first_frame;
    let source = HandedLevelSets {
        handed,
        first: None,
        first_number: first,
        init: spec.init.clone(),
        spec: &spec,
    };
    let run = super::LevelSetRun::start(source, first)?;
    let params = spec.physics.params(run.voxel_size());
    params.check()?;
    let looks = (spec.velocities, spec.region, spec.collider.clone());
    let mut outputs = sink_outputs(sink, looks, first)?;
    let plan = super::LevelSetPlan {
        range: (first, i64::MAX),
        write_from: first,
        fps: spec.fps,
        timing: spec.timing,
        seed: spec.seed,
    };
    run.run(params, &plan, &mut outputs)
}

/// Level sets handed over one frame at a time.
struct HandedLevelSets<'a> {
    handed: Receiver<LevelSetFrame>,
    /// The first frame, kept: the run asks for it once or twice.
    first: Option<LevelSetFrame>,
    first_number: i64,
    init: Option<LevelSetFrame>,
    spec: &'a LevelSetSpec,
}

impl HandedLevelSets<'_> {
    fn read(&self, frame: LevelSetFrame) -> Result<(TargetRead, Option<GridFlow>), FrameError> {
        let spec = self.spec;
        let flow = frame
            .velocity
            .map(|v| {
                GridFlow::new(&v, spec.velocity_scale, 1.0 / spec.fps).map_err(|source| {
                    FrameError::Velocity {
                        path: frame.label.clone(),
                        source,
                    }
                })
            })
            .transpose()?;
        let target = target_from_grid(&frame.label, frame.grid, spec.iso, spec.units)?;
        Ok((target, flow))
    }

    fn next(&self) -> Result<LevelSetFrame, FrameError> {
        self.handed
            .recv()
            .map_err(|_| DataError::NoMoreFrames.into())
    }
}

impl super::LevelSetSource for HandedLevelSets<'_> {
    fn frame(&mut self, frame: i64) -> Result<(TargetRead, Option<GridFlow>), FrameError> {
        if frame != self.first_number {
            let next = self.next()?;
            return self.read(next);
        }
        let first = match self.first.take() {
            Some(first) => first,
            None => self.next()?,
        };
        self.first = Some(first.clone());
        self.read(first)
    }

    fn init(&mut self) -> Result<Option<TargetRead>, FrameError> {
        match self.init.take() {
            Some(init) => self.read(init).map(|(target, _)| Some(target)),
            None => Ok(None),
        }
    }

    /// Not read ahead: the caller hands the next frame once it has this one's surface.
    fn reads_ahead(&self) -> bool {
        false
    }
}
