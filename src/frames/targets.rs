//! VDB inputs: level-set and fog targets checked and read, in world units, and the
//! velocity grids beside them with their scale and timing measured.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use super::scale::{self, ScaleFit};
use super::{FrameError, InputFrames};
use crate::flow::{Flow, GridFlow, Mean, Timing};
use crate::sequence::FramePattern;
use crate::target::{FogTarget, LevelSetTarget, Target};
use crate::vdb::{self, Grid};
use crate::volume::{units, GridClass, GridData};

/// What a level set target's distances are measured in (`--target-units`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TargetUnits {
    /// Measured from |∇φ| across the zero crossing; rescaled when not 1 per world unit.
    #[default]
    Auto,
    World,
    /// Voxels, as Mantaflow's `phi`.
    Voxel,
}

/// A target read from a VDB file (a level set, or a fog volume at density `iso`), and its
/// voxel size; level sets in other units rescaled to world units ([`TargetUnits::Auto`]).
pub fn read_target(
    path: &Path,
    grid: Option<&str>,
    iso: Option<f32>,
) -> Result<(Box<dyn Target>, f32), FrameError> {
    read_target_in(path, grid, iso, TargetUnits::Auto).map(|read| (read.target, read.dx))
}

/// A target as [`read_target_in`] reads it.
pub struct TargetRead {
    pub target: Box<dyn Target>,
    /// The grid's voxel size.
    pub dx: f32,
    /// What was done to the level set's distances, when anything was.
    pub note: Option<String>,
}

/// [`read_target`] with the level set's `units` given, and a line saying what was done to
/// its distances, when anything was.
pub fn read_target_in(
    path: &Path,
    grid: Option<&str>,
    iso: Option<f32>,
    units: TargetUnits,
) -> Result<TargetRead, FrameError> {
    let mut data = Grid::read(path, grid)?.to_data()?;
    check_usable(path, &data)?;
    // An empty grid is a frame without liquid (an emitter not started yet, a pool drained):
    // all outside, the skin goes on toward it.
    let dx = data.transform.voxel_size() as f32;
    let note = match data.class {
        GridClass::LevelSet => to_world_units(&mut data, units),
        _ => None,
    };
    let target: Box<dyn Target> = match (data.class, iso) {
        (GridClass::LevelSet, _) => Box::new(LevelSetTarget::new(&data)),
        (_, Some(iso)) if iso.is_finite() => Box::new(FogTarget::new(&data, iso)),
        (_, Some(iso)) => {
            return Err(FrameError::Usage(format!(
                "--iso must be a number, got {iso}"
            )))
        }
        (_, None) => {
            return Err(FrameError::Usage(format!(
                "{}: grid '{}' is not a level set: give --iso, the density of its surface",
                path.display(),
                data.name
            )))
        }
    };
    Ok(TargetRead { target, dx, note })
}

/// A factor as a person reads it: 4 significant digits, in scientific notation when far
/// from 1 (a factor of 1e-30 printed as 0.0000 said nothing).
fn readable(k: f64) -> String {
    if (1e-3..1e4).contains(&k.abs()) {
        format!("{k:.4}")
    } else {
        format!("{k:.3e}")
    }
}

/// Makes a level set's distances world units, and a background of 0 (a dense grid, as
/// Mantaflow writes) outside; says what it did.
fn to_world_units(data: &mut GridData, units: TargetUnits) -> Option<String> {
    let dx = data.transform.voxel_size() as f32;
    let name = data.name.clone();
    let ratio = |k: f64| (0.7..1.43).contains(&k);
    let (scale, mut note) = match units {
        TargetUnits::World => (1.0, None),
        TargetUnits::Voxel => (dx, None),
        TargetUnits::Auto => match units::gradient_per_world_unit(data) {
            Some(k) if ratio(k) => (1.0, None),
            Some(k) if ratio(k * f64::from(dx)) => (
                dx,
                Some(format!(
                    "grid '{name}': distances in voxels (|∇φ| {k:.1} per world unit, Δx = {dx}); rescaled to world units (--target-units world keeps them)"
                )),
            ),
            Some(k) => (
                (1.0 / k) as f32,
                Some(format!(
                    "grid '{name}': |∇φ| is {} per world unit, not 1; distances rescaled by {} (--target-units world keeps them)",
                    readable(k),
                    readable(1.0 / k)
                )),
            ),
            None => (1.0, None),
        },
    };
    if scale != 1.0 {
        units::rescale(data, scale);
    }
    if let Some(line) = background_outside(data) {
        note = Some(match note {
            Some(n) => format!("{n}; {line}"),
            None => line,
        });
    }
    note
}

/// A level set whose background is not outside (0, as Mantaflow's dense `phi`): beyond its
/// voxels is taken as outside, as far as its farthest stored distance, so that liquid
/// touching the domain's walls is closed there; says so.
pub fn background_outside(data: &mut GridData) -> Option<String> {
    if data.background > 0.0 {
        return data.tiles_within_leaves().is_some().then(|| {
            format!(
                "grid '{}': inside tiles reach past its active voxels (a band left open, then flood-filled); closed where the voxels end",
                data.name
            )
        });
    }
    let dx = data.transform.voxel_size() as f32;
    let outside = data
        .leaf_values
        .iter()
        .chain(data.tiles.iter().map(|t| &t.value))
        .fold(3.0 * dx, |m, &v| m.max(v));
    let line = format!(
        "grid '{}': background {} taken as {outside} (outside) beyond its voxels",
        data.name, data.background
    );
    data.background = outside;
    Some(line)
}

/// What any grid we sample or mesh must be: uniform voxels and finite values.
pub fn check_usable(path: &Path, data: &GridData) -> Result<(), FrameError> {
    check_transform(path, data)?;
    let finite = data.background.is_finite()
        && data.leaf_values.par_iter().all(|v| v.is_finite())
        && data.tiles.iter().all(|t| t.value.is_finite());
    if !finite {
        return Err(not_finite(path, data));
    }
    Ok(())
}

/// The transform half of [`check_usable`], for a caller that reads every value anyway:
/// cubic voxels, and leaves near enough the origin for 32-bit positions to resolve them.
pub fn check_transform(path: &Path, data: &GridData) -> Result<(), FrameError> {
    if !data.uniform_linear {
        return Err(FrameError::Data(format!(
            "{}: grid '{}' has a non-uniform or non-linear transform; resample it to cubic voxels",
            path.display(),
            data.name
        )));
    }
    let dx = data.transform.voxel_size();
    let farthest = data
        .leaf_origins
        .iter()
        .flat_map(|o| {
            [0.0, 8.0].map(|d| data.transform.index_to_world(o.map(|c| f64::from(c) + d)))
        })
        .flat_map(|p| p.map(f64::abs))
        .fold(0.0, f64::max);
    if farthest / dx > f64::from(crate::grid::REACH_VOXELS) {
        return Err(FrameError::Data(format!(
            "{}: grid '{}' lies {farthest:.4e} from the origin, {:.2e} voxels of {dx:.3e}: past 2^20 voxels, 32-bit positions do not resolve a voxel; move it nearer the origin or use larger voxels",
            path.display(),
            data.name,
            farthest / dx
        )));
    }
    Ok(())
}

/// The error of a grid holding a value that is not a finite number.
pub fn not_finite(path: &Path, data: &GridData) -> FrameError {
    FrameError::Data(format!(
        "{}: grid '{}' holds NaN or infinite values",
        path.display(),
        data.name
    ))
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
    pub source: VelocitySource,
    /// Velocity files, when not in the target's.
    pub files: Option<FramePattern>,
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
        note: &mut dyn FnMut(String),
    ) -> Result<Option<GridFlow>, FrameError> {
        let path = match &self.files {
            Some(pattern) => pattern.path(frame),
            None => target_file.to_path_buf(),
        };
        let name = match &self.source {
            VelocitySource::Off => return Ok(None),
            VelocitySource::Named(name) => name.clone(),
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
                            "velocity: grid '{n}' of {} (--no-velocity to ignore it)",
                            path.display()
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
                        let listed: Vec<String> =
                            grids.iter().map(|(g, t)| format!("'{g}' ({t})")).collect();
                        return Err(FrameError::Data(format!(
                            "{}: no velocity grid named {} (grids: {}); name it with --velocity NAME",
                            path.display(),
                            VELOCITY_NAMES.join(", "),
                            match listed.is_empty() {
                                true => "none".to_string(),
                                false => listed.join(", "),
                            }
                        )));
                    }
                    None => return Ok(None),
                }
            }
        };
        let grid = vdb::read_vector_grid(&path, Some(&name))?;
        if !grid.uniform_linear {
            return Err(FrameError::Data(format!(
                "{}: velocity grid '{name}' has a non-uniform or non-linear transform",
                path.display()
            )));
        }
        GridFlow::new(&grid, self.scale, frame_time)
            .map(Some)
            .map_err(|source| FrameError::Velocity { path, source })
    }
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
                    "velocity: scale {k:.4} measured from frames {a}–{b} (R² ≥ {worst_r2:.2}), timing {carried} {how}; --velocity-scale, --velocity-time to override"
                )
            }
            None => {
                self.source = VelocitySource::Off;
                format!(
                    "warning: the velocity does not explain the surface's motion over frames {a}–{b} (R² {best_r2:.2} < {}): left out; give --velocity-scale to use it anyway",
                    scale::MIN_R2
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
