//! A block's values with a one-node border taken from its neighbours: every stencil of
//! the solver and every cube of the polygonizer reads from here, without hashing.

use super::{node_offset, Potential, SparseGrid, BLOCK_DIM};
use glam::IVec3;

/// Side of the padded cube: 8 nodes plus one on each side.
pub const HALO_DIM: usize = 10;

/// Values of a block and its one-node border, as f32, x-major like the block.
pub struct Halo {
    pub values: [f32; HALO_DIM * HALO_DIM * HALO_DIM],
}

impl Default for Halo {
    fn default() -> Self {
        Halo {
            values: [1.0; HALO_DIM * HALO_DIM * HALO_DIM],
        }
    }
}

impl Halo {
    /// Index of local node (x, y, z), each in -1..=8.
    #[inline]
    pub fn index(x: i32, y: i32, z: i32) -> usize {
        ((x + 1) as usize * HALO_DIM + (y + 1) as usize) * HALO_DIM + (z + 1) as usize
    }

    #[inline]
    pub fn at(&self, x: i32, y: i32, z: i32) -> f32 {
        // SAFETY: callers pass local coordinates in -1..=8, so the index is < 1000.
        unsafe { *self.values.get_unchecked(Self::index(x, y, z)) }
    }

    /// Fills from the block at `coord` and its 26 neighbours (tiles give their side).
    pub fn gather<P: Potential>(&mut self, grid: &SparseGrid<P>, coord: IVec3) {
        let around = grid.neighbourhood(coord);
        for hx in -1..=BLOCK_DIM {
            let (bx, lx) = split(hx);
            for hy in -1..=BLOCK_DIM {
                let (by, ly) = split(hy);
                for hz in -1..=BLOCK_DIM {
                    let (bz, lz) = split(hz);
                    let n = ((bx + 1) * 9 + (by + 1) * 3 + (bz + 1)) as usize;
                    let v = match around[n] {
                        Ok(id) => grid.block(id).values[node_offset(lx, ly, lz)],
                        Err(tile) => tile,
                    };
                    self.values[Self::index(hx, hy, hz)] = v.to_f32();
                }
            }
        }
    }
}

/// Local coordinate -1..=8 → (neighbour step -1, 0 or 1, coordinate in that block).
#[inline]
fn split(h: i32) -> (i32, i32) {
    if h < 0 {
        (-1, BLOCK_DIM - 1)
    } else if h >= BLOCK_DIM {
        (1, 0)
    } else {
        (0, h)
    }
}
