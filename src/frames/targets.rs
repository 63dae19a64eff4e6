//! VDB inputs: level-set and fog targets checked and read, in world units, and the
//! velocity grids beside them with their scale and timing measured.

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::level_sets::{target_from_grid, to_world_units, TargetRead, TargetUnits};
use super::scale::{self, ScaleFit};
use super::{DataError, FrameError, InputFrames, LevelSetFrame};
use crate::field::Field;
use crate::flow::{Flow, GridFlow, Mean, Timing};
use crate::sequence::FramePattern;
use crate::target::{LevelSetTarget, Target};
use crate::vdb::{self, Grid};
use crate::volume::{GridClass, GridData, VectorGrid};

/// A target read from a VDB file (a level set, or a fog volume at density `iso`), and its
/// voxel size; level sets in other units rescaled to world units ([`TargetUnits::Auto`]).
pub fn read_target(
    path: &Path,
    grid: Option<&str>,
    iso: Option<f32>,
) -> Result<(Box<dyn Target>, f32), FrameError> {
    read_target_in(path, grid, iso, TargetUnits::Auto).map(|read| (read.target, read.dx))
}

/// [`read_target`] with the level set's `units` given, and a line saying what was done to
/// its distances, when anything was.
pub fn read_target_in(
    path: &Path,
    grid: Option<&str>,
    iso: Option<f32>,
    units: TargetUnits,
) -> Result<TargetRead, FrameError> {
    let data = Grid::read(path, grid)?.to_data()?;
    target_from_grid(path, data, iso, units)
}

/// A level-set run's frames read from their files (`skin --target`): each frame's target
/// ([`read_target_in`]) and velocity ([`VelocityInput::flow`]), the first frame's
/// velocity grid looked for when one is named; `note` hears, once each, what was done to
/// the distances and which velocity grid was chosen.
pub struct LevelSetFiles<'a> {
    /// The target files and the frames to run.
    pub input: &'a InputFrames,
    /// The target grid's name, when given.
    pub grid: Option<&'a str>,
    /// The density of a fog volume's surface.
    pub iso: Option<f32>,
    /// What the level sets' distances are in.
    pub units: TargetUnits,
    /// Keep the last target through missing frames instead of stopping.
    pub hold_missing: bool,
    /// Where each frame's velocity comes from.
    pub velocity: &'a VelocityInput,
    /// Frames per second (a carry's extent).
    pub fps: f64,
    /// The file the skin starts on instead of the first target (its `grid` when it has
    /// one of that name, else its first float grid).
    pub init: Option<&'a Path>,
    /// Hears each note once.
    pub note: Box<dyn FnMut(String) + Send + 'a>,
    /// Which notes were said: the units', the velocity's.
    pub noted: (bool, bool),
}

impl super::LevelSetSource for LevelSetFiles<'_> {
    fn frame(&mut self, frame: i64) -> Result<(TargetRead, Option<GridFlow>), FrameError> {
        let path = self.input.file(frame, self.hold_missing)?;
        let read = read_target_in(&path, self.grid, self.iso, self.units)?;
        // Said once: every frame of a cache is in the same units.
        if let Some(line) = read.note.clone().filter(|_| !self.noted.0) {
            (self.note)(line);
            self.noted.0 = true;
        }
        let (note, noted) = (&mut self.note, &mut self.noted.1);
        let mut once = |line: String| {
            if !*noted {
                note(line);
            }
            *noted = true;
        };
        let flow = self
            .velocity
            .flow(&path, frame, 1.0 / self.fps, &mut once)?;
        Ok((read, flow))
    }

    fn init(&mut self) -> Result<Option<TargetRead>, FrameError> {
        let Some(path) = self.init else {
            return Ok(None);
        };
        let has_grid = |name: &&str| {
            vdb::grid_types(path).is_ok_and(|grids| grids.iter().any(|(g, _)| g == name))
        };
        let grid = self.grid.filter(has_grid);
        read_target_in(path, grid, None, self.units).map(Some)
    }
}

/// Where a frame's velocity comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum VelocitySource {
    /// No velocity: the skin follows by attraction alone.
    Off,
    /// A vector grid named `vel`, `v` or `velocity` when the file holds one.
    Auto,
    /// This grid, which must be there.
    Named(String),
}

/// The velocity of each frame (paper §7): a vector grid in the target's file or in files
/// of its own, in world units per second after `scale`.
#[derive(Debug, Clone)]
pub struct VelocityInput {
    /// Where the velocity grid is found.
    pub source: VelocitySource,
    /// Velocity files, when not in the target's.
    pub files: Option<FramePattern>,
    /// What turns its values into world units per second.
    pub scale: f32,
}

/// The names a simulation's velocity goes by: Houdini `vel` (and `v` for points),
/// Mantaflow `velocity`.
pub const VELOCITY_NAMES: [&str; 3] = ["vel", "v", "velocity"];

impl VelocityInput {
    /// The flow of `frame`, whose target is `target_file`, extended for a carry over
    /// `frame_time` seconds ([`GridFlow::new`]); `None` when off, or when automatic and
    /// the file holds no velocity grid. `note` hears which grid was chosen.
    pub fn flow(
        &self,
        target_file: &Path,
        frame: i64,
        frame_time: f64,
        note: &mut (dyn FnMut(String) + Send),
    ) -> Result<Option<GridFlow>, FrameError> {
        let Some((path, grid)) = self.grid(target_file, frame, note)? else {
            return Ok(None);
        };
        GridFlow::new(&grid, self.scale, frame_time)
            .map(Some)
            .map_err(|source| FrameError::Velocity { path, source })
    }

    /// The velocity grid of `frame` ([`VelocityInput::flow`]) and the file it is in,
    /// unscaled.
    pub fn grid(
        &self,
        target_file: &Path,
        frame: i64,
        note: &mut (dyn FnMut(String) + Send),
    ) -> Result<Option<(PathBuf, VectorGrid)>, FrameError> {
        let path = match &self.files {
            Some(pattern) => pattern.path(frame),
            None => target_file.to_path_buf(),
        };
        let name = match &self.source {
            VelocitySource::Off => return Ok(None),
            VelocitySource::Named(name) => {
                let grids = vdb::grid_types(&path)?;
                if !grids.iter().any(|(g, _)| g == name) {
                    return Err(DataError::NoVelocityGrid {
                        path,
                        name: name.clone(),
                        grids,
                    }
                    .into());
                }
                name.clone()
            }
            VelocitySource::Auto => {
                let grids = vdb::grid_types(&path)?;
                let typed = |n: &str, kinds: &[&str]| {
                    grids
                        .iter()
                        .any(|(g, t)| g == n && kinds.iter().any(|k| t.contains(k)))
                };
                match VELOCITY_NAMES
                    .into_iter()
                    .find(|n| typed(n, &["vec3s", "vec3d"]))
                {
                    Some(n) => {
                        note(format!(
                            "velocity: grid '{n}' of {} ({} to ignore it)",
                            path.display(),
                            Field::NoVelocity
                        ));
                        n.to_string()
                    }
                    // Integer vectors are not a velocity (Houdini's and OpenVDB's are
                    // float): skipped, and said.
                    None if VELOCITY_NAMES.into_iter().any(|n| typed(n, &["vec3i"])) => {
                        note(format!(
                            "velocity: {} holds integer vectors (vec3i) under a velocity's name: not used",
                            path.display()
                        ));
                        return Ok(None);
                    }
                    // Velocity files given and none holds a velocity: not silently unused.
                    None if self.files.is_some() => {
                        return Err(DataError::NoVelocityFound { path, grids }.into());
                    }
                    None => return Ok(None),
                }
            }
        };
        let grid = vdb::read_vector_grid(&path, Some(&name))?;
        if !grid.uniform_linear {
            return Err(DataError::VelocityNonUniform { path, name }.into());
        }
        Ok(Some((path, grid)))
    }
}

/// One frame of a level-set or fog target from a VDB file, with its velocity grid as
/// `velocity` says (in the file's units), as [`super::LevelSetStream`] takes it: `skin`
/// reads the same grids.
pub fn read_level_set_frame(
    path: &Path,
    grid: Option<&str>,
    velocity: VelocitySource,
) -> Result<LevelSetFrame, FrameError> {
    let data = Grid::read(path, grid)?.to_data()?;
    let input = VelocityInput {
        source: velocity,
        files: None,
        scale: 1.0,
    };
    let velocity = input.grid(path, 0, &mut |_| {})?.map(|(_, v)| v);
    Ok(LevelSetFrame {
        grid: data,
        velocity,
        label: path.to_path_buf(),
    })
}

/// The velocity's scale as measured by [`VelocityInput::measure_scale`].
#[derive(Debug, Clone)]
pub struct ScaleEstimate {
    /// The median of the good fits under `timing`; `None` when no pair fits well.
    pub scale: Option<f64>,
    /// The timing chosen ([`scale::choose_timing`]), or given.
    pub timing: Timing,
    /// Each frame pair tried, with its fit under `timing`.
    pub fits: Vec<((i64, i64), ScaleFit)>,
    /// The same pairs' fits under the other timing, when it was tried.
    pub other: Vec<ScaleFit>,
}

impl ScaleEstimate {
    /// The estimate as a stats field.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "scale": self.scale,
            "timing": self.timing.name(),
            "pairs": self.fits.iter().map(|((a, b), f)| serde_json::json!({
                "frames": [a, b], "scale": f.scale, "r2": f.r2, "samples": f.samples,
            })).collect::<Vec<_>>(),
            "other_timing_scales": self.other.iter().map(|f| f.scale).collect::<Vec<_>>(),
        })
    }
}

/// Frame pairs the scale is measured on, at most.
const SCALE_PAIRS: usize = 3;
/// Points per pair, at most (every k-th band voxel).
const SCALE_POINTS: usize = 20_000;

impl VelocityInput {
    /// Settles an automatic scale: measured on the first frame pairs
    /// ([`VelocityInput::measure_scale`]); with no pair to measure on (one frame, no
    /// velocity) the scale stays as it is; with a poor fit the velocity is left out.
    /// Returns the estimate, for the stats, and one line saying what was settled.
    pub fn settle_scale(
        &mut self,
        input: &InputFrames,
        target: (Option<&str>, TargetUnits),
        fps: f64,
        timing: Option<Timing>,
    ) -> Result<Option<(ScaleEstimate, String)>, FrameError> {
        if self.source == VelocitySource::Off {
            return Ok(None);
        }
        let estimate = self.measure_scale(input, target, fps, timing)?;
        let Some(((a, _), _)) = estimate.fits.first() else {
            return Ok(None);
        };
        let b = estimate.fits.last().map_or(*a, |f| f.0 .1);
        let r2 = estimate.fits.iter().map(|f| f.1.r2);
        let (worst_r2, best_r2) = (
            r2.clone().fold(f64::MAX, f64::min),
            r2.fold(f64::MIN, f64::max),
        );
        let note = match estimate.scale {
            Some(k) => {
                self.scale = k as f32;
                let carried = match estimate.timing {
                    Timing::Start => "start (each frame's velocity carries the liquid to the next)",
                    Timing::Mid => "mid (the mean of both frames' velocities carries it)",
                };
                let how = if timing.is_none() {
                    "measured"
                } else {
                    "given"
                };
                format!(
                    "velocity: scale {k:.4} measured from frames {a}–{b} (R² ≥ {worst_r2:.2}), timing {carried} {how}; {}, {} to override",
                    Field::VelocityScale,
                    Field::VelocityTime
                )
            }
            None => {
                self.source = VelocitySource::Off;
                format!(
                    "warning: the velocity does not explain the surface's motion over frames {a}–{b} (R² {best_r2:.2} < {}): left out; give {} to use it anyway",
                    scale::MIN_R2,
                    Field::VelocityScale
                )
            }
        };
        Ok(Some((estimate, note)))
    }

    /// Measures the factor that turns the velocity into world units per second from the
    /// first frame pairs of `frames` whose level sets (grid `grid`, distances in `units`)
    /// and velocities exist:
    /// the surface's own motion between them against the velocity's prediction
    /// ([`scale::fit`]), over the voxels within 1.5 voxels of the earlier surface. Under
    /// `timing`, or under each timing when `None`, keeping the one that fits
    /// ([`scale::choose_timing`]).
    pub fn measure_scale(
        &self,
        input: &InputFrames,
        (grid, units): (Option<&str>, TargetUnits),
        fps: f64,
        timing: Option<Timing>,
    ) -> Result<ScaleEstimate, FrameError> {
        let timings = match timing {
            Some(t) => vec![t],
            None => vec![Timing::Start, Timing::Mid],
        };
        let mut fits: Vec<((i64, i64), Vec<ScaleFit>)> = Vec::new();
        let unscaled = VelocityInput {
            scale: 1.0,
            ..self.clone()
        };
        let (first, last) = input.range;
        let frames: Vec<i64> = input
            .existing
            .iter()
            .copied()
            .filter(|f| (first..=last).contains(f))
            .collect();
        for pair in frames.windows(2).filter(|w| w[1] == w[0] + 1) {
            if fits.len() == SCALE_PAIRS {
                break;
            }
            let (a, b) = (pair[0], pair[1]);
            // A pair without velocity or level sets, or a frame that cannot be read, ends
            // the measurement (the run reports a bad frame when it gets there, after writing
            // the frames before).
            match fit_pair(&unscaled, input, (grid, units), (a, b), fps, &timings) {
                Ok(Some(fit)) => fits.push(((a, b), fit)),
                Ok(None) | Err(_) => break,
            }
        }
        let under = |i: usize| fits.iter().map(|(_, f)| f[i]).collect::<Vec<ScaleFit>>();
        let candidates: Vec<(Timing, Vec<ScaleFit>)> = timings
            .iter()
            .enumerate()
            .map(|(i, &t)| (t, under(i)))
            .collect();
        let (chosen, scale) = scale::choose_timing(&candidates);
        let index = timings.iter().position(|&t| t == chosen).unwrap_or(0);
        Ok(ScaleEstimate {
            scale,
            timing: chosen,
            fits: fits.iter().map(|(pair, f)| (*pair, f[index])).collect(),
            other: fits
                .iter()
                .flat_map(|(_, f)| f.iter().enumerate().filter(|&(i, _)| i != index))
                .map(|(_, f)| *f)
                .collect(),
        })
    }
}

/// The fits of one frame pair under each of `timings`; `None` when a frame lacks a
/// velocity or is not a level set.
fn fit_pair(
    unscaled: &VelocityInput,
    input: &InputFrames,
    (grid, units): (Option<&str>, TargetUnits),
    (a, b): (i64, i64),
    fps: f64,
    timings: &[Timing],
) -> Result<Option<Vec<ScaleFit>>, FrameError> {
    let (path_a, path_b) = (input.pattern.path(a), input.pattern.path(b));
    let mut quiet = |_: String| {};
    let (Some(flow_a), Some(flow_b)) = (
        unscaled.flow(&path_a, a, 1.0 / fps, &mut quiet)?,
        unscaled.flow(&path_b, b, 1.0 / fps, &mut quiet)?,
    ) else {
        return Ok(None);
    };
    let (mut data_a, mut data_b) = (
        Grid::read(&path_a, grid)?.to_data()?,
        Grid::read(&path_b, grid)?.to_data()?,
    );
    if data_a.class != GridClass::LevelSet || data_b.class != GridClass::LevelSet {
        return Ok(None); // a fog volume's density is not a distance
    }
    // The distances the skin will see.
    to_world_units(&mut data_a, units);
    to_world_units(&mut data_b, units);
    let dx = data_a.transform.voxel_size() as f32;
    let points = band_points(&data_a, 1.5 * dx);
    let step = points.len().div_ceil(SCALE_POINTS).max(1);
    let points: Vec<Vec3> = points.into_iter().step_by(step).collect();
    let (before, after) = (LevelSetTarget::new(&data_a), LevelSetTarget::new(&data_b));
    let fits = timings
        .iter()
        .map(|timing| {
            let mean = Mean(&flow_a, &flow_b);
            let flow: &dyn Flow = match timing {
                Timing::Start => &flow_a,
                Timing::Mid => &mean,
            };
            scale::fit(&before, &after, flow, &points, (1.0 / fps) as f32, 0.5 * dx)
        })
        .collect();
    Ok(Some(fits))
}

/// World positions of a level set's active voxels with |φ| < `within`.
fn band_points(data: &GridData, within: f32) -> Vec<Vec3> {
    data.active_voxels()
        .filter(|(_, phi)| phi.abs() < within)
        .map(|(ijk, _)| {
            let world = data.transform.index_to_world(ijk.map(f64::from));
            Vec3::from(world.map(|c| c as f32))
        })
        .collect()
}
