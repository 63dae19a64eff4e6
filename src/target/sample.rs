//! A target sampled into a VDB narrow-band level set: fixtures, sample data, references.

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use super::Target;
use crate::grid::offset_coords;
use crate::volume::{GridClass, GridData, Tile, Transform, LEAF_VOXELS, MASK_WORDS};

/// The target's distance on voxels of `dx` (origin at world zero), active within
/// `half_width` voxels of the surface, clamped to ± the background `half_width·dx`
/// beyond; blocks wholly inside become inactive tiles. Exact where the target's distance is.
pub fn level_set(target: &dyn Target, dx: f32, half_width: f32) -> GridData {
    let background = crate::volume::narrow_band_background(half_width, dx);
    let bounds = target.bounds().padded(background + 2.0 * dx);
    let leaf = 8.0 * dx;
    let lo = (bounds.min / leaf).floor().as_ivec3() - IVec3::ONE;
    let hi = (bounds.max / leaf).ceil().as_ivec3() + IVec3::ONE;
    let coords: Vec<IVec3> = (lo.x..=hi.x)
        .flat_map(|x| {
            (lo.y..=hi.y).flat_map(move |y| (lo.z..=hi.z).map(move |z| IVec3::new(x, y, z)))
        })
        .collect();
    // A leaf whose centre is farther than its half-diagonal plus the band holds no
    // active voxel: a tile if inside, nothing if outside.
    let reach = 3.5 * 3f32.sqrt() * dx + background + dx;
    enum Sampled {
        Leaf(IVec3, Box<[f32; LEAF_VOXELS]>, [u64; MASK_WORDS]),
        Inside(IVec3),
        Outside,
    }
    let sampled: Vec<Sampled> = coords
        .par_iter()
        .map(|&c| {
            let origin = c * 8;
            let centre = (origin.as_vec3() + Vec3::splat(3.5)) * dx;
            let d = target.distance(centre);
            if d > reach {
                return Sampled::Outside;
            }
            if d < -reach {
                return Sampled::Inside(origin);
            }
            let mut values = Box::new([0.0f32; LEAF_VOXELS]);
            let mut mask = [0u64; MASK_WORDS];
            for (offset, v) in values.iter_mut().enumerate() {
                let l = offset_coords(offset);
                let d = target.distance((origin + l).as_vec3() * dx);
                *v = d.clamp(-background, background);
                if d.abs() < background {
                    mask[offset >> 6] |= 1 << (offset & 63);
                }
            }
            if mask.iter().all(|&w| w == 0) {
                return if values[0] < 0.0 {
                    Sampled::Inside(origin)
                } else {
                    Sampled::Outside
                };
            }
            Sampled::Leaf(origin, values, mask)
        })
        .collect();
    let transform = Transform::uniform(f64::from(dx), [0.0; 3]);
    let mut data = GridData::empty("surface", GridClass::LevelSet, background, transform);
    for s in sampled {
        match s {
            Sampled::Leaf(origin, values, mask) => {
                data.push_leaf(origin.to_array(), &values[..], mask)
            }
            Sampled::Inside(origin) => data.tiles.push(Tile {
                origin: origin.to_array(),
                dim: 8,
                value: -background,
                active: false,
            }),
            Sampled::Outside => {}
        }
    }
    data
}
