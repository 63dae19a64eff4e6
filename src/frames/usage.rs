//! Requests that no files can satisfy (a setting out of its range, a pattern that names
//! no sequence, outputs that collide): [`FrameError::Usage`](super::FrameError::Usage).
//! Each says the settings it is about as [`Field`]s, which every front end spells its
//! own way (the command line `--radius`, Python `radius=`).

use std::fmt;
use std::path::PathBuf;

use crate::field::Field;
use crate::sequence::{FramePattern, PatternError};
use crate::target::MAX_SMOOTHING_LENGTH;

/// What is wrong with the request.
#[derive(Debug, thiserror::Error)]
pub enum UsageError {
    /// A setting that must be a finite positive number.
    #[error("{field} must be a positive number, got {}", Number(*value))]
    NotPositive { field: Field, value: f64 },
    /// A setting that must be a finite number.
    #[error("{field} must be a number, got {}", Number(*value))]
    NotANumber { field: Field, value: f64 },
    /// A length that must be a finite number, zero or more.
    #[error("{field} must be a number of world units, zero or more, got {}", Number(*value))]
    Negative { field: Field, value: f64 },
    /// A length past what 32-bit floats hold the areas of.
    #[error(
        "{field} {value} is beyond {:e} world units: 32-bit floats cannot hold the areas of such voxels",
        super::inputs::MAX_LENGTH
    )]
    TooLong { field: Field, value: f32 },
    /// A kernel wider than the density can sum.
    #[error(
        "{} {value} is beyond {MAX_SMOOTHING_LENGTH} radii (some 17 000 neighbours a particle)",
        Field::SmoothingLength
    )]
    SmoothingTooLong { value: f32 },
    /// Voxels coarser than the particles' kernel.
    #[error(
        "{} {voxel} is coarser than the particles' kernel (support {support}): at most that; the default, radius/2, resolves them",
        Field::VoxelSize
    )]
    CoarserThanKernel { voxel: f32, support: f32 },
    /// Particles all too far from the origin for the voxels.
    #[error(
        "{}: every particle lies more than {reach} from the origin, where 32-bit coordinates do not resolve voxels of {voxel}: give a larger voxel size",
        path.display()
    )]
    FarFromOrigin {
        path: PathBuf,
        reach: f32,
        voxel: f32,
    },
    /// A frame range whose first frame comes after its last.
    #[error(
        "{} {first}-{last} is empty: the first frame comes after the last",
        Field::Frames
    )]
    EmptyRange { first: i64, last: i64 },
    /// One file given as a sequence without the frames to hold it over.
    #[error(
        "{field} '{spec}' is one file, not a sequence: give {} FIRST-LAST to hold it that long",
        Field::Frames
    )]
    OneFile { field: Field, spec: String },
    /// Neither a file nor a frame pattern.
    #[error("{field} '{spec}': no such file, and no frame number for a sequence (use ####, %04d, $F4, $F or {{}})")]
    NotASequence { field: Field, spec: String },
    /// A frame pattern that cannot be used.
    #[error(transparent)]
    Pattern(PatternError),
    /// A sequence with no file.
    #[error("no file matches {field} '{spec}'")]
    NoMatch { field: Field, spec: String },
    /// A fog volume given without the density of its surface.
    #[error(
        "{}: grid '{grid}' is not a level set: give {}, the density of its surface",
        path.display(),
        Field::Iso
    )]
    NotALevelSet { path: PathBuf, grid: String },
    /// A dense grid whose values do not fill its dimensions.
    #[error("a grid of {dims:?} voxels needs {voxels} values, got {got}")]
    GridValues {
        dims: [usize; 3],
        voxels: usize,
        got: usize,
    },
    /// A volume reference frame after the run's first frame.
    #[error("the volume's reference frame {reference} must come before the first frame, {first}")]
    ReferenceAfterFirst { reference: i64, first: i64 },
    /// A frame outside the USD shot it is written into.
    #[error("frame {frame} is not one of the shot's frames, {first}-{last}")]
    FrameOutsideShot { frame: i64, first: i64, last: i64 },
    /// VDB output from a build without OpenVDB.
    #[error("{field} writes VDB fog volumes: this activeskin was built without OpenVDB (the `vdb` feature)")]
    FogWithoutVdb { field: Field },
    /// Skin VDBs asked of a build without OpenVDB.
    #[error(
        "{} writes VDB files: this activeskin was built without OpenVDB (the `vdb` feature); write {} instead",
        Field::Out,
        Field::Mesh
    )]
    SkinWithoutVdb,
    /// No output asked for.
    #[error(
        "nothing to write: give {}, {}, {}, {} or {}",
        Field::Out,
        Field::Mesh,
        Field::Usd,
        Field::Render,
        Field::Stats
    )]
    NothingToWrite,
    /// A resume without the skin VDBs it continues from.
    #[error(
        "{} needs {}: it continues from the last skin VDB written there",
        Field::Resume,
        Field::Out
    )]
    ResumeWithoutOut,
    /// An output pattern with the wrong extension.
    #[error("{field} '{pattern}': {what} must end in .{}", extensions.join(" or ."))]
    Extension {
        field: Field,
        pattern: FramePattern,
        what: &'static str,
        extensions: Vec<&'static str>,
    },
    /// An output that would overwrite an input.
    #[error("{field} would overwrite the input {}: write elsewhere", input.display())]
    OverwritesInput { field: Field, input: PathBuf },
    /// Two outputs writing one file.
    #[error("{first} and {second} would both write {}", path.display())]
    SameOutput {
        first: Field,
        second: Field,
        path: PathBuf,
    },
    /// A USD stage named for a binary layer.
    #[error("{} '{}': activeskin writes USD as text, name the stage .usda or .usd (Pixar's usdcat turns it into .usdc)", Field::Usd, stage.display())]
    UsdBinary { stage: PathBuf },
    /// A USD stage with another extension.
    #[error("{} '{}': a USD stage must end in .usda or .usd", Field::Usd, stage.display())]
    UsdExtension { stage: PathBuf },
    /// A USD stage whose name its layers' names cannot hold.
    #[error("{} '{}': the stage's name cannot hold @ \" # % $ or \\ (its frames' layers are named after it)", Field::Usd, stage.display())]
    UsdName { stage: PathBuf },
    /// A VDB collider without OpenVDB (an OBJ mesh needs none).
    #[error(
        "{} as a VDB needs the `vdb` feature (activeskin built with OpenVDB); a closed OBJ mesh does not",
        Field::Collider
    )]
    ColliderWithoutVdb,
    /// A collider file of a kind that cannot be one.
    #[error("{} '{}': a collider is a VDB level set (.vdb) or a closed OBJ mesh (.obj)", Field::Collider, path.display())]
    ColliderKind { path: PathBuf },
    /// A region that holds nothing.
    #[error(
        "{} must be a box with finite corners, the first below the second on every axis, got {}",
        Field::Region,
        given
    )]
    EmptyRegion { given: String },
    /// A USD shot that does not hold the frames written.
    #[error(
        "{} {}-{} must hold the frames written, {}-{}",
        Field::ShotFrames,
        shot.0,
        shot.1,
        written.0,
        written.1
    )]
    ShotTooShort {
        shot: (i64, i64),
        written: (i64, i64),
    },
}

/// A setting's value as it was given: shortest for the 32-bit floats most settings are
/// (`0.1`, not `0.10000000149011612`).
struct Number(f64);

impl fmt::Display for Number {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let single = self.0 as f32;
        match f64::from(single) == self.0 || self.0.is_nan() {
            true => write!(f, "{single}"),
            false => write!(f, "{}", self.0),
        }
    }
}

/// `value` unless it is a finite number.
pub(crate) fn finite(field: Field, value: f64) -> Result<(), UsageError> {
    match value.is_finite() {
        true => Ok(()),
        false => Err(UsageError::NotANumber { field, value }),
    }
}

/// `value` unless it is a finite number, zero or more.
pub(crate) fn non_negative(field: Field, value: f64) -> Result<(), UsageError> {
    match value.is_finite() && value >= 0.0 {
        true => Ok(()),
        false => Err(UsageError::Negative { field, value }),
    }
}

/// `value` unless it is a finite positive number.
pub(crate) fn positive(field: Field, value: f64) -> Result<(), UsageError> {
    match value.is_finite() && value > 0.0 {
        true => Ok(()),
        false => Err(UsageError::NotPositive { field, value }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_setting_is_said_as_it_was_given() {
        let said = |value: f64| {
            UsageError::NotPositive {
                field: Field::Radius,
                value,
            }
            .to_string()
        };
        assert_eq!(
            said(f64::from(-0.1f32)),
            "`radius` must be a positive number, got -0.1"
        );
        assert_eq!(said(-0.1), "`radius` must be a positive number, got -0.1");
        assert_eq!(
            said(f64::NAN),
            "`radius` must be a positive number, got NaN"
        );
        assert!(positive(Field::Fps, 24.0).is_ok());
        assert!(positive(Field::Fps, f64::INFINITY).is_err());
    }
}
