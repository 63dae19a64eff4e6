//! The hashed block-sparse grid that holds the skin's potential (paper §4.1, §4.2).
//!
//! Nodes are grouped in blocks of 8³ (one per OpenVDB leaf), stored in an arena that rayon
//! walks in parallel and found through a hashbrown map keyed by block coordinate. A block
//! that is not stored is a *tile*: wholly inside (potential -1) or wholly outside (+1), so
//! a node woken there knows its side. Values are clamped to [-1, 1] and stored as `f32` or
//! as 16-bit fixed point (§4.2.1), chosen at run time through [`Potential`].

mod halo;
mod import;
mod space;
pub(crate) use import::TileSides;
pub mod tube;

pub use space::{Aabb, IndexToWorld};

use glam::IVec3;
use hashbrown::{HashMap, HashSet};
use rayon::prelude::*;

pub(crate) use halo::{Halo, InsideRows, WideHalo, HALO_DIM, WIDE_DIM};

/// Nodes along a block edge.
pub const BLOCK_DIM: i32 = 8;

/// How far from the origin (in voxels) the grid places anything: 2²⁰ voxels, where a
/// 32-bit coordinate still resolves an eighth of a voxel. Farther, positions snap to a
/// coarser lattice than the grid's and surfaces break up.
pub const REACH_VOXELS: f32 = (1 << 20) as f32;
/// Nodes per block, in OpenVDB's leaf order: offset = x << 6 | y << 3 | z.
pub(crate) const BLOCK_NODES: usize = 512;

/// Offset of local node (x, y, z), each in 0..8, inside a block.
#[inline]
pub(crate) fn node_offset(x: i32, y: i32, z: i32) -> usize {
    ((x << 6) | (y << 3) | z) as usize
}

/// Local coordinates of a node offset.
#[inline]
pub(crate) fn offset_coords(offset: usize) -> IVec3 {
    let o = offset as i32;
    IVec3::new(o >> 6, (o >> 3) & 7, o & 7)
}

/// The 27 steps of a 3³ neighbourhood, (0, 0, 0) included; step n is
/// (n / 9 − 1, n / 3 mod 3 − 1, n mod 3 − 1), the order of [`SparseGrid::neighbourhood`].
pub(crate) const AROUND: [IVec3; 27] = {
    let mut steps = [IVec3::ZERO; 27];
    let mut n = 0;
    while n < 27 {
        steps[n] = IVec3::new(n as i32 / 9 - 1, (n as i32 / 3) % 3 - 1, n as i32 % 3 - 1);
        n += 1;
    }
    steps
};

/// Bit n of a 27-bit set of [`AROUND`]'s steps.
#[inline]
pub(crate) fn around_bit(step: IVec3) -> u32 {
    1 << ((step.x + 1) * 9 + (step.y + 1) * 3 + step.z + 1)
}

/// Bits of a run of values along z for which `pick` holds: bit k for value k.
#[inline]
pub(crate) fn row_bits<P: Potential>(values: &[P], pick: impl Fn(f32) -> bool) -> u16 {
    values
        .iter()
        .enumerate()
        .fold(0, |bits, (k, v)| bits | u16::from(pick(v.to_f32())) << k)
}

/// The blocks around a block ([`around_bit`]s, its own left out) across the faces, edges
/// and corners on which a node whose value `pick`s lies.
pub(crate) fn sides_where<P: Potential>(
    values: &[P; BLOCK_NODES],
    pick: impl Fn(f32) -> bool + Copy,
) -> u32 {
    sides_of_rows(|x, y| {
        let start = node_offset(x, y, 0);
        row_bits(&values[start..start + BLOCK_DIM as usize], pick)
    })
}

/// [`sides_where`] for the nodes of `rows` (bit z of row (x, y) for node (x, y, z)).
pub(crate) fn sides_of_rows(rows: impl Fn(i32, i32) -> u16) -> u32 {
    const LOW: u16 = 1;
    const HIGH: u16 = 1 << (BLOCK_DIM - 1);
    let side = |c: i32| match c {
        0 => -1,
        c if c == BLOCK_DIM - 1 => 1,
        _ => 0,
    };
    let mut sides = 0u32;
    for x in 0..BLOCK_DIM {
        for y in 0..BLOCK_DIM {
            let row = rows(x, y);
            if row == 0 {
                continue;
            }
            // Every node of the row is on the x and y sides of (x, y); its ends also on z's.
            let zs = [(true, 0), (row & LOW != 0, -1), (row & HIGH != 0, 1)];
            for sx in [0, side(x)] {
                for sy in [0, side(y)] {
                    for (on, sz) in zs {
                        if on {
                            sides |= around_bit(IVec3::new(sx, sy, sz));
                        }
                    }
                }
            }
        }
    }
    sides & !around_bit(IVec3::ZERO)
}

/// The rows along z with a node set in an active mask: (x, y, bit z for each node).
pub(crate) fn mask_rows(mask: [u64; 8]) -> impl Iterator<Item = (i32, i32, u16)> {
    (0..BLOCK_DIM).flat_map(move |x| {
        (0..BLOCK_DIM).filter_map(move |y| {
            let row = (mask[x as usize] >> (8 * y)) as u16 & 0xFF;
            (row != 0).then_some((x, y, row))
        })
    })
}

/// The set bits of `word`, lowest first.
pub(crate) fn bits(mut word: u16) -> impl Iterator<Item = i32> {
    std::iter::from_fn(move || {
        (word != 0).then(|| {
            let b = word.trailing_zeros() as i32;
            word &= word - 1;
            b
        })
    })
}

/// The bits set in a mask, by index: a block's active mask gives node offsets (a copy:
/// the block's values may be written while they are visited).
pub(crate) fn mask_offsets(mask: impl IntoIterator<Item = u64>) -> impl Iterator<Item = usize> {
    mask.into_iter().enumerate().flat_map(|(w, word)| {
        let mut bits = word;
        std::iter::from_fn(move || {
            if bits == 0 {
                return None;
            }
            let b = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            Some(w * 64 + b)
        })
    })
}

/// The six steps to a node's (or a block's) face neighbours.
pub(crate) const FACES: [IVec3; 6] = [
    IVec3::NEG_X,
    IVec3::X,
    IVec3::NEG_Y,
    IVec3::Y,
    IVec3::NEG_Z,
    IVec3::Z,
];

/// The 26 steps to a block's neighbours: [`AROUND`] without its own.
pub(crate) fn neighbour_steps() -> impl Iterator<Item = IVec3> {
    AROUND.into_iter().filter(|d| *d != IVec3::ZERO)
}

/// The block holding global node `ijk`.
#[inline]
pub(crate) fn block_of(ijk: IVec3) -> IVec3 {
    ijk >> 3
}

/// The block holding global node `ijk` and the node's offset in it.
#[inline]
pub(crate) fn node_in_block(ijk: IVec3) -> (IVec3, usize) {
    let coord = block_of(ijk);
    let l = ijk - coord * BLOCK_DIM;
    (coord, node_offset(l.x, l.y, l.z))
}

/// A stored value of the potential, clamped to [-1, 1].
pub trait Potential: Copy + Send + Sync + 'static {
    const INSIDE: Self;
    const OUTSIDE: Self;
    fn to_f32(self) -> f32;
    /// Stores `f`, already clamped to [-1, 1].
    fn from_f32(f: f32) -> Self;
}

impl Potential for f32 {
    const INSIDE: Self = -1.0;
    const OUTSIDE: Self = 1.0;
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline]
    fn from_f32(f: f32) -> Self {
        f
    }
}

/// The paper's 16-bit fixed point: f = n / 32767, a resolution of 3e-5 (1e-4 voxel with a
/// 3-voxel band), half the memory of `f32`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fixed16(pub i16);

impl Fixed16 {
    const SCALE: f32 = 32767.0;
}

impl Potential for Fixed16 {
    const INSIDE: Self = Fixed16(-32767);
    const OUTSIDE: Self = Fixed16(32767);
    #[inline]
    fn to_f32(self) -> f32 {
        f32::from(self.0) / Self::SCALE
    }
    #[inline]
    fn from_f32(f: f32) -> Self {
        Fixed16((f * Self::SCALE).round() as i16)
    }
}

/// Storage chosen at run time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    #[default]
    F32,
    Fixed16,
}

/// Typed index of a block in the arena.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct BlockId(pub u32);

/// 8³ nodes and the mask of those in the active tube.
#[derive(Clone)]
pub(crate) struct Block<P> {
    /// Block coordinate: global node = 8 · coord + local.
    pub coord: IVec3,
    /// The potential at the block's 8³ nodes, x-major (`node_offset`).
    pub values: [P; BLOCK_NODES],
    /// The band's nodes among them, a bit per node offset.
    pub active: [u64; 8],
}

impl<P: Potential> Block<P> {
    fn filled(coord: IVec3, value: P) -> Self {
        Block {
            coord,
            values: [value; BLOCK_NODES],
            active: [0; 8],
        }
    }

    pub(crate) fn active_count(&self) -> usize {
        self.active.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Offsets of active nodes, in order.
    pub(crate) fn active_offsets(&self) -> impl Iterator<Item = usize> {
        mask_offsets(self.active)
    }

    /// The rows along z with an active node: (x, y, bit z for each active node).
    pub(crate) fn active_rows(&self) -> impl Iterator<Item = (i32, i32, u16)> {
        mask_rows(self.active)
    }
}

/// Blocks in a hashed arena, plus the blocks known to be wholly inside.
#[derive(Clone)]
pub struct SparseGrid<P> {
    index: HashMap<IVec3, BlockId>,
    blocks: Vec<Block<P>>,
    /// Unstored blocks wholly inside; every other unstored block is outside.
    inside: HashSet<IVec3>,
    /// Each block's neighbourhood, in block order, while `around_fresh`: the passes of a
    /// step between two band upkeeps read it instead of hashing 26 neighbours each.
    around: Vec<[Result<BlockId, P>; 27]>,
    around_fresh: bool,
}

impl<P: Potential> Default for SparseGrid<P> {
    fn default() -> Self {
        Self::new()
    }
}

impl<P: Potential> SparseGrid<P> {
    pub fn new() -> Self {
        SparseGrid {
            index: HashMap::new(),
            blocks: Vec::new(),
            inside: HashSet::new(),
            around: Vec::new(),
            around_fresh: false,
        }
    }

    pub(crate) fn blocks(&self) -> &[Block<P>] {
        &self.blocks
    }

    pub(crate) fn blocks_mut(&mut self) -> &mut [Block<P>] {
        &mut self.blocks
    }

    pub fn block_count(&self) -> usize {
        self.blocks.len()
    }

    pub(crate) fn inside_tiles(&self) -> &HashSet<IVec3> {
        &self.inside
    }

    pub(crate) fn find(&self, coord: IVec3) -> Option<BlockId> {
        self.index.get(&coord).copied()
    }

    pub(crate) fn block(&self, id: BlockId) -> &Block<P> {
        &self.blocks[id.0 as usize]
    }

    pub(crate) fn block_mut(&mut self, id: BlockId) -> &mut Block<P> {
        &mut self.blocks[id.0 as usize]
    }

    /// Value of an unstored block (its tile side).
    pub(crate) fn tile_value(&self, coord: IVec3) -> P {
        if self.inside.contains(&coord) {
            P::INSIDE
        } else {
            P::OUTSIDE
        }
    }

    /// Value at a global node, stored or not.
    pub fn value(&self, ijk: IVec3) -> f32 {
        let (coord, o) = node_in_block(ijk);
        match self.find(coord) {
            Some(id) => self.block(id).values[o].to_f32(),
            None => self.tile_value(coord).to_f32(),
        }
    }

    /// The trilinear interpolation of the nodes' values at `u` (index space), stored or not:
    /// one block looked up when the cell lies within one (343 of its 512 cells).
    pub fn trilinear(&self, u: glam::Vec3) -> f32 {
        let floor = u.floor();
        let t = u - floor;
        let ijk = floor.as_ivec3();
        let (coord, _) = node_in_block(ijk);
        let local = ijk - coord * BLOCK_DIM;
        let one_block = local.max_element() < BLOCK_DIM - 1;
        let stored = one_block.then(|| self.find(coord)).flatten();
        let at = |c: IVec3| match stored {
            Some(id) => {
                let l = local + c;
                self.block(id).values[node_offset(l.x, l.y, l.z)].to_f32()
            }
            None => self.value(ijk + c),
        };
        let lerp = |a: f32, b: f32, s: f32| a + (b - a) * s;
        let edge = |y: i32, z: i32| lerp(at(IVec3::new(0, y, z)), at(IVec3::new(1, y, z)), t.x);
        let face = |z: i32| lerp(edge(0, z), edge(1, z), t.y);
        lerp(face(0), face(1), t.z)
    }

    /// The block at `coord`, created from its tile (every node at the tile's side) if absent.
    pub(crate) fn touch(&mut self, coord: IVec3) -> BlockId {
        if let Some(id) = self.find(coord) {
            return id;
        }
        let value = self.tile_value(coord);
        self.inside.remove(&coord);
        self.around_fresh = false;
        let id = BlockId(self.blocks.len() as u32);
        if self.blocks.len() == self.blocks.capacity() {
            // Grow by 1/32 rather than doubling: a block is 1–2 KB and the band moves by a
            // few blocks per step, so memory stays within a few percent of what is used.
            self.blocks.reserve_exact(self.blocks.len() / 32 + 16);
        }
        self.blocks.push(Block::filled(coord, value));
        self.index.insert(coord, id);
        id
    }

    /// Room for `more` blocks, to [`SparseGrid::touch`] many at once without regrowing.
    pub(crate) fn reserve_blocks(&mut self, more: usize) {
        self.blocks.reserve_exact(more);
        self.index.reserve(more);
    }

    /// Marks an unstored block as wholly inside (`true`) or outside.
    pub(crate) fn set_tile(&mut self, coord: IVec3, inside: bool) {
        debug_assert!(self.find(coord).is_none());
        self.around_fresh = false;
        if inside {
            self.inside.insert(coord);
        } else {
            self.inside.remove(&coord);
        }
    }

    /// Drops the blocks `retire` says to, turning each into a tile of its side.
    pub(crate) fn retire_blocks(&mut self, retire: impl Fn(&Block<P>) -> bool) {
        let mut i = 0;
        while i < self.blocks.len() {
            if retire(&self.blocks[i]) {
                self.around_fresh = false;
                let block = self.blocks.swap_remove(i);
                self.index.remove(&block.coord);
                if block.values[0].to_f32() < 0.0 {
                    self.inside.insert(block.coord);
                }
                if i < self.blocks.len() {
                    let moved = self.blocks[i].coord;
                    self.index.insert(moved, BlockId(i as u32));
                }
            } else {
                i += 1;
            }
        }
        // Give back what a shrinking skin no longer needs (growth adds len/32 + 16).
        let len = self.blocks.len();
        if self.blocks.capacity() > len + len / 32 + 16 {
            self.blocks.shrink_to(len + len / 128);
        }
    }

    /// Releases all spare capacity (after building or restoring a grid).
    pub(crate) fn shrink_to_fit(&mut self) {
        self.blocks.shrink_to_fit();
        self.index.shrink_to_fit();
        self.inside.shrink_to_fit();
    }

    /// Every stored node's value, block by block.
    pub fn stored_values(&self) -> impl Iterator<Item = f32> + '_ {
        self.blocks
            .iter()
            .flat_map(|b| b.values.iter().map(|v| v.to_f32()))
    }

    pub fn active_node_count(&self) -> usize {
        self.blocks.iter().map(Block::active_count).sum()
    }

    /// Bytes held by the grid's potential: blocks, their index, and the inside tiles. Not
    /// the neighbourhood cache (216 bytes a block): like the skin's rates (2 KB a block)
    /// it is a step's scratch, as OpenVDB's tools' temporary buffers are not in memUsage.
    pub fn memory_bytes(&self) -> usize {
        let block = std::mem::size_of::<Block<P>>();
        let entry = std::mem::size_of::<(IVec3, BlockId)>() + 1;
        let tile = std::mem::size_of::<IVec3>() + 1;
        self.blocks.capacity() * block
            + self.index.capacity() * entry
            + self.inside.capacity() * tile
    }

    /// The 27 blocks around `coord` (itself at index 13), for halo gathering.
    pub(crate) fn neighbourhood(&self, coord: IVec3) -> [Result<BlockId, P>; 27] {
        AROUND.map(|d| {
            let c = coord + d;
            self.find(c).ok_or_else(|| self.tile_value(c))
        })
    }

    /// [`SparseGrid::neighbourhood`] of a block of this grid (one of [`SparseGrid::blocks`]):
    /// from the cache while no block or tile has changed since
    /// [`SparseGrid::refresh_neighbourhoods`].
    #[inline]
    pub(crate) fn neighbourhood_of(&self, block: &Block<P>) -> [Result<BlockId, P>; 27] {
        if self.around_fresh {
            // The block's place in the arena, from its address (a block from elsewhere
            // is looked up by coordinates instead).
            let i = (block as *const Block<P> as usize).wrapping_sub(self.blocks.as_ptr() as usize)
                / std::mem::size_of::<Block<P>>();
            if let (Some(stored), Some(around)) = (self.blocks.get(i), self.around.get(i)) {
                if std::ptr::eq(stored, block) {
                    return *around;
                }
            }
        }
        self.neighbourhood(block.coord)
    }

    /// Caches every block's neighbourhood until the blocks or tiles next change.
    pub(crate) fn refresh_neighbourhoods(&mut self) {
        if self.around_fresh {
            return;
        }
        let mut around = std::mem::take(&mut self.around);
        around.clear();
        around.par_extend(self.blocks.par_iter().map(|b| self.neighbourhood(b.coord)));
        self.around = around;
        self.around_fresh = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The trilinear value at any point is the blend of its cell's eight nodes as
    /// [`SparseGrid::value`] reads them, whether the cell lies within a stored block, across
    /// blocks, or on tiles; and a node's own value at the node.
    #[test]
    fn trilinear_blends_the_cells_nodes() {
        let mut below = crate::test_rng(11);
        let mut grid: SparseGrid<f32> = SparseGrid::new();
        for n in 0..27 {
            let c = IVec3::new(n / 9 - 1, n / 3 % 3 - 1, n % 3 - 1);
            match below(3) {
                0 => {
                    grid.touch(c);
                }
                1 => grid.set_tile(c, true),
                _ => {}
            }
        }
        for block in grid.blocks_mut() {
            for v in block.values.iter_mut() {
                *v = below(2001) as f32 / 1000.0 - 1.0;
            }
        }
        let unit = |below: &mut dyn FnMut(u64) -> u64| below(1_000_001) as f32 / 1e6;
        for _ in 0..20_000 {
            let u = Vec3::new(unit(&mut below), unit(&mut below), unit(&mut below)) * 24.0
                - Vec3::splat(8.0);
            let (l, t) = (u.floor().as_ivec3(), u - u.floor());
            let mut blend = 0.0;
            for n in 0..8 {
                let c = IVec3::new(n >> 2, (n >> 1) & 1, n & 1);
                let w = |on: i32, s: f32| if on == 1 { s } else { 1.0 - s };
                blend += w(c.x, t.x) * w(c.y, t.y) * w(c.z, t.z) * grid.value(l + c);
            }
            let got = grid.trilinear(u);
            assert!((got - blend).abs() < 1e-5, "{u}: {got} against {blend}");
            assert_eq!(grid.trilinear(l.as_vec3()), grid.value(l));
        }
    }
}
