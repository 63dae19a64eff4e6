//! Level-set and fog targets from grids in memory, whichever file or array they came
//! from: checked, in world units, outside beyond their voxels. A VDB file's grid
//! ([`super::read_target_in`]) and a dense array handed over by the Python API go through
//! the same steps, so both give the same skin.

use std::path::Path;

use rayon::prelude::*;

use super::{DataError, FrameError, UsageError};
use crate::field::Field;
use crate::target::{FogTarget, LevelSetTarget, Target};
use crate::volume::{units, GridClass, GridData, Transform};

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

/// A target as [`read_target_in`] reads it.
pub struct TargetRead {
    /// The frame's target, as the skin reads it.
    pub target: Box<dyn Target>,
    /// The grid's voxel size.
    pub dx: f32,
    /// What was done to the level set's distances, when anything was.
    pub note: Option<String>,
}

/// The target a grid holds (a level set, or a fog volume at density `iso`), `path` naming
/// it in messages; a level set in other units made world units ([`TargetUnits::Auto`]).
pub fn target_from_grid(
    path: &Path,
    mut data: GridData,
    iso: Option<f32>,
    units: TargetUnits,
) -> Result<TargetRead, FrameError> {
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
            return Err(UsageError::NotANumber {
                field: Field::Iso,
                value: f64::from(iso),
            }
            .into())
        }
        (_, None) => {
            return Err(UsageError::NotALevelSet {
                path: path.into(),
                grid: data.name.clone(),
            }
            .into())
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
pub(super) fn to_world_units(data: &mut GridData, units: TargetUnits) -> Option<String> {
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
                    "grid '{name}': distances in voxels (|∇φ| {k:.1} per world unit, Δx = {dx}); rescaled to world units ({} world keeps them)",
                    Field::TargetUnits
                )),
            ),
            Some(k) => (
                (1.0 / k) as f32,
                Some(format!(
                    "grid '{name}': |∇φ| is {} per world unit, not 1; distances rescaled by {} ({} world keeps them)",
                    readable(k),
                    readable(1.0 / k),
                    Field::TargetUnits
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
        return Err(DataError::NonUniform {
            path: path.into(),
            grid: data.name.clone(),
        }
        .into());
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
        return Err(DataError::FarFromOrigin {
            path: path.into(),
            grid: data.name.clone(),
            farthest,
            dx,
        }
        .into());
    }
    Ok(())
}

/// The error of a grid holding a value that is not a finite number.
pub fn not_finite(path: &Path, data: &GridData) -> FrameError {
    DataError::NotFinite {
        path: path.into(),
        grid: data.name.clone(),
    }
    .into()
}

/// A dense block of values (C order: `values[(i·ny + j)·nz + k]` at voxel (i, j, k)), as a
/// simulation or numpy holds a grid, voxel (0,0,0) centred at `origin`: a level set, or
/// a fog volume's densities. Past the block is outside: a level set's padding is its
/// largest value (at least 3 voxels), so that liquid touching the block's faces is closed
/// there, as a Mantaflow `phi` is; a fog volume's is 0.
pub fn dense_grid(
    class: GridClass,
    (dims, values): ([usize; 3], &[f32]),
    spacing: f32,
    origin: [f64; 3],
) -> Result<GridData, FrameError> {
    let voxels: usize = dims.iter().product();
    if values.len() != voxels || voxels == 0 {
        return Err(UsageError::GridValues {
            dims,
            voxels,
            got: values.len(),
        }
        .into());
    }
    super::usage::positive(Field::Spacing, f64::from(spacing))?;
    let (name, outside) = match class {
        GridClass::LevelSet => (
            "phi",
            values
                .iter()
                .fold(3.0 * spacing, |m, &v| if v > m { v } else { m }),
        ),
        _ => ("density", 0.0),
    };
    let transform = Transform::uniform(f64::from(spacing), origin);
    Ok(GridData::from_dense(
        name,
        class,
        (dims, values),
        transform,
        outside,
    ))
}
