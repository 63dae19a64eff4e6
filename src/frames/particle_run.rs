//! A particle sequence through the frame loop (§6.1, §7): each frame's particles read
//! once; matched with the frame before (by id, or by an order their motion confirms),
//! their own displacements carry the skin in one trace, else their velocities do; the
//! skin starts on the first frame's density, one solid. The `particles` command and the
//! library's callers run it alike, with or without OpenVDB.

use std::sync::Arc;

use super::{FrameError, FrameInput, InputFrames, Outputs, ParticleFrame, ParticleInput};
use crate::flow::{Flow, FlowMap, Timing};
use crate::particles::{self, Particles};
use crate::skin::{AnySkin, SkinParams};
use crate::target::DensityGrid;

/// What a particle run needs besides its outputs.
pub struct ParticleRun<'a> {
    pub input: &'a InputFrames,
    pub particles: &'a ParticleInput,
    pub params: SkinParams,
    pub fps: f64,
    /// Which frames' velocities carry the liquid when the particles cannot be matched.
    pub timing: Timing,
    /// The first frame written: the frames of `input.range` before it warm the skin up.
    pub write_from: i64,
}

impl ParticleRun<'_> {
    /// Runs the frames into `outputs`; `note` hears, once, what the user should know
    /// (particles left out).
    pub fn run(
        &self,
        outputs: &mut Outputs,
        note: &mut dyn FnMut(String),
    ) -> Result<(), FrameError> {
        if let Err(why) = self.particles.check() {
            return Err(FrameError::Usage(why));
        }
        let (input, range, write_from) = (self.input, self.input.range, self.write_from);
        // A warm-up frame writes nothing, its density neither.
        let quiet = ParticleInput {
            density_out: None,
            ..self.particles.clone()
        };
        let duration = (1.0 / self.fps) as f32;
        // The particles of the frame read last, matched with the next frame's.
        let mut last: Option<(i64, Particles)> = None;
        let mut noted = false;
        // Each frame is read once (its density is the skin's target and, with a
        // density output, written as a fog volume on the way); the density comes back
        // with whether it carries the frame's motion.
        let mut frame_at = |frame: i64| -> Result<(DensityGrid, bool), FrameError> {
            let path = input.pattern.path(frame);
            let exists =
                |f: i64| input.pattern.is_held() || input.existing.binary_search(&f).is_ok();
            if !exists(frame) {
                // There but not a file: said so, not called missing.
                if let Some(why) = crate::io::not_a_file(&path) {
                    return Err(FrameError::Data(format!("{}: {why}", path.display())));
                }
                return Err(FrameError::Data(format!(
                    "{}: frame {frame} of the particles is missing",
                    path.display()
                )));
            }
            let before = match last.take() {
                Some((f, particles)) if f == frame - 1 => Some(particles),
                // After a resume, or in a chunk: read as an uninterrupted run has it.
                _ if frame > range.0 && exists(frame - 1) => {
                    Some(particles::read(&input.pattern.path(frame - 1))?)
                }
                _ => None,
            };
            let reader = match frame < write_from {
                true => &quiet,
                false => self.particles,
            };
            let ParticleFrame {
                density,
                particles,
                carried,
                note: said,
            } = reader.frame(&path, frame, before.as_ref(), duration)?;
            // Said once: a cache that strays does so on many frames.
            if let Some(line) = said.filter(|_| !noted) {
                note(line);
                noted = true;
            }
            last = Some((frame, particles));
            Ok((density, carried))
        };
        // The skin starts on the first frame's density, one solid: the small voids of a
        // density whose kernel barely spans the spacing would each become a skin to remove.
        let mut first = frame_at(range.0)?.0;
        first.fill_voids(self.particles.void_volume());
        let skin = AnySkin::new(&first, self.params);
        // The loop asks for the first frame once more, for its velocity.
        let mut first = Some(Arc::new(first));
        super::run(
            range,
            write_from,
            skin,
            (self.fps, self.timing),
            outputs,
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
}
