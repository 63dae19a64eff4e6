//! Topology from the target: where the target has material and the skin is wholly
//! outside — new liquid from an emitter, a droplet the skin missed, a target that ran
//! away from it — the skin is seeded with the target's own surface there, so no target
//! component stays missing. (The paper's skin only changes topology by its own motion.)

use glam::{IVec3, Vec3};
use hashbrown::HashSet;
use rayon::prelude::*;

use super::Skin;
use crate::grid::{offset_coords, Potential, AROUND, BLOCK_DIM, BLOCK_NODES};
use crate::grid::{Aabb, IndexToWorld};
use crate::target::Target;

/// How far from a block's centre the target's surface may be for the block to hold part
/// of the band: its half-diagonal, the band and a voxel.
pub(super) fn block_reach(band_width: f32, dx: f32) -> f32 {
    (3.5 * 3f32.sqrt() + band_width + 1.0) * dx
}

/// The blocks around the target's bounds with the target's distance at each centre, in
/// coordinate order.
pub(super) fn classify_blocks(
    target: &dyn Target,
    xf: IndexToWorld,
    band_width: f32,
) -> Vec<(IVec3, f32)> {
    target_blocks(target, xf, band_width)
        .into_par_iter()
        .map(|c| (c, block_centre_distance(target, xf, c)))
        .collect()
}

/// The blocks of `target`'s parts, padded by the band and one block.
fn target_blocks(target: &dyn Target, xf: IndexToWorld, band_width: f32) -> Vec<IVec3> {
    blocks_around(&target.parts(), target.bounds(), xf, band_width)
}

/// The blocks of the boxes `parts` (within `bounds`), each padded by the band and one
/// block, once each, in coordinate order. Many parts that fill their bounds are
/// enumerated as the bounds, at once.
pub(super) fn blocks_around(
    parts: &[Aabb],
    bounds: Aabb,
    xf: IndexToWorld,
    band_width: f32,
) -> Vec<IVec3> {
    let (boxes, _) = block_boxes(parts, bounds, xf, band_width);
    let mut coords: Vec<IVec3> = boxes
        .into_iter()
        .flat_map(|(lo, hi)| {
            (lo.x..=hi.x).flat_map(move |x| {
                (lo.y..=hi.y).flat_map(move |y| (lo.z..=hi.z).map(move |z| IVec3::new(x, y, z)))
            })
        })
        .collect();
    coords.par_sort_unstable_by_key(|c| c.to_array());
    coords.dedup();
    coords
}

/// How many blocks [`blocks_around`] lists (at most; before removing repeats), known
/// before listing them: in f64, as a bounding box can hold more than an i64 counts.
pub(super) fn blocks_listed(target: &dyn Target, xf: IndexToWorld, band_width: f32) -> f64 {
    block_boxes(&target.parts(), target.bounds(), xf, band_width).1
}

/// The index boxes of blocks [`blocks_around`] lists, with their total count.
fn block_boxes(
    parts: &[Aabb],
    bounds: Aabb,
    xf: IndexToWorld,
    band_width: f32,
) -> (Vec<(IVec3, IVec3)>, f64) {
    let dx = xf.dx;
    let side = dx * BLOCK_DIM as f32;
    let range = |b: Aabb| {
        let b = b.padded((band_width + 2.0) * dx);
        let lo = ((b.min - xf.origin) / side).floor().as_ivec3() - IVec3::ONE;
        let hi = ((b.max - xf.origin) / side).ceil().as_ivec3() + IVec3::ONE;
        (lo, hi)
    };
    let count = |(lo, hi): (IVec3, IVec3)| {
        let n = (hi.as_dvec3() - lo.as_dvec3() + 1.0).max(glam::DVec3::ZERO);
        n.x * n.y * n.z
    };
    let boxes: Vec<(IVec3, IVec3)> = parts.iter().map(|&b| range(b)).collect();
    let whole = range(bounds);
    let listed: f64 = boxes.iter().map(|&r| count(r)).sum();
    if listed >= count(whole) {
        (vec![whole], count(whole))
    } else {
        (boxes, listed)
    }
}

/// The target's distance at the centre of block `c`.
fn block_centre_distance(target: &dyn Target, xf: IndexToWorld, c: IVec3) -> f32 {
    target.distance(xf.apply((c * BLOCK_DIM).as_vec3() + Vec3::splat(3.5)))
}

impl<P: Potential> Skin<P> {
    /// Seeds the skin where `target` has material and the skin has none within a block
    /// (8 voxels) around: each such block takes the smaller of the skin's potential and
    /// the target's distance. Returns the number of blocks seeded (then the tube and the
    /// mesh are rebuilt).
    pub fn seed(&mut self, target: &dyn Target) -> usize {
        let (dx, w) = (self.params.dx, self.params.band_width);
        let reach = block_reach(w, dx);
        // Blocks where the skin has material: a stored block with a node inside, or an
        // inside tile.
        let occupied: HashSet<IVec3> = self
            .grid
            .blocks()
            .par_iter()
            .filter(|b| b.values.iter().any(|v| v.to_f32() < 0.0))
            .map(|b| b.coord)
            .collect::<Vec<_>>()
            .into_iter()
            .chain(self.grid.inside_tiles().iter().copied())
            .collect();
        let near_skin = |c: IVec3| AROUND.iter().any(|&d| occupied.contains(&(c + d)));
        let xf = self.xf;
        let wanted: Vec<(IVec3, Box<[f32; BLOCK_NODES]>)> = target_blocks(target, xf, w)
            .into_par_iter()
            .filter(|&c| {
                let corner = |k: i32| xf.apply((c * BLOCK_DIM + IVec3::splat(k)).as_vec3());
                let region = Aabb {
                    min: corner(0),
                    max: corner(BLOCK_DIM - 1),
                };
                !near_skin(c)
                    && target.may_be_inside(region)
                    && block_centre_distance(target, xf, c) <= reach
            })
            .filter_map(|c| {
                let base = c * BLOCK_DIM;
                let mut values = Box::new([0.0f32; BLOCK_NODES]);
                let mut material = false;
                for (offset, v) in values.iter_mut().enumerate() {
                    let d = target.distance(xf.apply((base + offset_coords(offset)).as_vec3()));
                    material |= d < 0.0;
                    *v = (d / (w * dx)).clamp(-1.0, 1.0);
                }
                material.then_some((c, values))
            })
            .collect();
        if wanted.is_empty() {
            return 0;
        }
        for (c, values) in &wanted {
            let id = self.grid.touch(*c);
            let block = &mut self.grid.blocks_mut()[id.0 as usize];
            for (v, &t) in block.values.iter_mut().zip(values.iter()) {
                if t < v.to_f32() {
                    *v = P::from_f32(t);
                }
            }
        }
        // As at a start: every crossed cell stored, its corners in the band.
        for _ in 0..4 {
            let missing = super::band::unstored_crossed(&self.grid);
            if missing.is_empty() {
                break;
            }
            for c in missing {
                self.grid.touch(c);
            }
        }
        super::band::clamp_at_crossings(&mut self.grid, w, &mut self.rates);
        crate::grid::tube::upkeep(&mut self.grid);
        // The seeds hold the target's own distance estimate (first order for densities):
        // made a distance like the rest of the band before anything reads or writes it.
        for _ in 0..3 {
            super::band::renormalize(&mut self.grid, w, 0.0, &mut self.rates);
            crate::grid::tube::upkeep(&mut self.grid);
        }
        self.polygonize();
        wanted.len()
    }
}
