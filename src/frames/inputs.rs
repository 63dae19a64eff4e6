//! A frame's inputs: sequences found on disk, and particle frames read and checked.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::{DataError, FrameError, UsageError};
use crate::field::Field;
use crate::grid::REACH_VOXELS;
use crate::io::particles;
use crate::particles::{motion::frame_velocities, Attribute, Particles};
use crate::sequence::{FramePattern, PatternError};
use crate::target::{
    fluid_iso, Density, DensityGrid, DEFAULT_SMOOTHING_LENGTH, MAX_SMOOTHING_LENGTH, SPRAY_LINK,
    SPRAY_MOST, VELOCITY_SUPPORT_RADII,
};
#[cfg(feature = "vdb")]
use crate::vdb::{self, Grid, WriteOptions};

/// What a start that is `d` voxels off the sequential skin fades to after an automatic
/// warm-up ([`auto_warmup`]): the attraction closes the gap as e^(−αt).
pub const WARMUP_AUTO_FACTOR: f64 = 40.0;

/// Frames for a start to fade to 1/[`WARMUP_AUTO_FACTOR`] of its offset at attraction
/// rate `alpha` (1/s) and `fps`: ln(40)·fps/α; none without attraction.
pub fn auto_warmup(alpha: f64, fps: f64) -> i64 {
    if !(alpha > 0.0 && fps > 0.0) {
        return 0;
    }
    (WARMUP_AUTO_FACTOR.ln() * fps / alpha).ceil().min(1e9) as i64
}

/// An input sequence: its pattern, the frames found on disk (sorted; none for one held
/// file), the range to run.
pub struct InputFrames {
    /// The frame pattern (`####`, `$F4`, `{}`), or one file held for every frame.
    pub pattern: FramePattern,
    /// The frame numbers found on disk, sorted.
    pub existing: Vec<i64>,
    /// The first and last frame to run, inclusive.
    pub range: (i64, i64),
}

impl InputFrames {
    /// Moves the start of the range `warmup` frames earlier, not before the sequence's
    /// first frame (a held single file has none): a chunk or a `--frames` range whose
    /// skin starts from its first target, warmed up on the frames before, meets the skin a
    /// whole run would have there. Returns the first frame to write.
    pub fn warm_up(&mut self, warmup: i64) -> i64 {
        let first = self.range.0;
        let earliest = match self.existing.first() {
            Some(&f) if !self.pattern.is_held() => f.min(first),
            _ => i64::MIN,
        };
        self.range.0 = first.saturating_sub(warmup.max(0)).max(earliest);
        first
    }

    /// The sequence given as `field` ([`Field::Target`], [`Field::Particles`]); the range
    /// is `frames`, or every frame found.
    /// A file without a frame number is held for every frame of `frames`, which must be
    /// given (a static target: a shape to smooth with tension, a morph's end).
    pub fn find(flag: Field, spec: &str, frames: Option<(i64, i64)>) -> Result<Self, FrameError> {
        if let Some((a, b)) = frames.filter(|(a, b)| a > b) {
            return Err(UsageError::EmptyRange { first: a, last: b }.into());
        }
        let pattern = match FramePattern::parse(spec) {
            Err(PatternError::NoFrameNumber(_)) if Path::new(spec).is_file() => {
                let Some((a, b)) = frames else {
                    return Err(UsageError::OneFile {
                        field: flag,
                        spec: spec.into(),
                    }
                    .into());
                };
                return Ok(InputFrames {
                    pattern: FramePattern::held(spec),
                    existing: Vec::new(),
                    range: (a, b),
                });
            }
            Err(PatternError::NoFrameNumber(_)) => {
                if let Some(why) = crate::io::not_a_file(Path::new(spec)) {
                    return Err(DataError::NotAFile {
                        path: spec.into(),
                        why,
                    }
                    .into());
                }
                return Err(UsageError::NotASequence {
                    field: flag,
                    spec: spec.into(),
                }
                .into());
            }
            other => other.map_err(UsageError::Pattern)?,
        };
        // Said with the pattern as the user spelled it.
        let existing = pattern.existing_frames().map_err(|e| match e {
            PatternError::Unreadable { reason, .. } => FrameError::from(DataError::Unlistable {
                field: flag,
                spec: spec.into(),
                reason,
            }),
            other => other.into(),
        })?;
        let range = match (frames, existing.first(), existing.last()) {
            (Some(range), _, _) => range,
            (None, Some(&a), Some(&b)) => (a, b),
            _ => {
                return Err(UsageError::NoMatch {
                    field: flag,
                    spec: spec.into(),
                }
                .into())
            }
        };
        Ok(InputFrames {
            pattern,
            existing,
            range,
        })
    }

    /// The file of `frame`; with `hold_missing`, the last earlier one when it is missing.
    pub fn file(&self, frame: i64, hold_missing: bool) -> Result<PathBuf, FrameError> {
        let path = self.pattern.path(frame);
        if self.pattern.is_held() || self.existing.binary_search(&frame).is_ok() {
            return Ok(path);
        }
        // There but not a file: an error, never a missing frame to hold over.
        if let Some(why) = crate::io::not_a_file(&path) {
            return Err(DataError::NotAFile { path, why }.into());
        }
        let held = self.existing.iter().rev().find(|&&f| f < frame);
        Err(match held {
            Some(&f) if hold_missing => return Ok(self.pattern.path(f)),
            _ if hold_missing => DataError::NothingToHold { path },
            _ => DataError::MissingTarget { path, frame },
        }
        .into())
    }
}

/// How particle frames become targets (§6.1): the density of particles of `radius` (or
/// their own radii) with supports of 2·`smoothing_length` radii, its surface at `iso`,
/// rasterized on the skin's voxels; written as a fog volume when `density_out`.
#[derive(Clone)]
pub struct ParticleInput {
    /// The particles' radius, world units: half their rest spacing.
    pub radius: f32,
    /// Use `radius` for every particle even where the file gives radii of their own.
    pub ignore_radii: bool,
    /// Half the kernel's support, in particle radii.
    pub smoothing_length: f32,
    /// The density's level (in the rest density's units) its surface lies at.
    pub iso: f32,
    /// Where each frame's density is written as a fog volume (OpenVDB only).
    pub density_out: Option<FramePattern>,
    /// The skin's voxel size, on whose nodes the density is rasterized.
    pub dx: f32,
    /// Multiplies the particles' velocities into world units per second; `None` ignores
    /// them.
    pub velocity_scale: Option<f32>,
    /// The particle attributes carried onto the surface (`--attribute`).
    pub attributes: AttributeChoice,
}

/// The cover ([`ParticleInput::cover`]), in radii: where a particle's centre lies outside
/// the skin as its cover starts and as it is whole, and the reach of the density's
/// surface around it. Measured on both SPlisHSPlasH dam breaks and a pool at rest
/// (`docs/benchmarks.md`, session 33): covering from half a radius inside the skin
/// lowered the pool's top by a fifth of a radius (its square rims given back volume,
/// which the volume hold takes from the top), from half a radius outside left 0.8 % of
/// the double dam break's particles outside; switched on whole at a threshold, the
/// covered patches flickered; a reach of 1–2 radii left beads along a column's edges.
const COVER_FROM: f32 = 0.25;
const COVER_FULL: f32 = 1.25;
const COVER_INNER: f32 = 2.5;
const COVER_OUTER: f32 = 4.0;

/// The largest radius or voxel size a particle run takes, in world units.
pub(super) const MAX_LENGTH: f32 = 1e15;

impl ParticleInput {
    /// How near its spray particles the skin takes a frame's target's surface
    /// ([`super::Spray`]): wholly within a radius short of the spray's link (3.25 radii at
    /// the default smoothing length, the drop's surface and the gap between it and the
    /// liquid), blending back to its own at the link.
    pub fn spray_reach(&self) -> (f32, f32) {
        let link = SPRAY_LINK * 2.0 * self.smoothing_length * self.radius;
        ((link - self.radius).max(0.5 * link), link)
    }

    /// How the smoothed skin keeps a frame's `points` under it ([`super::Cover`]): around a
    /// particle whose centre lies outside the skin, from a quarter radius out on (wholly
    /// from 1.25), the skin takes the density's surface where that lies farther out,
    /// within 2.5 radii of it, blending back to its own by 4 radii.
    pub fn cover(&self, points: Vec<Vec3>) -> super::Cover {
        let r = self.radius;
        super::Cover {
            points,
            from: COVER_FROM * r,
            full: COVER_FULL * r,
            inner: COVER_INNER * r,
            outer: COVER_OUTER * r,
        }
    }

    /// Particles of `radius` at the defaults: smoothing length
    /// [`DEFAULT_SMOOTHING_LENGTH`], the iso-density of a fluid at rest's boundary
    /// ([`fluid_iso`]), voxels of half the radius, velocities as they are, no attributes.
    pub fn with_radius(radius: f32) -> Self {
        ParticleInput {
            radius,
            ignore_radii: false,
            smoothing_length: DEFAULT_SMOOTHING_LENGTH,
            iso: fluid_iso(DEFAULT_SMOOTHING_LENGTH),
            density_out: None,
            dx: 0.5 * radius,
            velocity_scale: Some(1.0),
            attributes: AttributeChoice::None,
        }
    }
}

/// Which particle attributes are carried onto the surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum AttributeChoice {
    #[default]
    None,
    /// These, by their names in the files.
    Named(Vec<String>),
    /// Every one the files hold.
    All,
}

/// A frame's particle attributes and the density whose weights carry them onto points
/// of the surface ([`Density::interpolate`]).
pub struct AttributeSource {
    density: Density,
    attributes: Vec<Attribute>,
}

impl AttributeSource {
    /// Each attribute at `points`, under its own name.
    pub fn at(&self, points: &[Vec3]) -> Vec<Attribute> {
        let fields: Vec<(&[f32], usize)> = self
            .attributes
            .iter()
            .map(|a| (a.values.as_slice(), a.components))
            .collect();
        let values = self.density.interpolate(points, &fields);
        self.attributes
            .iter()
            .zip(values)
            .map(|(a, values)| Attribute {
                name: a.name.clone(),
                components: a.components,
                values,
            })
            .collect()
    }
}

/// One particle frame read: its density (the skin's target) and its particles, kept to
/// match the next frame's ([`crate::particles::motion`]).
pub struct ParticleFrame {
    /// The frame's density, rasterized on the skin's voxels: its target.
    pub density: DensityGrid,
    /// The particles read, those out of reach left out.
    pub particles: Particles,
    /// The density's velocities are each particle's motion since `before`, so the
    /// density is the frame's flow map ([`crate::flow::FlowMap`]).
    pub carried: bool,
    /// What the user should know about the frame: particles left out.
    pub note: Option<String>,
    /// The attributes asked for, when some were.
    pub attributes: Option<AttributeSource>,
    /// Spray particles.
    pub spray: Vec<Vec3>,
}

impl ParticleInput {
    /// Why these parameters cannot make a skin, if they cannot: the radius, smoothing
    /// length, iso and voxel size must be finite and positive, the velocity scale finite,
    /// and the voxel no coarser than the kernel's support (2 × smoothing length ×
    /// radius) — coarser, the density is sampled by less than a node per particle and
    /// the skin takes the shape of the voxels (a ball of radius 0.1 at `--voxel-size
    /// 1e4` became a blob of 6·10¹⁰ m³).
    pub fn check(&self) -> Result<(), FrameError> {
        let positive = |field: Field, v: f32| super::usage::positive(field, f64::from(v));
        positive(Field::Radius, self.radius)?;
        positive(Field::SmoothingLength, self.smoothing_length)?;
        // Before the iso, which is NaN past it.
        if self.smoothing_length > MAX_SMOOTHING_LENGTH {
            return Err(UsageError::SmoothingTooLong {
                value: self.smoothing_length,
            }
            .into());
        }
        positive(Field::Iso, self.iso)?;
        positive(Field::VoxelSize, self.dx)?;
        // Areas and tensions (β ∝ Δx²) must stay finite in 32-bit floats.
        for (field, value) in [(Field::Radius, self.radius), (Field::VoxelSize, self.dx)] {
            if value > MAX_LENGTH {
                return Err(UsageError::TooLong { field, value }.into());
            }
        }
        if let Some(k) = self.velocity_scale {
            super::usage::finite(Field::VelocityScale, f64::from(k))?;
        }
        if cfg!(not(feature = "vdb")) && self.density_out.is_some() {
            return Err(UsageError::FogWithoutVdb {
                field: Field::DensityOut,
            }
            .into());
        }
        let support = 2.0 * self.smoothing_length * self.radius;
        if self.dx > support {
            return Err(UsageError::CoarserThanKernel {
                voxel: self.dx,
                support,
            }
            .into());
        }
        Ok(())
    }

    /// Reads the particles of `frame` from `path` (once) and builds their density, with
    /// their velocities when the file has them and they are not ignored.
    pub fn target(&self, path: &Path, frame: i64) -> Result<DensityGrid, FrameError> {
        Ok(self.frame(path, frame, None, 0.0)?.density)
    }

    /// [`ParticleInput::target`], keeping the particles; given the particles of the frame
    /// `duration` seconds `before`, and velocities not ignored, their density carries
    /// each particle's mean velocity over that interval when the two frames match (ids,
    /// or an order the motion confirms), the saved velocities otherwise.
    pub fn frame(
        &self,
        path: &Path,
        frame: i64,
        before: Option<&Particles>,
        duration: f32,
    ) -> Result<ParticleFrame, FrameError> {
        // No particles is a frame without liquid, as an empty grid is.
        self.frame_of(particles::read(path)?, path, frame, before, duration)
    }

    /// [`ParticleInput::frame`] of particles already read (`path` names them in
    /// messages).
    pub fn frame_of(
        &self,
        mut cloud: Particles,
        path: &Path,
        frame: i64,
        before: Option<&Particles>,
        duration: f32,
    ) -> Result<ParticleFrame, FrameError> {
        // Stray particles beyond the grid's reach would snap to a lattice coarser than
        // its voxels: left out, and said (as are those of the frame they are matched to).
        let reach = REACH_VOXELS * self.dx;
        let far = cloud.keep_within(reach);
        if far > 0 && cloud.positions.is_empty() {
            return Err(UsageError::FarFromOrigin {
                path: path.into(),
                reach,
                voxel: self.dx,
            }
            .into());
        }
        // Copied only when it has some to leave out.
        let before: Option<Cow<Particles>> = before.map(|b| match b.within(reach) {
            true => Cow::Borrowed(b),
            false => {
                let mut b = b.clone();
                b.keep_within(reach);
                Cow::Owned(b)
            }
        });
        let before = before.as_deref();
        let attributes = self.chosen_attributes(path, &mut cloud)?;
        let note = (far > 0).then(|| {
            format!(
                "{}: {far} particle(s) more than {reach} from the origin left out (2^20 voxels of {}: farther, 32-bit coordinates do not resolve the voxels)",
                path.display(),
                self.dx
            )
        });
        let support = 2.0 * self.smoothing_length;
        let h = support * self.radius;
        let motion = match (before, self.velocity_scale) {
            (Some(before), Some(k)) => frame_velocities(before, &cloud, duration, Some(k), h),
            _ => None,
        };
        let carried = motion.is_some();
        let l = self.smoothing_length;
        let density = match &cloud.radii {
            Some(radii) if !self.ignore_radii => {
                let supports = radii.iter().map(|r| support * r).collect();
                Density::with_supports(cloud.positions.clone(), supports, self.iso)
            }
            _ => Density::new(cloud.positions.clone(), support * self.radius, self.iso),
        };
        let density = density.finding_spray(self.spray_reach().1, SPRAY_MOST);
        let density = match (motion, &cloud.velocities, self.velocity_scale) {
            (Some(u), ..) => density
                .with_velocities(&u)
                .normalized(l)
                .velocity_within(VELOCITY_SUPPORT_RADII, l),
            (None, Some(v), Some(k)) => {
                let scaled: Vec<Vec3> = v.iter().map(|&u| u * k).collect();
                density.normalized(l).with_velocities(&scaled)
            }
            _ => density.normalized(l),
        };
        let spray_points = density.spray_positions();
        let budget = crate::budget::bytes();
        let over = |needed| FrameError::OverBudget {
            path: path.into(),
            needed,
            voxel: self.dx,
            kernel: 2.0 * support * self.radius,
            budget,
        };
        let grid = DensityGrid::rasterize_within(&density, self.dx, budget, false).map_err(over)?;
        // The fog volume (OpenVDB only: check() refuses --density-out without it).
        #[cfg(not(feature = "vdb"))]
        let _ = frame;
        #[cfg(feature = "vdb")]
        if let Some(out) = &self.density_out {
            // Every node of it, summed again apart from the skin's compacted grid (the
            // skin never depends on what is written).
            let whole =
                DensityGrid::rasterize_within(&density, self.dx, budget, true).map_err(over)?;
            let fog = Grid::from_data(&whole.to_fog_volume())?;
            let meta = vdb::frame_metadata(frame);
            vdb::write_grids(&out.path(frame), &[(&fog, WriteOptions::default())], &meta)?;
        }
        Ok(ParticleFrame {
            density: grid,
            particles: cloud,
            carried,
            note,
            spray: spray_points,
            attributes: attributes.map(|attributes| AttributeSource {
                density,
                attributes,
            }),
        })
    }

    /// The attributes asked for, taken out of `cloud` (which is kept a frame to match
    /// the next: it need not carry them); `Err` names one the file does not hold.
    fn chosen_attributes(
        &self,
        path: &Path,
        cloud: &mut Particles,
    ) -> Result<Option<Vec<Attribute>>, FrameError> {
        let held = std::mem::take(&mut cloud.attributes);
        let names = match &self.attributes {
            AttributeChoice::None => return Ok(None),
            AttributeChoice::All => return Ok(Some(held)),
            AttributeChoice::Named(names) => names,
        };
        let mut chosen = Vec::with_capacity(names.len());
        for name in names {
            match held.iter().find(|a| a.name == *name) {
                Some(a) => chosen.push(a.clone()),
                None => {
                    return Err(DataError::NoAttribute {
                        path: path.into(),
                        name: name.clone(),
                        listed: held.iter().map(|a| a.name.clone()).collect(),
                    }
                    .into());
                }
            }
        }
        Ok(Some(chosen))
    }

    /// The volume below which an enclosed void of the density is filled when a skin
    /// starts on it ([`DensityGrid::fill_voids`]): a ball of the kernel's support.
    pub fn void_volume(&self) -> f32 {
        let h = 2.0 * self.smoothing_length * self.radius;
        4.0 / 3.0 * std::f32::consts::PI * h.powi(3)
    }
}
