//! Marching cubes over the tube (paper §3.2, §4.6): an indexed mesh with one shared vertex
//! per crossed edge, its normals from the interpolated gradient, and the crossing points
//! handed to the next step (§4.3.2).
//!
//! Cube corners and edges (corner c sits at (c & 1, c >> 1 & 1, c >> 2 & 1)):
//!
//! ```text
//!         6-----11-------7            edges by axis
//!        /|             /|            x:  0 (0-1)  1 (2-3)  2 (4-5)  3 (6-7)
//!       6 |            7 |            y:  4 (0-2)  5 (1-3)  6 (4-6)  7 (5-7)
//!      /  10          /  11           z:  8 (0-4)  9 (1-5) 10 (2-6) 11 (3-7)
//!     4------2-------5   |
//!     |   |          |   |      z
//!     |   2------1---|---3      |  y
//!     8  /           9  /       | /
//!     | 4            | 5        |/
//!     |/             |/         +---- x
//!     0------0-------1
//! ```
//!
//! No 256-case table: each cube's polygons are assembled from its six faces. Walking a face
//! counter-clockwise seen from outside the cube, a crossing from an inside corner (φ < 0)
//! to an outside one is an *exit*, the reverse an *entry*; every entry is joined to the next
//! exit. That one rule separates inside corners on ambiguous faces, the same way from both
//! cubes sharing the face, so the mesh is closed and manifold; and each crossing point is
//! an entry on one of its faces and an exit on the other, so the segments chain into loops
//! wound with the normal pointing outward (toward φ > 0).

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::grid::{
    node_offset, offset_coords, Block, BlockId, Halo, Potential, SparseGrid, BLOCK_DIM, BLOCK_NODES,
};
use crate::mesh::Mesh;
use crate::vdb::GridData;

/// Corners of each edge, ordered along its axis.
const EDGE_CORNERS: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// Faces as corner cycles, counter-clockwise seen from outside: -x +x -y +y -z +z.
const FACES: [[usize; 4]; 6] = [
    [0, 4, 6, 2],
    [1, 3, 7, 5],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 2, 3, 1],
    [4, 5, 7, 6],
];

const fn corner_offset(c: usize) -> IVec3 {
    IVec3::new((c & 1) as i32, ((c >> 1) & 1) as i32, ((c >> 2) & 1) as i32)
}

const fn edge_between(a: usize, b: usize) -> usize {
    let mut e = 0;
    while e < 12 {
        let (p, q) = EDGE_CORNERS[e];
        if (p == a && q == b) || (p == b && q == a) {
            return e;
        }
        e += 1;
    }
    panic!("corners are not adjacent");
}

/// Edge index of each face side (corner i to corner i+1 of `FACES`).
const FACE_EDGES: [[usize; 4]; 6] = {
    let mut t = [[0; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            t[f][i] = edge_between(FACES[f][i], FACES[f][(i + 1) % 4]);
            i += 1;
        }
        f += 1;
    }
    t
};

/// Axis of an edge.
const fn edge_axis(e: usize) -> usize {
    e / 4
}

/// Words of a block's crossed-edge mask: bit 3·offset + axis is the edge from that node
/// toward +axis.
const EDGE_WORDS: usize = 3 * BLOCK_NODES / 64;

/// The mesh vertices on the edges owned by one block's nodes, numbered in bit order from
/// `first`: a lookup is a popcount, not a hash.
#[derive(Clone, Default)]
pub struct EdgeTable {
    first: u32,
    crossed: [u64; EDGE_WORDS],
    /// Crossed edges in the words before each word.
    before: [u32; EDGE_WORDS],
}

impl EdgeTable {
    #[inline]
    fn mark(&mut self, offset: usize, axis: usize) {
        let bit = 3 * offset + axis;
        self.crossed[bit >> 6] |= 1 << (bit & 63);
    }

    /// Fixes the numbering once every crossed edge is marked; returns the next free index.
    fn number_from(&mut self, first: u32) -> u32 {
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

/// The crossing points of the last polygonization (§4.3.2), one [`EdgeTable`] per block of
/// the grid it ran on, in that grid's block order: valid until the grid next changes.
#[derive(Default)]
pub struct Crossings {
    tables: Vec<EdgeTable>,
}

impl Crossings {
    /// The tables of the 27 blocks around one block (from [`SparseGrid::neighbourhood`]).
    pub fn around<P>(&self, neighbourhood: &[Result<BlockId, P>; 27]) -> LocalCrossings<'_> {
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
pub struct LocalCrossings<'a> {
    tables: [Option<&'a EdgeTable>; 27],
}

impl LocalCrossings<'_> {
    /// The mesh vertex on the edge from local node `l` toward +`axis`, if it is crossed.
    #[inline]
    pub fn vertex(&self, l: IVec3, axis: usize) -> Option<u32> {
        let step = (l >> IVec3::splat(3)) + IVec3::ONE;
        let table = self.tables[(step.x * 9 + step.y * 3 + step.z) as usize]?;
        let local = l & IVec3::splat(BLOCK_DIM - 1);
        table.vertex(node_offset(local.x, local.y, local.z), axis)
    }
}

/// What one block contributes to the mesh.
#[derive(Default)]
struct BlockWork {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

#[derive(Default)]
pub struct Polygonizer {
    work: Vec<BlockWork>,
}

/// Index space → world space.
#[derive(Debug, Clone, Copy)]
pub struct IndexToWorld {
    pub origin: Vec3,
    pub dx: f32,
}

impl IndexToWorld {
    #[inline]
    pub fn apply(&self, ijk: Vec3) -> Vec3 {
        self.origin + ijk * self.dx
    }
}

#[inline]
fn inside(v: f32) -> bool {
    v < 0.0
}

impl Polygonizer {
    /// Meshes the zero isosurface of `grid` into `mesh` and records the crossings.
    pub fn run<P: Potential>(
        &mut self,
        grid: &SparseGrid<P>,
        xf: IndexToWorld,
        mesh: &mut Mesh,
        crossings: &mut Crossings,
    ) {
        self.work
            .resize_with(grid.block_count(), BlockWork::default);
        crossings
            .tables
            .resize_with(grid.block_count(), EdgeTable::default);

        // Pass 1: the crossed edges owned by each block (lower node inside the block).
        for_each_block(
            self.work
                .par_iter_mut()
                .zip(crossings.tables.par_iter_mut()),
            grid,
            |(work, table), block, halo, _| {
                work.positions.clear();
                work.normals.clear();
                *table = EdgeTable::default();
                let base = block.coord * BLOCK_DIM;
                for offset in block.active_offsets() {
                    let l = offset_coords(offset);
                    let fa = halo.at(l.x, l.y, l.z);
                    for axis in 0..3 {
                        let m = l + IVec3::AXES[axis];
                        let fb = halo.at(m.x, m.y, m.z);
                        if inside(fa) == inside(fb) {
                            continue;
                        }
                        let t = fa / (fa - fb);
                        let p = l.as_vec3() + IVec3::AXES[axis].as_vec3() * t;
                        let g = gradient(halo, l).lerp(gradient(halo, m), t);
                        table.mark(offset, axis);
                        work.positions.push(xf.apply(base.as_vec3() + p));
                        work.normals.push(g.normalize_or_zero());
                    }
                }
            },
        );

        // Global vertex numbering, in block order.
        mesh.clear();
        let mut first = 0;
        for (work, table) in self.work.iter().zip(crossings.tables.iter_mut()) {
            first = table.number_from(first);
            mesh.positions.extend_from_slice(&work.positions);
            mesh.normals.extend_from_slice(&work.normals);
        }

        // Pass 2: the cubes whose lower corner is an active node of the block.
        let shared = &*crossings;
        for_each_block(
            self.work.par_iter_mut(),
            grid,
            |work, block, halo, around| {
                work.triangles.clear();
                let local = shared.around(around);
                for offset in block.active_offsets() {
                    cube_triangles(halo, offset_coords(offset), &local, &mut work.triangles);
                }
            },
        );
        for work in &self.work {
            mesh.triangles.extend_from_slice(&work.triangles);
        }
    }
}

/// Visits each block of `grid` with its item, its halo (gathered only when the block has
/// active nodes) and its neighbourhood.
fn for_each_block<P: Potential, T: Send>(
    items: impl IndexedParallelIterator<Item = T>,
    grid: &SparseGrid<P>,
    visit: impl Fn(T, &Block<P>, &Halo, &[Result<BlockId, P>; 27]) + Sync,
) {
    items.zip(grid.blocks().par_iter()).for_each_init(
        Box::<Halo>::default,
        |halo, (item, block)| {
            let around = grid.neighbourhood(block.coord);
            if block.active_count() > 0 {
                halo.fill(grid, &around);
            }
            visit(item, block, halo, &around);
        },
    );
}

#[inline]
fn gradient(halo: &Halo, l: IVec3) -> Vec3 {
    let d = |axis: usize| {
        let e = IVec3::AXES[axis];
        let (lo, hi) = (l - e, l + e);
        let c = l[axis];
        if c >= BLOCK_DIM {
            halo.at(l.x, l.y, l.z) - halo.at(lo.x, lo.y, lo.z)
        } else {
            0.5 * (halo.at(hi.x, hi.y, hi.z) - halo.at(lo.x, lo.y, lo.z))
        }
    };
    Vec3::new(d(0), d(1), d(2))
}

/// Polygons of the cube with lower corner `l` (local), fanned into triangles.
fn cube_triangles(halo: &Halo, l: IVec3, crossings: &LocalCrossings, out: &mut Vec<[u32; 3]>) {
    let mut signs = 0u8;
    for c in 0..8 {
        let p = l + corner_offset(c);
        if inside(halo.at(p.x, p.y, p.z)) {
            signs |= 1 << c;
        }
    }
    if signs == 0 || signs == 0xFF {
        return;
    }
    let is_in = |c: usize| signs >> c & 1 == 1;

    // next[e] = the edge that follows crossed edge e along its loop.
    let mut next = [u8::MAX; 12];
    for (face, edges) in FACES.iter().zip(FACE_EDGES.iter()) {
        let mut events = [(0u8, false); 4];
        let mut n = 0;
        for i in 0..4 {
            let (a, b) = (face[i], face[(i + 1) % 4]);
            if is_in(a) != is_in(b) {
                events[n] = (edges[i] as u8, is_in(b));
                n += 1;
            }
        }
        for i in 0..n {
            let (edge, entry) = events[i];
            if entry {
                next[edge as usize] = events[(i + 1) % n].0;
            }
        }
    }

    // Every crossed edge of an active cube has a vertex while the tube is valid; if one is
    // missing (a skin that jumped a node), the cube is left out rather than guessed.
    let mut vertices = [0u32; 12];
    for e in 0..12 {
        if next[e] != u8::MAX {
            let (a, _) = EDGE_CORNERS[e];
            match crossings.vertex(l + corner_offset(a), edge_axis(e)) {
                Some(v) => vertices[e] = v,
                None => return,
            }
        }
    }
    let vertex = |e: usize| vertices[e];
    let mut done = 0u16;
    for start in 0..12 {
        if next[start] == u8::MAX || done >> start & 1 == 1 {
            continue;
        }
        let mut lp = [0u32; 12];
        let mut len = 0;
        let mut e = start;
        loop {
            done |= 1 << e;
            lp[len] = vertex(e);
            len += 1;
            e = next[e] as usize;
            if e == start || len == 12 {
                break;
            }
        }
        for i in 1..len.saturating_sub(1) {
            out.push([lp[0], lp[i], lp[i + 1]]);
        }
    }
}

/// Meshes a grid copied from VDB, `value` mapping its values into [-1, 1] with the surface
/// at 0 and negative inside; in index space, then carried by the grid's full transform.
pub fn mesh_vdb(data: &GridData, value: impl Fn(f32) -> f32) -> Mesh {
    let mut grid: SparseGrid<f32> = SparseGrid::from_vdb(data, value);
    crate::skin::band::upkeep(&mut grid);
    let index = IndexToWorld {
        origin: Vec3::ZERO,
        dx: 1.0,
    };
    let mut mesh = Mesh::default();
    Polygonizer::default().run(&grid, index, &mut mesh, &mut Crossings::default());
    let xf = &data.transform;
    let to_world =
        |p: Vec3| Vec3::from(xf.index_to_world(p.as_dvec3().to_array()).map(|c| c as f32));
    let origin = to_world(Vec3::ZERO);
    for p in &mut mesh.positions {
        *p = to_world(*p);
    }
    for n in &mut mesh.normals {
        *n = (to_world(*n) - origin).normalize_or_zero();
    }
    let axes = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| to_world(a) - origin);
    if axes[0].cross(axes[1]).dot(axes[2]) < 0.0 {
        // A mirroring transform turns the winding inside out.
        mesh.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    }
    mesh
}
