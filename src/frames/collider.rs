//! `--collider`: what the liquid meets ([`crate::target::meet_collider`]), read for the
//! outputs: a VDB level set or a closed OBJ mesh (made a level set at the skin's voxel by
//! OpenVDB's meshToLevelSet), one file for the whole shot or one a frame.

use std::path::PathBuf;
use std::sync::Arc;

use super::usage::non_negative;
use super::{DataError, FrameError, UsageError};
use crate::field::Field;
use crate::sequence::FramePattern;
use crate::target::{liquid_origin, meet_collider, ColliderGrid, MeshShape, Target};
use crate::volume::GridData;

/// The collider's files.
#[derive(Debug, Clone)]
pub enum ColliderFiles {
    /// One file for every frame (a static tank, an obstacle at rest).
    One(PathBuf),
    /// One file a frame (a moving obstacle).
    Frames(FramePattern),
}

/// What the liquid meets, and how.
#[derive(Debug, Clone)]
pub struct ColliderSpec {
    /// A VDB level set (.vdb, its first float grid) or a closed OBJ mesh.
    pub files: ColliderFiles,
    /// How near the skin must come (world units) to be carried on to the collider; `None`:
    /// [`DEFAULT_GAP_VOXELS`] voxels.
    pub gap: Option<f32>,
    /// How far into the collider the liquid runs (world units): 0 meets its face.
    pub depth: f32,
}

/// The gap when none is given, in voxels: past the shell a particle skin closes about a
/// radius (two voxels at its default voxel) off a wall.
pub const DEFAULT_GAP_VOXELS: f32 = 4.0;

/// A particle skin's gap when none is given, in particle radii: SPH solvers keep their
/// particles about two radii off a wall, and the skin closes a radius past them.
pub const PARTICLE_GAP_RADII: f32 = 3.0;

impl ColliderSpec {
    /// `files` (a file, or a frame pattern with `#`), checked as every front end takes it:
    /// a gap and a depth of zero or more world units.
    pub fn new(files: &str, gap: Option<f32>, depth: f32) -> Result<Self, FrameError> {
        for (field, value) in [
            (Field::ColliderGap, gap.unwrap_or(0.0)),
            (Field::ColliderDepth, depth),
        ] {
            non_negative(field, f64::from(value))?;
        }
        let files = match FramePattern::parse(files) {
            Ok(pattern) => ColliderFiles::Frames(pattern),
            Err(_) => ColliderFiles::One(PathBuf::from(files)),
        };
        Ok(ColliderSpec { files, gap, depth })
    }

    /// A particle skin's: past the shell it closes about a radius off a wall, so the gap,
    /// when not given, is [`PARTICLE_GAP_RADII`] radii.
    pub fn for_particles(mut self, radius: f32) -> Self {
        self.gap.get_or_insert(PARTICLE_GAP_RADII * radius);
        self
    }

    /// The file of `frame`.
    fn path(&self, frame: i64) -> PathBuf {
        match &self.files {
            ColliderFiles::One(path) => path.clone(),
            ColliderFiles::Frames(pattern) => pattern.path(frame),
        }
    }

    /// Checked before the run: a kind of file it can read (a VDB with OpenVDB).
    pub fn check(&self) -> Result<(), FrameError> {
        let path = self.path(0);
        match extension(&path).as_deref() {
            Some("vdb") if cfg!(not(feature = "vdb")) => Err(UsageError::ColliderWithoutVdb.into()),
            Some("vdb") | Some("obj") => Ok(()),
            _ => Err(UsageError::ColliderKind { path }.into()),
        }
    }
}

fn extension(path: &std::path::Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// The collider of each frame, read once for a static one, and its distance at the
/// skin's nodes kept while it stays.
pub(crate) struct Colliders {
    spec: ColliderSpec,
    /// The last read: its file and voxel size, and the collider.
    read: Option<(PathBuf, f32, Arc<dyn Target>)>,
    grid: Option<ColliderGrid>,
}

impl Colliders {
    pub(crate) fn new(spec: ColliderSpec) -> Self {
        Colliders {
            spec,
            read: None,
            grid: None,
        }
    }

    /// The collider at `frame` for a skin of voxel `dx`.
    fn at(&mut self, frame: i64, dx: f32) -> Result<Arc<dyn Target>, FrameError> {
        let path = self.spec.path(frame);
        if let Some((read, at, collider)) = &self.read {
            if *read == path && *at == dx {
                return Ok(collider.clone());
            }
        }
        if !path.is_file() {
            return Err(DataError::MissingCollider { path, frame }.into());
        }
        // A mesh's distance exact past the gap, the depth and a block's half diagonal.
        let reach = self.gap(dx).max(self.spec.depth) + 8.0 * dx;
        let collider = read(&path, reach)?;
        self.read = Some((path, dx, collider.clone()));
        Ok(collider)
    }

    /// The settled `level_set` of `frame` meeting its collider
    /// ([`crate::target::meet_collider`]); `None` where it comes nowhere near.
    pub(crate) fn meet(
        &mut self,
        frame: i64,
        level_set: &GridData,
    ) -> Result<Option<GridData>, FrameError> {
        let dx = level_set.transform.voxel_size() as f32;
        let collider = self.at(frame, dx)?;
        let origin = liquid_origin(level_set);
        let gap = self.gap(dx);
        let grid = match self.grid.take() {
            Some(grid) if grid.is_on(&collider, origin, dx, gap) => grid,
            _ => ColliderGrid::new(collider, origin, dx, gap),
        };
        let grid = self.grid.insert(grid);
        Ok(meet_collider(level_set, grid, gap, self.spec.depth))
    }

    /// The gap for a skin of voxel `dx`.
    fn gap(&self, dx: f32) -> f32 {
        self.spec.gap.unwrap_or(DEFAULT_GAP_VOXELS * dx)
    }
}

/// A collider file as a signed distance: a closed OBJ mesh as it is (exact within
/// `reach` of its surface, [`MeshShape`]), a VDB level set read with OpenVDB.
fn read(path: &std::path::Path, reach: f32) -> Result<Arc<dyn Target>, FrameError> {
    if extension(path).as_deref() == Some("obj") {
        let mesh = crate::io::obj::read(path)?;
        let shape = MeshShape::new(&mesh.positions, &mesh.triangles, reach).map_err(|source| {
            DataError::ColliderNotClosed {
                path: path.to_owned(),
                source,
            }
        })?;
        return Ok(Arc::new(shape));
    }
    read_vdb(path)
}

#[cfg(feature = "vdb")]
fn read_vdb(path: &std::path::Path) -> Result<Arc<dyn Target>, FrameError> {
    let data = crate::vdb::Grid::read(path, None)?.to_data()?;
    let read = super::target_from_grid(path, data, None, super::TargetUnits::Auto)?;
    Ok(Arc::from(read.target))
}

#[cfg(not(feature = "vdb"))]
fn read_vdb(_: &std::path::Path) -> Result<Arc<dyn Target>, FrameError> {
    Err(UsageError::ColliderWithoutVdb.into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_collider_is_a_vdb_read_with_openvdb_or_a_closed_obj() {
        let spec = |name: &str| ColliderSpec {
            files: ColliderFiles::One(name.into()),
            gap: None,
            depth: 0.0,
        };
        let said = |name: &str| spec(name).check().map_err(|e| e.to_string());
        assert!(said("Tank.OBJ").is_ok());
        assert!(said("tank.stl")
            .unwrap_err()
            .contains("a collider is a VDB level set"));
        match cfg!(feature = "vdb") {
            true => assert!(said("tank.vdb").is_ok()),
            false => assert!(said("tank.vdb")
                .unwrap_err()
                .contains("as a VDB needs the `vdb` feature")),
        }
    }

    #[test]
    fn an_open_obj_is_one_line() {
        let dir = std::env::temp_dir().join(format!("activeskin-open-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("lid.obj");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let said = read(&path, 0.1).err().unwrap().to_string();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(
            said.contains("lid.obj: the collider is not a closed mesh: 3 of its edges"),
            "{said}"
        );
    }
}
