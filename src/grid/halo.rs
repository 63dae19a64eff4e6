//! A block's values with a one-node border taken from its neighbours: every stencil of
//! the solver and every cube of the polygonizer reads from here, without hashing.

use super::{Block, BlockId, Potential, SparseGrid, BLOCK_DIM};

/// Side of the padded cube: 8 nodes plus one on each side.
pub(crate) const HALO_DIM: usize = 10;

/// Values of a block and its one-node border, as f32, x-major like the block.
pub(crate) struct Halo {
    /// The block's values and its neighbours' one node around ([`Halo::index`]).
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

    /// Fills from a block of `grid` and its 26 neighbours (tiles give their side).
    pub(crate) fn gather<P: Potential>(&mut self, grid: &SparseGrid<P>, block: &Block<P>) {
        self.fill(grid, &grid.neighbourhood_of(block));
    }

    /// Fills from a block's neighbourhood, as [`SparseGrid::neighbourhood`] gives it.
    pub(crate) fn fill<P: Potential>(
        &mut self,
        grid: &SparseGrid<P>,
        around: &[Result<BlockId, P>; 27],
    ) {
        fill_boxes::<P, 1, HALO_DIM, { HALO_DIM * HALO_DIM * HALO_DIM }>(
            &mut self.values,
            grid,
            around,
        );
    }
}

/// Fills a padded cube of side `H` = 8 + 2·`BORDER` (x-major, like a block) from a block's
/// neighbourhood: each of the 27 sources fills its box (a corner, an edge run, a face or
/// the block itself), a tile as one constant, a block by fixed-length row copies.
#[inline(always)]
fn fill_boxes<P: Potential, const BORDER: usize, const H: usize, const N: usize>(
    values: &mut [f32; N],
    grid: &SparseGrid<P>,
    around: &[Result<BlockId, P>; 27],
) {
    const D: usize = BLOCK_DIM as usize;
    debug_assert!(H == D + 2 * BORDER && N == H * H * H);
    // Along one axis, per neighbour step -1, 0, 1: the first padded index, the first source
    // index and the length of the run.
    let runs: [(usize, usize, usize); 3] = [
        (0, D - BORDER, BORDER),
        (BORDER, 0, D),
        (BORDER + D, 0, BORDER),
    ];
    for (n, source) in around.iter().enumerate() {
        let (hx, bx, nx) = runs[n / 9];
        let (hy, by, ny) = runs[n / 3 % 3];
        let (hz, bz, nz) = runs[n % 3];
        for i in 0..nx {
            for j in 0..ny {
                let start = ((hx + i) * H + hy + j) * H + hz;
                let from = ((bx + i) * D + by + j) * D + bz;
                // SAFETY: the runs keep every copy within the block (from + nz ≤ 8³) and
                // within the padded cube (start + nz ≤ H³). (Checked indexing cost half
                // the gather; runs of a fixed length are copied fastest.)
                unsafe {
                    let out = values.as_mut_ptr().add(start);
                    match source {
                        Ok(id) => {
                            let run = grid.block(*id).values.as_ptr().add(from);
                            if nz == D {
                                let run = &*(run as *const [P; D]);
                                *(out as *mut [f32; D]) = run.map(P::to_f32);
                            } else {
                                let run = &*(run as *const [P; BORDER]);
                                *(out as *mut [f32; BORDER]) = run.map(P::to_f32);
                            }
                        }
                        Err(tile) => {
                            if nz == D {
                                *(out as *mut [f32; D]) = [tile.to_f32(); D];
                            } else {
                                *(out as *mut [f32; BORDER]) = [tile.to_f32(); BORDER];
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Side of [`WideHalo`]: 8 nodes plus two on each side.
pub const WIDE_DIM: usize = 12;

/// A block's values with a two-node border, for stencils four nodes wide (the advection's
/// cubic interpolation).
pub struct WideHalo {
    /// The block's values and its neighbours' two nodes around.
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

    /// Fills from a block of `grid` and its 26 neighbours (tiles give their side).
    pub(crate) fn gather<P: Potential>(&mut self, grid: &SparseGrid<P>, block: &Block<P>) {
        fill_boxes::<P, 2, WIDE_DIM, { WIDE_DIM * WIDE_DIM * WIDE_DIM }>(
            &mut self.values,
            grid,
            &grid.neighbourhood_of(block),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Fixed16;
    use glam::IVec3;

    fn assert_halos_match<P: Potential>(grid: &SparseGrid<P>) {
        let mut halo = Box::<Halo>::default();
        let mut wide = Box::<WideHalo>::default();
        for block in grid.blocks() {
            halo.gather(grid, block);
            wide.gather(grid, block);
            let base = block.coord * BLOCK_DIM;
            for x in -2..BLOCK_DIM + 2 {
                for y in -2..BLOCK_DIM + 2 {
                    for z in -2..BLOCK_DIM + 2 {
                        let l = IVec3::new(x, y, z);
                        let (at, value) = (block.coord, grid.value(base + l));
                        assert_eq!(wide.at(x, y, z), value, "wide {l} of {at}");
                        if l.min_element() >= -1 && l.max_element() <= BLOCK_DIM {
                            assert_eq!(halo.at(x, y, z), value, "{l} of {at}");
                        }
                    }
                }
            }
        }
    }

    /// Every halo node holds the grid's value there, whether it comes from the block, a
    /// stored neighbour, an inside tile or the outside, for both potential types; and so
    /// it does from the cached neighbourhoods, and after blocks and tiles change.
    fn gathers_what_the_grid_holds<P: Potential>() {
        let mut below = crate::test_rng(7);
        let mut grid: SparseGrid<P> = SparseGrid::new();
        let mut random_blocks = |grid: &mut SparseGrid<P>, tiles: bool| {
            for x in -2..3 {
                for y in -2..3 {
                    for z in -2..3 {
                        let c = IVec3::new(x, y, z);
                        match (below(4), grid.find(c)) {
                            (0, _) => {
                                grid.touch(c);
                            }
                            (1, None) if tiles => grid.set_tile(c, true),
                            (2, None) if tiles => grid.set_tile(c, false),
                            _ => {}
                        }
                    }
                }
            }
            for block in grid.blocks_mut() {
                for v in block.values.iter_mut() {
                    *v = P::from_f32(below(2001) as f32 / 1000.0 - 1.0);
                }
                block.active = [below(2); 8];
            }
        };
        random_blocks(&mut grid, true);
        assert_halos_match(&grid);
        grid.refresh_neighbourhoods();
        assert_halos_match(&grid);
        // Each way blocks and tiles change: the cache must not be read until refreshed.
        grid.retire_blocks(|b| b.active[0] == 0);
        assert_halos_match(&grid);
        grid.refresh_neighbourhoods();
        random_blocks(&mut grid, false);
        assert_halos_match(&grid);
        grid.refresh_neighbourhoods();
        let tiles: Vec<IVec3> = (-3..4)
            .map(|x| IVec3::new(x, 3, 0))
            .filter(|&c| grid.find(c).is_none())
            .collect();
        for c in tiles {
            grid.set_tile(c, true);
        }
        assert_halos_match(&grid);
    }

    #[test]
    fn a_halo_gathers_what_the_grid_holds() {
        gathers_what_the_grid_holds::<f32>();
        gathers_what_the_grid_holds::<Fixed16>();
    }
}

/// Which nodes of a halo are inside (f < 0, as the polygonizer cuts), one row along z at
/// a time: bit k + 1 for local z = k.
#[derive(Clone)]
pub(crate) struct InsideRows([u16; HALO_DIM * HALO_DIM]);

impl Default for InsideRows {
    fn default() -> Self {
        InsideRows([0; HALO_DIM * HALO_DIM])
    }
}

impl InsideRows {
    pub(crate) fn of(halo: &Halo) -> Self {
        let mut rows = [0u16; HALO_DIM * HALO_DIM];
        for (bits, row) in rows.iter_mut().zip(halo.values.chunks_exact(HALO_DIM)) {
            *bits = row
                .iter()
                .enumerate()
                .fold(0, |b, (k, &v)| b | u16::from(v < 0.0) << k);
        }
        InsideRows(rows)
    }

    /// The row of local (x, y), each in -1..=8.
    #[inline]
    pub(crate) fn at(&self, x: i32, y: i32) -> u16 {
        self.0[(x + 1) as usize * HALO_DIM + (y + 1) as usize]
    }

    /// Bit z (local z in 0..8): node (x, y, z) has a node of each side among itself and
    /// its 26 neighbours (x, y in 0..8).
    pub(crate) fn mixed_around(&self, x: i32, y: i32) -> u8 {
        let (mut any, mut all) = (0u16, 0x3FFu16);
        for a in x - 1..=x + 1 {
            for b in y - 1..=y + 1 {
                let r = self.at(a, b);
                any |= r | r << 1 | r >> 1;
                all &= r & (r << 1 | 1) & (r >> 1 | 0x200);
            }
        }
        ((any & !all) >> 1) as u8
    }

    /// Bit z + 1 (local z in -1..8): the cell with lower corner (x, y, z) has corners on
    /// both sides (x, y in -1..8).
    pub(crate) fn crossed_cells(&self, x: i32, y: i32) -> u16 {
        let (r0, r1, r2, r3) = (
            self.at(x, y),
            self.at(x + 1, y),
            self.at(x, y + 1),
            self.at(x + 1, y + 1),
        );
        let (any, all) = (r0 | r1 | r2 | r3, r0 & r1 & r2 & r3);
        // Cell z spans bits z + 1 and z + 2.
        ((any | any >> 1) & !(all & all >> 1)) & 0x1FF
    }
}
