//! A particle sequence through the frame loop (§6.1, §7): each frame's particles read
//! once; matched with the frame before (by id, or by an order their motion confirms),
//! their own displacements carry the skin in one trace, else their velocities do; the
//! skin starts on the first frame's density, one solid. The `particles` command and the
//! library's callers run it alike, with or without OpenVDB.

use std::path::PathBuf;
use std::sync::Arc;

use super::{
    AttributeChoice, DataError, FrameError, FrameInput, InputFrames, Outputs, ParticleFrame,
    ParticleInput, Spray,
};
use crate::flow::{Flow, FlowMap, Timing};
use crate::io::particles;
use crate::particles::Particles;
use crate::skin::{AnySkin, SkinParams};

/// What a particle run needs besides its outputs.
pub struct ParticleRun<'a> {
    /// The particle files and the frames to run.
    pub input: &'a InputFrames,
    /// How each frame's particles become its target.
    pub particles: &'a ParticleInput,
    /// The skin's parameters.
    pub params: SkinParams,
    /// Frames per second: a frame advances the skin 1/fps seconds.
    pub fps: f64,
    /// Which frames' velocities carry the liquid when the particles cannot be matched.
    pub timing: Timing,
    /// The first frame written: the frames of `input.range` before it warm the skin up.
    pub write_from: i64,
    /// Hold the skin to the volume the particles stand for on every frame
    /// ([`ParticleRun::volume_share`]); `false` leaves it to the density's iso-surface.
    pub hold_volume: bool,
}

/// Where a particle run's frames come from: files (`--particles`), or particles handed
/// over frame by frame (the Python API).
pub trait ParticleSource: Send {
    /// The particles of `frame` and the path naming them in messages; `Ok(None)` when the
    /// source has no such frame.
    fn particles(&mut self, frame: i64) -> Result<Option<(Particles, PathBuf)>, FrameError>;
    /// Why frame `frame` cannot be had, when it was needed.
    fn missing(&self, frame: i64) -> FrameError;
    /// Whether the next frame may be asked for while the current one settles: not where
    /// asking waits on a caller who is waiting for that frame's surface.
    fn reads_ahead(&self) -> bool {
        true
    }
}

/// The frames of a pattern, read from their files.
struct Files<'a>(&'a InputFrames);

impl ParticleSource for Files<'_> {
    fn particles(&mut self, frame: i64) -> Result<Option<(Particles, PathBuf)>, FrameError> {
        let input = self.0;
        if !(input.pattern.is_held() || input.existing.binary_search(&frame).is_ok()) {
            return Ok(None);
        }
        let path = input.pattern.path(frame);
        Ok(Some((particles::read(&path)?, path)))
    }

    fn missing(&self, frame: i64) -> FrameError {
        let path = self.0.pattern.path(frame);
        // There but not a file: said so, not called missing.
        match crate::io::not_a_file(&path) {
            Some(why) => DataError::NotAFile { path, why }.into(),
            None => DataError::MissingParticles { path, frame }.into(),
        }
    }
}

impl ParticleRun<'_> {
    /// Runs the frames into `outputs`; `note` hears, once, what the user should know
    /// (particles left out).
    pub fn run(
        &self,
        outputs: &mut Outputs,
        note: &mut (dyn FnMut(String) + Send),
    ) -> Result<(), FrameError> {
        self.run_from(&mut Files(self.input), outputs, note)
    }

    /// [`ParticleRun::run`] on the frames of `source` (`self.input` gives the range).
    pub fn run_from(
        &self,
        source: &mut dyn ParticleSource,
        outputs: &mut Outputs,
        note: &mut (dyn FnMut(String) + Send),
    ) -> Result<(), FrameError> {
        self.particles.check()?;
        super::check_fps(self.fps)?;
        self.params.check()?;
        let (range, write_from) = (self.input.range, self.write_from);
        // A warm-up frame writes nothing, its density neither.
        let quiet = ParticleInput {
            density_out: None,
            attributes: AttributeChoice::None,
            ..self.particles.clone()
        };
        let duration = (1.0 / self.fps) as f32;
        // The particles of the frame read last, matched with the next frame's.
        let mut last: Option<(i64, Particles)> = None;
        let mut noted = false;
        // Each frame is read once (its density is the skin's target and, with a
        // density output, written as a fog volume on the way); it comes back with what
        // its particles hold (their number), the particles kept to match the next's.
        // The sequence's first frame sets the volume held: every run, chunk and resume
        // of the shot holds the same (this run's first frame's is measured below).
        let reference_share = match self.reference_frame() {
            f if self.hold_volume && f != range.0 => {
                self.volume_share(source, f, &quiet, duration)?
            }
            _ => None,
        };
        let read_ahead = source.reads_ahead();
        let (inner, outer) = self.particles.spray_reach();
        let covers = self.params.smoothing > 0.0;
        let mut frame_at = |frame: i64| -> Result<(ParticleFrame, f64), FrameError> {
            let Some((cloud, path)) = source.particles(frame)? else {
                return Err(source.missing(frame));
            };
            let before = match last.take() {
                Some((f, particles)) if f == frame - 1 => Some(particles),
                // After a resume, or in a chunk: read as an uninterrupted run has it.
                _ if frame > range.0 => source.particles(frame - 1)?.map(|(p, _)| p),
                _ => None,
            };
            let reader = match frame < write_from {
                true => &quiet,
                false => self.particles,
            };
            let mut read = reader.frame_of(cloud, &path, frame, before.as_ref(), duration)?;
            // Said once: a cache that strays does so on many frames.
            if let Some(line) = read.note.take().filter(|_| !noted) {
                note(line);
                noted = true;
            }
            let particles = std::mem::take(&mut read.particles);
            // The positions stay with the frame for the smoothed skin's cover.
            if covers {
                read.particles.positions = particles.positions.clone();
            }
            let count = held(&particles, reader);
            last = Some((frame, particles));
            Ok((read, count))
        };
        // The skin starts on the first frame's density, one solid: the small voids of a
        // density whose kernel barely spans the spacing would each become a skin to remove.
        let (mut first, count) = frame_at(range.0)?;
        first.density.fill_voids(self.particles.void_volume());
        let skin = AnySkin::try_new(&first.density, self.params)?;
        let share = match self.hold_volume {
            false => None,
            true => reference_share.or(Some(skin.stats().volume / count)),
        }
        .filter(|s| s.is_finite() && *s > 0.0);
        // The loop asks for the first frame once more, for its velocity (the skin starts
        // on it: not carried).
        first.carried = false;
        let mut first = Some(first);
        super::run(
            range,
            write_from,
            skin,
            (self.fps, self.timing),
            outputs,
            (read_ahead, |frame| {
                let (read, count) = match first.take() {
                    Some(read) if frame == range.0 => (read, count),
                    _ => frame_at(frame)?,
                };
                let ParticleFrame {
                    density,
                    carried,
                    attributes,
                    spray,
                    particles,
                    ..
                } = read;
                let density = Arc::new(density);
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
                    volume: share.map(|share| share * count),
                    attributes,
                    spray: Spray {
                        points: spray,
                        inner,
                        outer,
                    },
                    cover: self.particles.cover(particles.positions),
                })
            }),
        )
    }

    /// The sequence's first frame (the run's own when one file is held for all).
    fn reference_frame(&self) -> i64 {
        match self.input.existing.first() {
            Some(&f) if !self.input.pattern.is_held() => f,
            _ => self.input.range.0,
        }
    }

    /// The volume of liquid each particle stands for, up to the factor [`held`] leaves
    /// out: the enclosed volume of the skin started on `frame`'s density, per particle.
    /// The density's iso-surface swells on thin sheets and spray (4 % on the
    /// SPlisHSPlasH dam break's impact frames, 2.4 % splashsurf's) while the liquid
    /// keeps its volume; a liquid at rest (a simulation's first frame) has it right.
    fn volume_share(
        &self,
        source: &mut dyn ParticleSource,
        frame: i64,
        reader: &ParticleInput,
        duration: f32,
    ) -> Result<Option<f64>, FrameError> {
        let Some((cloud, path)) = source.particles(frame)? else {
            return Err(source.missing(frame));
        };
        let ParticleFrame {
            mut density,
            particles,
            ..
        } = reader.frame_of(cloud, &path, frame, None, duration)?;
        density.fill_voids(reader.void_volume());
        let volume = AnySkin::try_new(&density, self.params)?.stats().volume;
        Ok(Some(volume / held(&particles, reader)))
    }
}

/// What particles hold, up to a common factor: their number, or with radii of their own
/// the sum of their cubes.
fn held(particles: &Particles, input: &ParticleInput) -> f64 {
    match &particles.radii {
        Some(radii) if !input.ignore_radii => radii.iter().map(|&r| f64::from(r).powi(3)).sum(),
        _ => particles.positions.len() as f64,
    }
}
