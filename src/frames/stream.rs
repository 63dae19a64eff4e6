//! Particles handed over frame by frame (the Python API, a solver coupled in memory)
//! through the same frame loop as `particles` on files: the loop runs on a thread of its
//! own, asking for each frame's particles in turn ([`ParticleSource`]) and handing each
//! frame's surface back ([`SurfaceSink`]). Same particles and parameters, same
//! surfaces as the command, byte for byte.

use std::path::PathBuf;
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use glam::Vec3;

use super::{
    FrameError, InputFrames, OutputSpec, Outputs, ParticleInput, ParticleRun, ParticleSource,
    Surface, SurfaceSink,
};
use crate::flow::Timing;
use crate::mesh::Mesh;
use crate::particles::{Attribute, Particles};
use crate::sequence::FramePattern;
use crate::skin::{SkinParams, StepStats};

/// One frame's surface, owned: what the outputs were handed.
#[derive(Debug, Clone)]
pub struct FrameSurface {
    pub frame: i64,
    pub mesh: Mesh,
    /// The surface's velocity at each vertex (world units per second), when asked for.
    pub velocities: Option<Vec<Vec3>>,
    /// The particles' attributes at each vertex.
    pub attributes: Vec<Attribute>,
    pub stats: StepStats,
}

/// How a stream is set up: what a `particles` run is given besides its files.
#[derive(Clone)]
pub struct StreamSpec {
    pub particles: ParticleInput,
    pub params: SkinParams,
    pub fps: f64,
    /// Hold the skin to the volume the particles stand for (the command's default).
    pub hold_volume: bool,
    /// The surface's velocity at the vertices.
    pub velocities: bool,
    /// The number of the first frame handed over.
    pub first_frame: i64,
    /// The particles of the sequence's first frame and its number, when the stream
    /// starts later: the volume they stand for is held, as the command holds it on a
    /// run of later frames (none: the first frame handed over's).
    pub reference: Option<(i64, Particles)>,
}

/// A particle skin advanced by particles handed over one frame at a time.
pub struct ParticleStream {
    frames: SyncSender<Particles>,
    surfaces: Receiver<Result<FrameSurface, FrameError>>,
    worker: Option<JoinHandle<()>>,
    /// Why the loop ended, once it has.
    ended: Option<String>,
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
            Err(_) => Err(FrameError::Data("no more frames".into())),
        }
    }

    fn missing(&self, frame: i64) -> FrameError {
        FrameError::Data(format!("frame {frame}: no particles"))
    }
}

impl ParticleStream {
    /// Checks `spec` and starts the loop, waiting for the first frame's particles.
    pub fn start(spec: StreamSpec) -> Result<Self, FrameError> {
        spec.particles.check()?;
        super::check_fps(spec.fps)?;
        if let Some((f, _)) = &spec.reference {
            if *f >= spec.first_frame {
                return Err(FrameError::Usage(format!(
                    "the volume's reference frame {f} must come before the first frame, {}",
                    spec.first_frame
                )));
            }
        }
        spec.params.check()?;
        let (frames, handed) = sync_channel::<Particles>(1);
        let (send_surface, surfaces) = sync_channel::<Result<FrameSurface, FrameError>>(1);
        let worker = std::thread::Builder::new()
            .name("activeskin frames".into())
            .spawn(move || {
                let errors = send_surface.clone();
                let sink = SurfaceSink(Arc::new(move |s: &Surface| {
                    let _ = send_surface.send(Ok(FrameSurface {
                        frame: s.frame,
                        mesh: s.mesh.clone(),
                        velocities: s.values.velocities.map(<[Vec3]>::to_vec),
                        attributes: s.values.attributes.to_vec(),
                        stats: *s.stats,
                    }));
                }));
                let source = Handed {
                    frames: handed,
                    reference: spec.reference.clone(),
                };
                if let Err(e) = run(spec, source, sink) {
                    let _ = errors.send(Err(e));
                }
            })
            .map_err(|e| FrameError::Data(format!("cannot start the frame loop: {e}")))?;
        Ok(ParticleStream {
            frames,
            surfaces,
            worker: Some(worker),
            ended: None,
        })
    }

    /// Hands over the next frame's particles; its surface comes from [`ParticleStream::wait`].
    pub fn send(&mut self, particles: Particles) -> Result<(), FrameError> {
        if let Some(why) = &self.ended {
            return Err(FrameError::Data(why.clone()));
        }
        self.frames
            .send(particles)
            .map_err(|_| self.end("the frame loop has stopped"))
    }

    /// The surface of the frame last handed over, waiting up to `timeout` (`Ok(None)`
    /// when it is not ready yet: a caller checks for an interrupt and waits again).
    pub fn wait(&mut self, timeout: Duration) -> Result<Option<FrameSurface>, FrameError> {
        if let Some(why) = &self.ended {
            return Err(FrameError::Data(why.clone()));
        }
        match self.surfaces.recv_timeout(timeout) {
            Ok(Ok(surface)) => Ok(Some(surface)),
            Ok(Err(e)) => {
                self.ended = Some(format!("the skin stopped: {e}"));
                Err(e)
            }
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(self.end("the frame loop has stopped")),
        }
    }

    /// [`ParticleStream::send`], then [`ParticleStream::wait`] until the surface is ready.
    pub fn advance(&mut self, particles: Particles) -> Result<FrameSurface, FrameError> {
        self.send(particles)?;
        loop {
            if let Some(surface) = self.wait(Duration::from_secs(3600))? {
                return Ok(surface);
            }
        }
    }

    fn end(&mut self, why: &str) -> FrameError {
        self.ended = Some(why.to_string());
        FrameError::Data(why.to_string())
    }
}

impl Drop for ParticleStream {
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
    let outputs = OutputSpec {
        out: None,
        mesh: None,
        render: None,
        up: Default::default(),
        stats: None,
        resume: false,
        progress: None,
        stats_fields: Default::default(),
        reads: Vec::new(),
        velocities: spec.velocities,
        usd: None,
        surfaces: Some(sink),
    };
    let mut outputs = Outputs::new(&outputs, (first, i64::MAX))?;
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
