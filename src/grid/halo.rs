//! A block's values with a one-node border taken from its neighbours: every stencil of
//! the solver and every cube of the polygonizer reads from here, without hashing.

use super::{node_offset, BlockId, Potential, SparseGrid, BLOCK_DIM};
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
        self.fill(grid, &grid.neighbourhood(coord));
    }

    /// Fills from a block's neighbourhood, as [`SparseGrid::neighbourhood`] gives it, one
    /// contiguous z-run at a time.
    pub fn fill<P: Potential>(&mut self, grid: &SparseGrid<P>, around: &[Result<BlockId, P>; 27]) {
        for (n, source) in around.iter().enumerate() {
            let (x, y, z) = (span(n / 9), span((n / 3) % 3), span(n % 3));
            for i in 0..x.len {
                for j in 0..y.len {
                    let h = Self::index(x.halo + i, y.halo + j, z.halo);
                    let run = &mut self.values[h..h + z.len as usize];
                    match source {
                        Ok(id) => {
                            let l = node_offset(x.local + i, y.local + j, z.local);
                            let values = &grid.block(*id).values[l..l + z.len as usize];
                            for (out, v) in run.iter_mut().zip(values) {
                                *out = v.to_f32();
                            }
                        }
                        Err(tile) => run.fill(tile.to_f32()),
                    }
                }
            }
        }
    }
}

/// Along one axis, the halo coordinates a neighbour covers and where they start in it.
struct Span {
    halo: i32,
    local: i32,
    len: i32,
}

/// Neighbour step 0 (−1), 1 (the block itself) or 2 (+1) along an axis.
fn span(step: usize) -> Span {
    match step {
        0 => Span {
            halo: -1,
            local: BLOCK_DIM - 1,
            len: 1,
        },
        1 => Span {
            halo: 0,
            local: 0,
            len: BLOCK_DIM,
        },
        _ => Span {
            halo: BLOCK_DIM,
            local: 0,
            len: 1,
        },
    }
}
