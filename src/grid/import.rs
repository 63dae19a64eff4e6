//! A grid copied from VDB, leaf for block: the values scaled into the potential's [-1, 1].

use glam::IVec3;
use hashbrown::HashSet;

use rayon::prelude::*;

use super::{Block, BlockId, Potential, SparseGrid, AROUND, BLOCK_DIM};
use crate::volume::GridData;

impl<P: Potential> SparseGrid<P> {
    /// One block per leaf, in coordinate order (so that two imports of the same data are
    /// the same grid, block for block), with `f = clamp(value(φ) / scale)`. Inside tiles of
    /// one block are kept; larger inside tiles and a negative background are kept where
    /// they touch a leaf, which is all a polygonizer or the band upkeep reads.
    pub fn from_vdb(data: &GridData, value: impl Fn(f32) -> f32 + Sync) -> Self {
        let mut grid = SparseGrid::new();
        grid.import(data, value);
        grid
    }

    /// [`SparseGrid::from_vdb`] into this grid, keeping its allocations (a skin restores
    /// its state every frame).
    pub fn import(&mut self, data: &GridData, value: impl Fn(f32) -> f32 + Sync) {
        self.index.clear();
        self.blocks.clear();
        self.inside.clear();
        let grid = self;
        let mut order: Vec<usize> = (0..data.leaf_count()).collect();
        order.sort_unstable_by_key(|&i| data.leaf_origins[i]);
        // Blocks filled in parallel, indexed after: a leaf is one block, each once.
        let value = &value;
        grid.blocks.par_extend(order.par_iter().map(|&leaf| {
            let coord = IVec3::from_array(data.leaf_origins[leaf]) >> IVec3::splat(3);
            let mut block = Block::filled(coord, P::OUTSIDE);
            for (out, &v) in block.values.iter_mut().zip(data.leaf_values(leaf)) {
                *out = P::from_f32(value(v).clamp(-1.0, 1.0));
            }
            block
        }));
        for (id, block) in grid.blocks.iter().enumerate() {
            grid.index.insert(block.coord, BlockId(id as u32));
        }
        let leaves: HashSet<IVec3> = grid.index.keys().copied().collect();
        for tile in &data.tiles {
            if value(tile.value) >= 0.0 {
                continue;
            }
            let lo = IVec3::from_array(tile.origin) >> IVec3::splat(3);
            let blocks = (tile.dim as i32 / BLOCK_DIM).max(1);
            if blocks == 1 {
                grid.set_tile(lo, true);
                continue;
            }
            let hi = lo + IVec3::splat(blocks);
            for &leaf in &leaves {
                for d in neighbour_steps() {
                    let c = leaf + d;
                    if c.cmpge(lo).all() && c.cmplt(hi).all() && !leaves.contains(&c) {
                        grid.set_tile(c, true);
                    }
                }
            }
        }
        if value(data.background) < 0.0 {
            // Everything not stored is inside: mark the ring around the leaves.
            let tiles: HashSet<IVec3> = data
                .tiles
                .iter()
                .map(|t| IVec3::from_array(t.origin) >> IVec3::splat(3))
                .collect();
            for &leaf in &leaves {
                for d in neighbour_steps() {
                    let c = leaf + d;
                    if !leaves.contains(&c) && !tiles.contains(&c) {
                        grid.set_tile(c, true);
                    }
                }
            }
        }
    }
}

fn neighbour_steps() -> impl Iterator<Item = IVec3> {
    AROUND.into_iter().filter(|d| *d != IVec3::ZERO)
}
