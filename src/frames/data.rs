//! Inputs a run cannot use and outputs it cannot write, found as it goes (a frame
//! missing, a grid too far from the origin, a folder it cannot create):
//! [`FrameError::Data`](super::FrameError::Data). Each holds what it is about — the
//! path, the grid, the frame — and the cause, where there is one, as its source.

use std::path::PathBuf;

use crate::field::Field;
use crate::skin::{SkinError, Stopped};

/// What the files or the run's state do not allow.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A path that is there but is not a regular file (a folder, a pipe), or unreadable.
    #[error("{}: {why}", path.display())]
    NotAFile { path: PathBuf, why: String },
    /// A sequence's folder that cannot be listed.
    #[error("cannot list the folder of {field} '{spec}': {reason}")]
    Unlistable {
        field: Field,
        spec: String,
        reason: String,
    },
    /// A target frame missing, and none before it to hold.
    #[error("{}: missing, and no earlier target to hold", path.display())]
    NothingToHold { path: PathBuf },
    /// A target frame missing, and not to be held.
    #[error(
        "{}: frame {frame} of the target is missing ({} keeps the last target)",
        path.display(),
        Field::HoldMissing
    )]
    MissingTarget { path: PathBuf, frame: i64 },
    /// A particle frame missing.
    #[error("{}: frame {frame} of the particles is missing", path.display())]
    MissingParticles { path: PathBuf, frame: i64 },
    /// A frame the caller did not hand particles for.
    #[error("frame {frame}: no particles")]
    NoParticlesHanded { frame: i64 },
    /// A particle attribute asked for that the file does not have.
    #[error(
        "{}: no particle attribute '{}' ({})",
        path.display(),
        crate::io::printable(name, 80),
        attributes_listed(listed)
    )]
    NoAttribute {
        path: PathBuf,
        name: String,
        /// The attributes the file has.
        listed: Vec<String>,
    },
    /// A grid whose voxels are not cubes.
    #[error(
        "{}: grid '{grid}' has a non-uniform or non-linear transform; resample it to cubic voxels",
        path.display()
    )]
    NonUniform { path: PathBuf, grid: String },
    /// A grid too far from the origin for 32-bit positions to resolve its voxels.
    #[error(
        "{}: grid '{grid}' lies {farthest:.4e} from the origin, {:.2e} voxels of {dx:.3e}: past 2^20 voxels, 32-bit positions do not resolve a voxel; move it nearer the origin or use larger voxels",
        path.display(),
        farthest / dx
    )]
    FarFromOrigin {
        path: PathBuf,
        grid: String,
        farthest: f64,
        dx: f64,
    },
    /// A grid holding NaN or infinite values.
    #[error("{}: grid '{grid}' holds NaN or infinite values", path.display())]
    NotFinite { path: PathBuf, grid: String },
    /// A velocity grid asked for by name that the file does not have.
    #[cfg(feature = "vdb")]
    #[error(
        "{}: no velocity grid named '{name}' (grids: {})",
        path.display(),
        grids_listed(grids)
    )]
    NoVelocityGrid {
        path: PathBuf,
        name: String,
        /// The file's grids: name and value type.
        grids: Vec<(String, String)>,
    },
    /// Velocity files given, none holding a grid of a velocity's usual names.
    #[cfg(feature = "vdb")]
    #[error(
        "{}: no velocity grid named {} (grids: {}); name it with {}",
        path.display(),
        super::VELOCITY_NAMES.join(", "),
        grids_listed(grids),
        Field::Velocity
    )]
    NoVelocityFound {
        path: PathBuf,
        /// The file's grids: name and value type.
        grids: Vec<(String, String)>,
    },
    /// A velocity grid whose voxels are not cubes.
    #[cfg(feature = "vdb")]
    #[error(
        "{}: velocity grid '{name}' has a non-uniform or non-linear transform",
        path.display()
    )]
    VelocityNonUniform { path: PathBuf, name: String },
    /// A collider mesh with no inside.
    #[error("{}: the collider is {source}", path.display())]
    ColliderNotClosed {
        path: PathBuf,
        #[source]
        source: crate::target::OpenMesh,
    },
    /// A collider file missing.
    #[error("{}: the collider is missing (frame {frame})", path.display())]
    MissingCollider { path: PathBuf, frame: i64 },
    /// A stats file to resume that is not one.
    #[error("{}: not a stats file (one JSON object per line)", path.display())]
    NotStats { path: PathBuf },
    /// An output folder that cannot be made.
    #[error("{}: cannot create the output folder: {source}", folder.display())]
    CreateFolder {
        folder: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A skin VDB to resume from that cannot be read.
    #[cfg(feature = "vdb")]
    #[error("{source}; cannot resume from it, delete it to recompute that frame")]
    ResumeUnreadable {
        #[source]
        source: crate::vdb::VdbError,
    },
    /// A skin VDB to resume from that is not this skin's.
    #[error("{}: cannot resume from it: {source}", path.display())]
    ResumeIncompatible {
        path: PathBuf,
        #[source]
        source: SkinError,
    },
    /// A frame that would take more sub-steps than the run allows.
    #[error("frame {frame} ({duration:.3e} s at {fps} fps) {stopped}")]
    TooManySubsteps {
        frame: i64,
        duration: f64,
        fps: f64,
        stopped: Stopped,
    },
    /// The caller handed no more frames.
    #[error("no more frames")]
    NoMoreFrames,
    /// The frame loop's thread could not be started.
    #[error("cannot start the frame loop: {source}")]
    LoopNotStarted {
        #[source]
        source: std::io::Error,
    },
    /// The frame loop is gone.
    #[error("the frame loop has stopped")]
    LoopStopped,
    /// The skin stopped on an error, said when it happened; asked again.
    #[error("the skin stopped: {why}")]
    SkinStopped { why: String },
}

fn attributes_listed(listed: &[String]) -> String {
    match listed.is_empty() {
        true => "the file has none besides positions, radii, velocities and ids".to_string(),
        false => format!("attributes: {}", listed.join(", ")),
    }
}

#[cfg(feature = "vdb")]
fn grids_listed(grids: &[(String, String)]) -> String {
    let listed: Vec<String> = grids.iter().map(|(g, t)| format!("'{g}' ({t})")).collect();
    match listed.is_empty() {
        true => "none".to_string(),
        false => listed.join(", "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error;

    #[test]
    fn each_says_what_it_is_about_and_keeps_its_cause() {
        let none = DataError::NoAttribute {
            path: "a.ply".into(),
            name: "temperature".into(),
            listed: vec![],
        };
        assert_eq!(
            none.to_string(),
            "a.ply: no particle attribute 'temperature' (the file has none besides positions, radii, velocities and ids)"
        );
        let some = DataError::NoAttribute {
            path: "a.ply".into(),
            name: "temperature".into(),
            listed: vec!["density".into(), "vorticity".into()],
        };
        assert!(some
            .to_string()
            .ends_with("(attributes: density, vorticity)"));
        let folder = DataError::CreateFolder {
            folder: "/out".into(),
            source: std::io::Error::from(std::io::ErrorKind::PermissionDenied),
        };
        assert_eq!(
            folder.to_string(),
            "/out: cannot create the output folder: permission denied"
        );
        assert!(folder.source().is_some());
        // Said once on the command line, the cause within the message.
        assert_eq!(crate::io::error_chain(&folder), folder.to_string());
    }
}
