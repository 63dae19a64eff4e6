//! A level-set (or fog) sequence through the frame loop (§6.2, §7): the skin starts on
//! the first frame's target, or on a shape given instead (`skin --init`, `morph
//! --from`), on the first target's voxels unless a voxel size is given; each frame's
//! velocity carries it, then its target attracts it, and where the target has material
//! the skin has none near, it is seeded (a simulation; not a morph). The `skin` command
//! and the Python level-set stream run it alike.

use super::{Cover, FrameError, FrameInput, Outputs, Spray, TargetRead};
use crate::flow::{Flow, GridFlow, Timing};
use crate::skin::{AnySkin, SkinParams};

/// Where a level-set run's frames come from: files (`skin --target`), or grids handed
/// over frame by frame (the Python API).
pub trait LevelSetSource: Send {
    /// Frame `frame`'s target and the material's velocity then, when known. Asked for
    /// the first frame once or twice (its voxel size, then the frame itself).
    fn frame(&mut self, frame: i64) -> Result<(TargetRead, Option<GridFlow>), FrameError>;
    /// The shape the skin starts on instead of the first frame's target, if any.
    fn init(&mut self) -> Result<Option<TargetRead>, FrameError>;
    /// As [`super::ParticleSource::reads_ahead`].
    fn reads_ahead(&self) -> bool {
        true
    }
}

/// A level-set run whose first frame is read: the voxel size the skin takes when none
/// is given is known ([`LevelSetRun::voxel_size`]), and the shape it starts on.
pub struct LevelSetRun<S> {
    source: S,
    /// The first target's voxel size.
    dx: f32,
    /// The shape the skin starts on.
    start: TargetRead,
}

/// How a [`LevelSetRun`] goes on: its frames, which it writes from, its clock, and
/// whether the target seeds the skin.
pub struct LevelSetPlan {
    /// First and last frame, inclusive.
    pub range: (i64, i64),
    /// The first frame written: those before it warm the skin up.
    pub write_from: i64,
    /// Frames per second: a frame advances the skin 1/fps seconds.
    pub fps: f64,
    /// Which frames' velocities carry the skin over an interval.
    pub timing: Timing,
    /// Seed the skin where the target has material it has none near ([`AnySkin::seed`]).
    pub seed: bool,
}

impl<S: LevelSetSource> LevelSetRun<S> {
    /// Reads frame `first`'s target (its voxel size) and the shape the skin starts on.
    pub fn start(mut source: S, first: i64) -> Result<Self, FrameError> {
        let first_target = source.frame(first)?.0;
        let dx = first_target.dx;
        let start = match source.init()? {
            Some(init) => init,
            None => first_target,
        };
        Ok(LevelSetRun { source, dx, start })
    }

    /// The first target's voxel size: the skin's when none is given.
    pub fn voxel_size(&self) -> f32 {
        self.dx
    }

    /// Runs the skin, of checked `params`, over `plan`'s frames into `outputs`.
    pub fn run(
        self,
        params: SkinParams,
        plan: &LevelSetPlan,
        outputs: &mut Outputs,
    ) -> Result<(), FrameError> {
        let LevelSetRun {
            mut source, start, ..
        } = self;
        let skin = AnySkin::try_new(&*start.target, params)?;
        drop(start);
        let seed = plan.seed;
        let read_ahead = source.reads_ahead();
        let input_at = move |frame: i64| -> Result<FrameInput, FrameError> {
            let (target, flow) = source.frame(frame)?;
            Ok(FrameInput {
                target: target.target,
                flow: flow.map(|f| Box::new(f) as Box<dyn Flow>),
                carried: None,
                seed,
                volume: None,
                attributes: None,
                spray: Spray::default(),
                cover: Cover::default(),
            })
        };
        super::run(
            plan.range,
            plan.write_from,
            skin,
            (plan.fps, plan.timing),
            outputs,
            (read_ahead, input_at),
        )
    }
}
