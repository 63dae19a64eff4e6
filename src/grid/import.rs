//! A grid copied from VDB, leaf for block: the values scaled into the potential's [-1, 1].

use glam::IVec3;
use hashbrown::{HashMap, HashSet};

use rayon::prelude::*;

use super::{neighbour_steps, Block, BlockId, Potential, SparseGrid, AROUND, BLOCK_DIM};
use crate::volume::GridData;

impl<P: Potential> SparseGrid<P> {
    /// One block per leaf, in coordinate order (so that two imports of the same data are
    /// the same grid, block for block), with `f = clamp(value(φ) / scale)`. Inside tiles of
    /// one block are kept; larger inside tiles and a negative background are kept where
    /// they touch a leaf, which is all the band upkeep reads ([`TileSides`] tells the rest).
    pub fn from_vdb(data: &GridData, value: impl Fn(f32) -> f32 + Sync) -> Self {
        let mut grid = SparseGrid::new();
        grid.import(data, value);
        grid
    }

    /// [`SparseGrid::from_vdb`] into this grid, keeping its allocations (a skin restores
    /// its state every frame).
    pub fn import(&mut self, data: &GridData, value: impl Fn(f32) -> f32 + Sync) {
        self.import_with_sides(data, value);
    }

    /// [`SparseGrid::import`], returning the side of every unstored block.
    pub(crate) fn import_with_sides(
        &mut self,
        data: &GridData,
        value: impl Fn(f32) -> f32 + Sync,
    ) -> TileSides {
        self.index.clear();
        self.blocks.clear();
        self.inside.clear();
        self.around_fresh = false;
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
        let mut sides = TileSides {
            outside: HashSet::new(),
            larger: Vec::new(),
            background_inside: value(data.background) < 0.0,
        };
        let cut = data.tiles_within_leaves();
        for tile in cut.as_deref().unwrap_or(&data.tiles) {
            let inside = value(tile.value) < 0.0;
            let coord = IVec3::from_array(tile.origin) >> IVec3::splat(3);
            let blocks = (tile.dim as i32 / BLOCK_DIM).max(1);
            if blocks == 1 {
                // Inside ones are all kept: a skin's own files hold only these.
                if inside {
                    grid.set_tile(coord, true);
                } else {
                    sides.outside.insert(coord);
                }
                continue;
            }
            let shift = blocks.trailing_zeros() as i32;
            let at = match sides.larger.iter().position(|(s, _)| *s == shift) {
                Some(at) => at,
                None => {
                    sides.larger.push((shift, HashMap::new()));
                    sides.larger.len() - 1
                }
            };
            sides.larger[at]
                .1
                .insert(coord >> IVec3::splat(shift), inside);
        }
        if !sides.larger.is_empty() || sides.background_inside {
            // The ring of unmarked blocks around the leaves that are inside.
            let grid_ref = &*grid;
            let ring: Vec<IVec3> = grid_ref
                .blocks
                .par_iter()
                .flat_map_iter(|block| neighbour_steps().map(move |d| block.coord + d))
                .filter(|&c| {
                    grid_ref.find(c).is_none()
                        && !grid_ref.inside.contains(&c)
                        && sides.unmarked_inside(c)
                })
                .collect();
            for c in ring {
                grid.set_tile(c, true);
            }
        }
        sides
    }

    /// The tiles marked inside with a neighbour (of 26) neither stored nor marked inside;
    /// the others are told by bits, chunks of 4³ blocks to a word.
    pub(crate) fn exposed_inside_tiles(&self) -> Vec<IVec3> {
        let chunk = |c: IVec3| c >> IVec3::splat(2);
        let bit = |c: IVec3| {
            let l = c & IVec3::splat(3);
            1u64 << (l.x * 16 + l.y * 4 + l.z)
        };
        let mut occupied: HashMap<IVec3, u64> = HashMap::new();
        let mut inside: HashMap<IVec3, u64> = HashMap::new();
        for &c in &self.inside {
            *occupied.entry(chunk(c)).or_default() |= bit(c);
            *inside.entry(chunk(c)).or_default() |= bit(c);
        }
        for block in &self.blocks {
            *occupied.entry(chunk(block.coord)).or_default() |= bit(block.coord);
        }
        let inside: Vec<(IVec3, u64)> = inside.into_iter().collect();
        inside
            .par_iter()
            .flat_map_iter(|&(key, word)| {
                let around: [u64; 27] =
                    AROUND.map(|d| occupied.get(&(key + d)).copied().unwrap_or(0));
                // Bit of block `c` (within one chunk of this one) in `around`.
                let occupied_at = move |c: IVec3| {
                    let d = chunk(c) - key;
                    around[((d.x + 1) * 9 + (d.y + 1) * 3 + d.z + 1) as usize] & bit(c) != 0
                };
                (0..64)
                    .filter(move |b| word >> b & 1 == 1)
                    .map(move |b| {
                        (key << IVec3::splat(2)) + IVec3::new(b >> 4, (b >> 2) & 3, b & 3)
                    })
                    .filter(move |&c| !neighbour_steps().all(|d| occupied_at(c + d)))
            })
            .collect()
    }

    /// Both sides of every border between unstored blocks of different sides, sorted, each
    /// once: each of `tiles` (a block and its side) with a neighbour (of 26) of the other
    /// side, and those neighbours. A neighbour marked inside is inside; one neither stored
    /// nor marked is as `unmarked_inside` says.
    pub(crate) fn tile_borders(
        &self,
        tiles: &[(IVec3, bool)],
        unmarked_inside: impl Fn(IVec3) -> bool + Sync,
    ) -> Vec<IVec3> {
        let unmarked_inside = &unmarked_inside;
        let mut borders: Vec<IVec3> = tiles
            .par_iter()
            .flat_map_iter(|&(tile, inside)| {
                let opposite = move |c: &IVec3| {
                    if self.inside.contains(c) {
                        return !inside;
                    }
                    self.find(*c).is_none() && unmarked_inside(*c) != inside
                };
                let mut across = neighbour_steps()
                    .map(move |d| tile + d)
                    .filter(opposite)
                    .peekable();
                let touching = across.peek().is_some();
                std::iter::once(tile)
                    .filter(move |_| touching)
                    .chain(across)
            })
            .collect();
        borders.sort_unstable_by_key(|c| c.to_array());
        borders.dedup();
        borders
    }
}

/// The side of each block a grid copied from VDB leaves unstored, from the tiles and the
/// background, for the blocks the grid does not mark inside: larger tiles by size, each
/// size one lookup away (a block's tile is its coordinate shifted).
#[derive(Default)]
pub(crate) struct TileSides {
    /// Outside tiles of one block.
    outside: HashSet<IVec3>,
    /// Per size (log₂ of its blocks per side): the tiles by shifted coordinate, inside or not.
    larger: Vec<(i32, HashMap<IVec3, bool>)>,
    background_inside: bool,
}

impl TileSides {
    /// Whether block `c`, neither stored nor marked inside in the grid, is inside.
    pub(crate) fn unmarked_inside(&self, c: IVec3) -> bool {
        if self.outside.contains(&c) {
            return false;
        }
        self.larger
            .iter()
            .find_map(|(shift, tiles)| tiles.get(&(c >> IVec3::splat(*shift))))
            .copied()
            .unwrap_or(self.background_inside)
    }

    /// The outside tiles of one block, then the blocks on the faces of every larger tile of
    /// up to 16³ blocks, with their sides (the faces of root tiles, 512³ blocks, are left
    /// out: a liquid never fills one).
    pub(crate) fn tile_blocks(&self) -> impl Iterator<Item = (IVec3, bool)> + '_ {
        let faces = self
            .larger
            .iter()
            .filter(|(shift, _)| *shift <= 4)
            .flat_map(|(shift, tiles)| {
                let n = 1 << shift;
                tiles.iter().flat_map(move |(&key, &inside)| {
                    let lo = key << IVec3::splat(*shift);
                    (0..n).flat_map(move |x| {
                        (0..n).flat_map(move |y| {
                            (0..n)
                                .filter(move |&z| [x, y, z].iter().any(|&c| c == 0 || c == n - 1))
                                .map(move |z| (lo + IVec3::new(x, y, z), inside))
                        })
                    })
                })
            });
        self.outside.iter().map(|&c| (c, false)).chain(faces)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::{GridClass, Tile, Transform, LEAF_VOXELS, MASK_WORDS};

    /// One leaf at block (15, 8, 8), the last of its 128³ node along x, with a tile of
    /// 128³ at x = 128 beyond it and a tile of one block at (15, 9, 8).
    fn leaf_beside_tiles(background: f32, big: f32, small: f32) -> GridData {
        let mut data = GridData::empty(
            "g",
            GridClass::LevelSet,
            background,
            Transform::uniform(1.0, [0.0; 3]),
        );
        data.leaf_origins.push([120, 64, 64]);
        data.leaf_values.extend([0.5f32; LEAF_VOXELS]);
        data.leaf_masks.push([u64::MAX; MASK_WORDS]);
        for (origin, dim, value) in [([128, 0, 0], 128, big), ([120, 72, 64], 8, small)] {
            data.tiles.push(Tile {
                origin,
                dim,
                value,
                active: false,
            });
        }
        data
    }

    fn inside_ring(grid: &SparseGrid<f32>) -> Vec<IVec3> {
        let leaf = IVec3::new(15, 8, 8);
        let mut ring: Vec<IVec3> = neighbour_steps()
            .map(|d| leaf + d)
            .filter(|c| grid.inside_tiles().contains(c))
            .map(|c| c - leaf)
            .collect();
        ring.sort_by_key(|c| c.to_array());
        ring
    }

    #[test]
    fn a_larger_inside_tile_is_inside_where_it_touches_a_leaf() {
        let grid = SparseGrid::<f32>::from_vdb(&leaf_beside_tiles(3.0, -3.0, 3.0), |v| v / 3.0);
        assert_eq!(grid.block_count(), 1);
        // The nine blocks across the +x face, edges and corners lie in the large tile.
        let ring = inside_ring(&grid);
        assert_eq!(ring.len(), 9, "{ring:?}");
        assert!(ring.iter().all(|c| c.x == 1));
        // Beyond the ring only the tile's side matters, not its blocks.
        assert!(!grid.inside_tiles().contains(&IVec3::new(20, 8, 8)));
    }

    #[test]
    fn an_inside_background_is_inside_where_no_tile_says_otherwise() {
        let grid = SparseGrid::<f32>::from_vdb(&leaf_beside_tiles(-3.0, 3.0, 3.0), |v| v / 3.0);
        let ring = inside_ring(&grid);
        // 26 neighbours, less the nine in the outside 128³ tile and the outside block tile.
        assert_eq!(ring.len(), 16, "{ring:?}");
        assert!(ring.iter().all(|c| c.x <= 0 && *c != IVec3::new(0, 1, 0)));
        // A one-block inside tile is kept wherever it lies.
        let grid = SparseGrid::<f32>::from_vdb(&leaf_beside_tiles(3.0, 3.0, -3.0), |v| v / 3.0);
        assert_eq!(inside_ring(&grid), vec![IVec3::new(0, 1, 0)]);
    }

    #[test]
    fn exposed_inside_tiles_are_those_with_a_neighbour_neither_stored_nor_inside() {
        let mut rng = crate::test_rng(7);
        let mut next = move |n: i32| rng(n as u64) as i32;
        for _ in 0..10 {
            let mut grid = SparseGrid::<f32>::new();
            // A cube of blocks across chunk and sign boundaries, a few left out.
            for x in -5..5 {
                for y in -5..5 {
                    for z in -5..5 {
                        let c = IVec3::new(x, y, z);
                        match next(40) {
                            0 => {}
                            1..=9 => {
                                grid.touch(c);
                            }
                            _ => grid.set_tile(c, true),
                        }
                    }
                }
            }
            let mut fast = grid.exposed_inside_tiles();
            fast.sort_by_key(|c| c.to_array());
            let mut slow: Vec<IVec3> = grid
                .inside_tiles()
                .iter()
                .copied()
                .filter(|&t| {
                    neighbour_steps().any(|d| {
                        grid.find(t + d).is_none() && !grid.inside_tiles().contains(&(t + d))
                    })
                })
                .collect();
            slow.sort_by_key(|c| c.to_array());
            assert!(!slow.is_empty() && slow.len() < grid.inside_tiles().len());
            assert_eq!(fast, slow);
        }
    }
}
