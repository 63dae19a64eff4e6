//! Topology from the target: where the target has material and the skin is wholly
//! outside — new liquid from an emitter, a droplet the skin missed, a target that ran
//! away from it — the skin is seeded with the target's own surface there, so no target
//! component stays missing. (The paper's skin only changes topology by its own motion.)

use glam::{IVec3, Vec3};
use hashbrown::HashSet;
use rayon::prelude::*;

use super::Skin;
use crate::grid::{node_in_block, offset_coords, Potential, AROUND, BLOCK_DIM, BLOCK_NODES};
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

/// How far outside the skin (voxels) every node of a target piece must lie for the
/// piece to count as one the skin lost: a droplet torn off beyond what the skin's tension
/// holds, within a block of the skin. A piece closer than that, or joined through the
/// target's material to where the skin is, is the attraction's to reach.
const LOST_VOXELS: f32 = 1.0;

/// A block's node values as seeds: the smaller of the skin's and the seed's is kept.
type Seeds = Vec<(IVec3, Box<[f32; BLOCK_NODES]>)>;

impl<P: Potential> Skin<P> {
    /// Seeds the skin with the target's pieces it has none of: blocks where the target
    /// has material and the skin none within a block (8 voxels) around, and, within
    /// that block, target pieces wholly [`LOST_VOXELS`] outside the skin (a droplet it
    /// lost). Each seeded node takes the smaller of the skin's potential and the target's
    /// distance. Returns the number of blocks seeded (then the tube and the mesh are
    /// rebuilt).
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
        let (near, far): (Vec<IVec3>, Vec<IVec3>) = target_blocks(target, xf, w)
            .into_par_iter()
            .filter(|&c| target.may_be_inside(block_region(xf, c)))
            .partition(|&c| near_skin(c));
        let mut wanted: Seeds = far
            .into_par_iter()
            .filter(|&c| block_centre_distance(target, xf, c) <= reach)
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
        wanted.extend(self.lost_pieces(target, &near));
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
        let changed: Vec<IVec3> = wanted.iter().map(|(c, _)| *c).collect();
        self.store_crossed_cells(&changed);
        // The seeds hold the target's own distance estimate (first order for densities):
        // made a distance like the rest of the band before anything reads or writes it.
        for _ in 0..3 {
            super::band::renormalize(&mut self.grid, w, 0.0, &mut self.rates);
            crate::grid::tube::upkeep(&mut self.grid);
        }
        self.polygonize();
        wanted.len()
    }

    /// After nodes were set from outside the skin's own motion (seeds, spray) in the
    /// blocks `changed`: as at a start, every crossed cell stored, its corners in the band
    /// (the corners clamped in those blocks and the blocks around them).
    pub(super) fn store_crossed_cells(&mut self, changed: &[IVec3]) {
        let near: HashSet<IVec3> = changed
            .iter()
            .flat_map(|&c| AROUND.iter().map(move |&d| c + d))
            .collect();
        // Only the blocks changed, and those stored for them, can cross into unstored
        // ones: the rest of the band had its crossed cells stored already.
        let mut reached = near.clone();
        for _ in 0..4 {
            let among = |c: IVec3| reached.contains(&c);
            let missing = super::band::unstored_crossed_among(&self.grid, among);
            if missing.is_empty() {
                break;
            }
            for c in missing {
                self.grid.touch(c);
                reached.extend(AROUND.iter().map(|&d| c + d));
            }
        }
        let w = self.params.band_width;
        let within = |c: IVec3| near.contains(&c);
        super::band::clamp_at_crossings_in(&mut self.grid, w, &mut self.rates, within);
        crate::grid::tube::upkeep(&mut self.grid);
    }

    /// Seeds for the target's pieces in blocks `near` the skin that lie wholly
    /// [`LOST_VOXELS`] outside it: the target's material outside the skin, flooded
    /// node to node, kept where no node of it comes nearer the skin than that. Each
    /// such piece's nodes and the nodes around them take the smaller of the skin's
    /// potential and the target's distance.
    fn lost_pieces(&self, target: &dyn Target, near: &[IVec3]) -> Seeds {
        let (dx, w) = (self.params.dx, self.params.band_width);
        let lost = (LOST_VOXELS / w).min(1.0);
        let xf = self.xf;
        // Each block's skin potential and where the target has material outside it.
        let read = |c: IVec3| -> Option<Nodes> {
            let skin: Box<[f32; BLOCK_NODES]> = Box::new(match self.grid.find(c) {
                Some(id) => std::array::from_fn(|o| self.grid.block(id).values[o].to_f32()),
                None => [self.grid.tile_value(c).to_f32(); BLOCK_NODES],
            });
            if skin.iter().all(|&s| s <= 0.0) {
                return None;
            }
            let mut wet = Box::new([false; BLOCK_NODES]);
            target.block_inside(xf.apply((c * BLOCK_DIM).as_vec3()), dx, &mut wet);
            for (wet, &s) in wet.iter_mut().zip(skin.iter()) {
                *wet &= s > 0.0;
            }
            Some(Nodes { skin, wet })
        };
        // Blocks holding target material far outside the skin: where a lost piece may
        // start.
        let starts: Vec<IVec3> = near
            .par_iter()
            .copied()
            .filter(|&c| {
                read(c).is_some_and(|n| (0..BLOCK_NODES).any(|o| n.wet[o] && n.skin[o] >= lost))
            })
            .collect();
        if starts.is_empty() {
            return Vec::new();
        }
        let mut around: Vec<IVec3> = starts
            .iter()
            .flat_map(|&c| AROUND.iter().map(move |&d| c + d))
            .collect();
        around.sort_unstable_by_key(|c| c.to_array());
        around.dedup();
        let blocks: hashbrown::HashMap<IVec3, Option<Nodes>> = around
            .into_par_iter()
            .map(|c| (c, read(c)))
            .collect::<Vec<_>>()
            .into_iter()
            .collect();
        // A node's skin potential and whether it is target material outside the skin;
        // `None` beyond the blocks read.
        let node = |n: IVec3| {
            let (c, o) = node_in_block(n);
            blocks.get(&c).map(|b| match b {
                Some(b) => (b.skin[o], b.wet[o]),
                None => (-1.0, false),
            })
        };
        // Flood the material from each far node, six neighbours at a time.
        let mut seen: HashSet<IVec3> = HashSet::new();
        let mut pieces: Vec<IVec3> = Vec::new();
        for &c in &starts {
            for o in 0..BLOCK_NODES {
                let start = c * BLOCK_DIM + offset_coords(o);
                if !node(start).is_some_and(|(s, wet)| wet && s >= lost) || !seen.insert(start) {
                    continue;
                }
                let (mut piece, mut open, mut kept) = (vec![start], vec![start], true);
                while let Some(n) = open.pop() {
                    for step in crate::grid::FACES {
                        let m = n + step;
                        match node(m) {
                            // Beyond the blocks read: the piece is not known whole.
                            None => kept = false,
                            Some((s, true)) => {
                                kept &= s >= lost;
                                if seen.insert(m) {
                                    piece.push(m);
                                    open.push(m);
                                }
                            }
                            // The skin's own material next to the target's: joined.
                            Some((s, false)) => kept &= s > 0.0,
                        }
                    }
                }
                if kept {
                    pieces.extend(piece);
                }
            }
        }
        // The kept pieces' nodes and the nodes around them (their band), by block.
        let mut band: Vec<IVec3> = pieces
            .iter()
            .flat_map(|&n| AROUND.iter().map(move |&d| n + d))
            .collect();
        band.sort_unstable_by_key(|n| n.to_array());
        band.dedup();
        let mut seeds: hashbrown::HashMap<IVec3, Box<[f32; BLOCK_NODES]>> = Default::default();
        for n in band {
            let Some((s, _)) = node(n).filter(|&(s, _)| s > 0.0) else {
                continue;
            };
            let d = target.distance(xf.apply(n.as_vec3())) / (w * dx);
            let (c, o) = node_in_block(n);
            seeds
                .entry(c)
                .or_insert_with(|| Box::new([1.0; BLOCK_NODES]))[o] = d.clamp(-1.0, 1.0).min(s);
        }
        let mut seeds: Seeds = seeds.into_iter().collect();
        seeds.sort_unstable_by_key(|(c, _)| c.to_array());
        seeds
    }
}

/// One block's skin potential and where the target has material outside the skin.
struct Nodes {
    skin: Box<[f32; BLOCK_NODES]>,
    wet: Box<[bool; BLOCK_NODES]>,
}

/// Block `c`'s box, node to node.
fn block_region(xf: IndexToWorld, c: IVec3) -> Aabb {
    let corner = |k: i32| xf.apply((c * BLOCK_DIM + IVec3::splat(k)).as_vec3());
    Aabb {
        min: corner(0),
        max: corner(BLOCK_DIM - 1),
    }
}
