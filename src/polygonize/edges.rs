//! Mesh vertices by grid edge: each block numbers the crossed edges its nodes own (the
//! edge from a node toward +x, +y or +z), so a lookup is a popcount, not a hash. Kept
//! after meshing as the crossing points of §4.3.2.

use glam::IVec3;

use crate::grid::{node_offset, BlockId, BLOCK_DIM, BLOCK_NODES};

/// Words of a block's crossed-edge mask: bit 3·offset + axis is the edge from that node
/// toward +axis.
const EDGE_WORDS: usize = 3 * BLOCK_NODES / 64;

/// The mesh vertices on the edges owned by one block's nodes, numbered in bit order from
/// `first`.
#[derive(Clone, Default)]
pub(crate) struct EdgeTable {
    first: u32,
    crossed: [u64; EDGE_WORDS],
    /// Crossed edges in the words before each word.
    before: [u32; EDGE_WORDS],
}

impl EdgeTable {
    #[inline]
    pub(super) fn mark(&mut self, offset: usize, axis: usize) {
        let bit = 3 * offset + axis;
        self.crossed[bit >> 6] |= 1 << (bit & 63);
    }

    /// Fixes the numbering once every crossed edge is marked; returns the next free index.
    pub(super) fn number_from(&mut self, first: u32) -> u32 {
        self.first = first;
        let mut count = 0;
        for (before, word) in self.before.iter_mut().zip(self.crossed) {
            *before = count;
            count += word.count_ones();
        }
        first + count
    }

    #[inline]
    fn vertex(&self, offset: usize, axis: usize) -> Option<u32> {
        let bit = 3 * offset + axis;
        let word = self.crossed[bit >> 6];
        let below = word & ((1u64 << (bit & 63)) - 1);
        (word >> (bit & 63) & 1 == 1)
            .then(|| self.first + self.before[bit >> 6] + below.count_ones())
    }
}

/// The crossing points of the last polygonization (§4.3.2), one `EdgeTable` per block of
/// the grid it ran on, in that grid's block order: valid until the grid next changes.
#[derive(Default)]
pub struct Crossings {
    pub(super) tables: Vec<EdgeTable>,
    /// The exact crossing point of each mesh vertex, by vertex index (the mesh keeps its
    /// vertices a margin away from the nodes).
    pub(super) points: Vec<glam::Vec3>,
}

impl Crossings {
    pub(crate) fn points(&self) -> &[glam::Vec3] {
        &self.points
    }

    /// The tables of the 27 blocks around one block (from `SparseGrid::neighbourhood`).
    pub(crate) fn around<P>(&self, neighbourhood: &[Result<BlockId, P>; 27]) -> LocalCrossings<'_> {
        LocalCrossings {
            tables: std::array::from_fn(|n| {
                neighbourhood[n]
                    .as_ref()
                    .ok()
                    .and_then(|id| self.tables.get(id.0 as usize))
            }),
        }
    }
}

/// Crossing lookups around one block, by local node coordinates in -1..=8.
pub(crate) struct LocalCrossings<'a> {
    tables: [Option<&'a EdgeTable>; 27],
}

impl LocalCrossings<'_> {
    /// The mesh vertex on the edge from local node `l` toward +`axis`, if it is crossed.
    #[inline]
    pub(crate) fn vertex(&self, l: IVec3, axis: usize) -> Option<u32> {
        let step = (l >> IVec3::splat(3)) + IVec3::ONE;
        let table = self.tables[(step.x * 9 + step.y * 3 + step.z) as usize]?;
        let local = l & IVec3::splat(BLOCK_DIM - 1);
        table.vertex(node_offset(local.x, local.y, local.z), axis)
    }
}
