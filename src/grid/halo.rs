//! A block's values with a one-node border taken from its neighbours: every stencil of
//! the solver and every cube of the polygonizer reads from here, without hashing.

use super::{node_offset, BlockId, Potential, SparseGrid, BLOCK_DIM};
use glam::IVec3;

/// Side of the padded cube: 8 nodes plus one on each side.
pub(crate) const HALO_DIM: usize = 10;

/// Values of a block and its one-node border, as f32, x-major like the block.
pub(crate) struct Halo {
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
    pub(crate) fn gather<P: Potential>(&mut self, grid: &SparseGrid<P>, coord: IVec3) {
        self.fill(grid, &grid.neighbourhood(coord));
    }

    /// Fills from a block's neighbourhood, as [`SparseGrid::neighbourhood`] gives it, one
    /// row of ten along z at a time: its eight middle values are a fixed-size copy.
    pub(crate) fn fill<P: Potential>(
        &mut self,
        grid: &SparseGrid<P>,
        around: &[Result<BlockId, P>; 27],
    ) {
        let node = |source: &Result<BlockId, P>, offset: usize| match source {
            Ok(id) => grid.block(*id).values[offset].to_f32(),
            Err(tile) => tile.to_f32(),
        };
        for hx in -1..=BLOCK_DIM {
            let (sx, lx) = split(hx);
            for hy in -1..=BLOCK_DIM {
                let (sy, ly) = split(hy);
                // The three neighbours along z of this row: n (−1), n + 1 (0), n + 2 (+1).
                let n = ((sx + 1) * 9 + (sy + 1) * 3) as usize;
                let start = Self::index(hx, hy, -1);
                let row: &mut [f32; HALO_DIM] = (&mut self.values[start..start + HALO_DIM])
                    .try_into()
                    .expect("a halo row is ten values");
                let first = node_offset(lx, ly, 0);
                row[0] = node(&around[n], first + BLOCK_DIM as usize - 1);
                row[HALO_DIM - 1] = node(&around[n + 2], first);
                match &around[n + 1] {
                    Ok(id) => {
                        let values = &grid.block(*id).values;
                        let middle: &[P; 8] = values[first..first + 8]
                            .try_into()
                            .expect("a block row is eight values");
                        for (out, v) in row[1..HALO_DIM - 1].iter_mut().zip(middle) {
                            *out = v.to_f32();
                        }
                    }
                    Err(tile) => row[1..HALO_DIM - 1].fill(tile.to_f32()),
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

/// Side of [`WideHalo`]: 8 nodes plus two on each side.
pub const WIDE_DIM: usize = 12;

/// A block's values with a two-node border, for stencils four nodes wide (the advection's
/// cubic interpolation). Gathered node by node: it is read once per pass.
pub struct WideHalo {
    pub values: [f32; WIDE_DIM * WIDE_DIM * WIDE_DIM],
}

impl Default for WideHalo {
    fn default() -> Self {
        WideHalo {
            values: [1.0; WIDE_DIM * WIDE_DIM * WIDE_DIM],
        }
    }
}

impl WideHalo {
    #[inline]
    pub(crate) fn index(x: i32, y: i32, z: i32) -> usize {
        ((x + 2) as usize * WIDE_DIM + (y + 2) as usize) * WIDE_DIM + (z + 2) as usize
    }

    /// The value at local node (x, y, z), each in -2..=9.
    #[inline]
    pub fn at(&self, x: i32, y: i32, z: i32) -> f32 {
        self.values[Self::index(x, y, z)]
    }

    /// Fills from the block at `coord` and its 26 neighbours (tiles give their side).
    pub fn gather<P: Potential>(&mut self, grid: &SparseGrid<P>, coord: IVec3) {
        let around = grid.neighbourhood(coord);
        let side = |h: i32| (h.div_euclid(BLOCK_DIM) + 1, h.rem_euclid(BLOCK_DIM));
        for hx in -2..BLOCK_DIM + 2 {
            let (sx, lx) = side(hx);
            for hy in -2..BLOCK_DIM + 2 {
                let (sy, ly) = side(hy);
                for hz in -2..BLOCK_DIM + 2 {
                    let (sz, lz) = side(hz);
                    let value = match &around[(sx * 9 + sy * 3 + sz) as usize] {
                        Ok(id) => grid.block(*id).values[node_offset(lx, ly, lz)].to_f32(),
                        Err(tile) => tile.to_f32(),
                    };
                    self.values[Self::index(hx, hy, hz)] = value;
                }
            }
        }
    }
}
