//! Marching cubes over the tube (paper §3.2, §4.6): an indexed mesh with one shared vertex
//! per crossed edge, its normals from the interpolated gradient, and the crossing points
//! handed to the next step (§4.3.2).
//!
//! The cases and their diagram are in `polygonize/cases.rs`; vertices are found by edge in
//! `polygonize/edges.rs`.

mod cases;
mod edges;

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::grid::{
    around_bit, bits, neighbour_steps, node_offset, row_bits, sides_of_rows, Block, BlockId, Halo,
    IndexToWorld, InsideRows, Potential, SparseGrid, TileSides, AROUND, BLOCK_DIM,
};
use crate::mesh::Mesh;
use crate::volume::GridData;

pub use edges::Crossings;
pub(crate) use edges::LocalCrossings;

use cases::{corner_offset, edge_axis, EDGE_CORNERS};
use edges::EdgeTable;

/// What one block contributes to the mesh.
#[derive(Default)]
struct BlockWork {
    points: Vec<Vec3>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

#[derive(Default)]
pub struct Polygonizer {
    work: Vec<BlockWork>,
    /// Each block's sides, kept from pass 1 for pass 2's cubes.
    sides: Vec<InsideRows>,
    /// The crossings' exact points are left out (a mesh without a solver reading them).
    mesh_only: bool,
}

#[inline]
fn inside(v: f32) -> bool {
    v < 0.0
}

/// Closest a mesh vertex comes to a node, in voxels: a node at exactly 0 (outside) would
/// otherwise put the vertices of all its crossed edges at one point and their triangles
/// at zero area. Only the mesh keeps this margin; the crossing points the solver reads
/// (§4.3.2) are exact, or a node near the skin would be pushed off it.
pub const VERTEX_MARGIN: f32 = 1.0 / 256.0;

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
        self.sides
            .resize_with(grid.block_count(), InsideRows::default);

        // Pass 1: the crossed edges owned by each block (lower node inside the block).
        let mesh_only = self.mesh_only;
        for_each_block(
            self.work
                .par_iter_mut()
                .zip(crossings.tables.par_iter_mut())
                .zip(self.sides.par_iter_mut()),
            grid,
            |((work, table), sides), block, halo, _| {
                block_crossings((work, table, sides), block, halo, xf, mesh_only)
            },
        );

        // Global vertex numbering, in block order.
        mesh.clear();
        crossings.points.clear();
        let mut first = 0;
        for table in crossings.tables.iter_mut() {
            first = table.number_from(first);
        }
        let work = &self.work;
        concat(&mut crossings.points, work.iter().map(|w| &w.points[..]));
        concat(&mut mesh.positions, work.iter().map(|w| &w.positions[..]));
        concat(&mut mesh.normals, work.iter().map(|w| &w.normals[..]));

        // Pass 2: the cubes whose lower corner is an active node of the block, from the
        // sides pass 1 kept (no halo to gather again).
        let shared = &*crossings;
        self.work
            .par_iter_mut()
            .zip(self.sides.par_iter())
            .zip(grid.blocks().par_iter())
            .for_each(|((work, rows), block)| {
                block_cubes(work, rows, block, grid, shared);
            });
        concat(
            &mut mesh.triangles,
            self.work.iter().map(|w| &w.triangles[..]),
        );
    }
}

/// Pass 1 for one block: the crossed edges whose lower node is in it, their vertices
/// (and crossing points, unless `mesh_only`) and normals into `work`, marked in `table`;
/// the block's `sides`, kept for pass 2.
fn block_crossings<P: Potential>(
    (work, table, sides): (&mut BlockWork, &mut EdgeTable, &mut InsideRows),
    block: &Block<P>,
    halo: &Halo,
    xf: IndexToWorld,
    mesh_only: bool,
) {
    work.points.clear();
    work.positions.clear();
    work.normals.clear();
    *table = EdgeTable::default();
    let base = block.coord * BLOCK_DIM;
    *sides = InsideRows::of(halo);
    let rows = &*sides;
    // Bit z: the edge from node z along x, y, z changes side.
    let crossed_from = |x: i32, y: i32| {
        let r = rows.at(x, y);
        [
            (r ^ rows.at(x + 1, y)) >> 1,
            (r ^ rows.at(x, y + 1)) >> 1,
            (r ^ (r >> 1)) >> 1,
        ]
    };
    // Room for them all at once (a first mesh grows no vector edge by edge).
    let count: u32 = block
        .active_rows()
        .map(|(x, y, active)| {
            let crossed = crossed_from(x, y);
            crossed
                .iter()
                .map(|c| (c & active).count_ones())
                .sum::<u32>()
        })
        .sum();
    work.positions.reserve(count as usize);
    work.normals.reserve(count as usize);
    if !mesh_only {
        work.points.reserve(count as usize);
    }
    for (x, y, active) in block.active_rows() {
        let crossed = crossed_from(x, y);
        for z in bits(active & (crossed[0] | crossed[1] | crossed[2])) {
            let l = IVec3::new(x, y, z);
            let offset = node_offset(x, y, z);
            let fa = halo.at(l.x, l.y, l.z);
            for axis in (0..3).filter(|&a| crossed[a] >> z & 1 == 1) {
                let m = l + IVec3::AXES[axis];
                let fb = halo.at(m.x, m.y, m.z);
                let t = fa / (fa - fb);
                let along = IVec3::AXES[axis].as_vec3();
                let at = |t: f32| xf.apply(base.as_vec3() + l.as_vec3() + along * t);
                let g = gradient(halo, l).lerp(gradient(halo, m), t);
                table.mark(offset, axis);
                if !mesh_only {
                    work.points.push(at(t));
                }
                work.positions
                    .push(at(t.clamp(VERTEX_MARGIN, 1.0 - VERTEX_MARGIN)));
                work.normals.push(g.normalize_or_zero());
            }
        }
    }
}

/// Pass 2 for one block: the triangles of the cubes whose lower corner is one of its
/// active nodes, from the sides pass 1 kept (`rows`; no halo to gather again) and the
/// vertices it numbered (`shared`).
fn block_cubes<P: Potential>(
    work: &mut BlockWork,
    rows: &InsideRows,
    block: &Block<P>,
    grid: &SparseGrid<P>,
    shared: &Crossings,
) {
    work.triangles.clear();
    if block.active_count() == 0 {
        return;
    }
    // A closed surface has about two triangles per vertex.
    work.triangles.reserve(2 * work.positions.len());
    let local = shared.around(&grid.neighbourhood_of(block));
    for (x, y, active) in block.active_rows() {
        let corners = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)];
        let all = corners
            .iter()
            .fold(u16::MAX, |a, &(i, j)| a & rows.at(i, j));
        let any = corners.iter().fold(0, |a, &(i, j)| a | rows.at(i, j));
        // Bit z: the cube from node z has corners on both sides.
        let uniform = (all & (all >> 1)) | (!any & !(any >> 1));
        for z in bits(active & (!uniform >> 1)) {
            cube_triangles(rows, IVec3::new(x, y, z), &local, &mut work.triangles);
        }
    }
}

/// `out` becomes the `parts` one after another, copied in parallel (a mesh of millions of
/// triangles is gathered from every block's work).
fn concat<'a, T: Copy + Send + Sync + 'a>(out: &mut Vec<T>, parts: impl Iterator<Item = &'a [T]>) {
    let parts: Vec<&[T]> = parts.collect();
    let total = parts.iter().map(|p| p.len()).sum();
    out.clear();
    out.reserve(total);
    let mut rest = &mut out.spare_capacity_mut()[..total];
    let mut pieces = Vec::with_capacity(parts.len());
    for part in &parts {
        let (piece, tail) = std::mem::take(&mut rest).split_at_mut(part.len());
        pieces.push(piece);
        rest = tail;
    }
    pieces.into_par_iter().zip(parts).for_each(|(piece, part)| {
        for (slot, &value) in piece.iter_mut().zip(part) {
            slot.write(value);
        }
    });
    // SAFETY: the pieces tile the first `total` spare slots, and every slot was written.
    unsafe { out.set_len(total) };
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
            let around = grid.neighbourhood_of(block);
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

/// Triangles of the cube with lower corner `l` (local), from its sign case.
fn cube_triangles(
    rows: &InsideRows,
    l: IVec3,
    crossings: &LocalCrossings,
    out: &mut Vec<[u32; 3]>,
) {
    let mut signs = 0u8;
    for c in 0..8 {
        let p = l + corner_offset(c);
        signs |= ((rows.at(p.x, p.y) >> (p.z + 1)) as u8 & 1) << c;
    }
    if signs == 0 || signs == 0xFF {
        return;
    }
    let case = &cases::table()[signs as usize];
    // Every crossed edge of an active cube has a vertex while the tube is valid; if one is
    // missing (a skin that jumped a node), the cube is left out rather than guessed.
    let mut vertices = [u32::MAX; 12];
    for t in case.triangles() {
        for &e in t {
            let e = e as usize;
            if vertices[e] == u32::MAX {
                let (a, _) = EDGE_CORNERS[e];
                match crossings.vertex(l + corner_offset(a), edge_axis(e)) {
                    Some(v) => vertices[e] = v,
                    None => return,
                }
            }
        }
    }
    out.extend(
        case.triangles()
            .iter()
            .map(|t| t.map(|e| vertices[e as usize])),
    );
}

/// Distance (voxels) from local node `l` of `halo` to the triangles the polygonizer cuts
/// in the eight cells around it, vertices clamped as the mesh's are; infinite when none
/// is crossed. Within a voxel of the node the mesh lies in those cells, so whenever it
/// comes that near this is its exact distance — found from the halo alone, with no
/// index of the mesh. (The oracle of [`distances_in_cells_around`].)
#[cfg(test)]
fn distance_in_cells_around(halo: &Halo, l: IVec3) -> f32 {
    let p = l.as_vec3();
    let mut best = f32::INFINITY;
    let mut triangles = [[Vec3::ZERO; 3]; cases::MAX_TRIANGLES];
    for c in 0..8 {
        let cut = cut_cell(halo, l - IVec3::ONE + corner_offset(c), &mut triangles);
        for &[a, b, c] in &triangles[..cut] {
            best = best.min(crate::mesh::point_triangle_distance(p, a, b, c));
        }
    }
    best
}

/// The triangles the polygonizer cuts in the cell whose lowest corner is local node
/// `cell` of `halo`, vertices clamped as the mesh's are, into `out`: how many.
fn cut_cell(halo: &Halo, cell: IVec3, out: &mut [[Vec3; 3]; cases::MAX_TRIANGLES]) -> usize {
    let value = |m: IVec3| halo.at(m.x, m.y, m.z);
    let signs = (0..8).fold(0u8, |s, k| {
        s | u8::from(inside(value(cell + corner_offset(k)))) << k
    });
    if signs == 0 || signs == 0xFF {
        return 0;
    }
    let vertex = |e: u8| {
        let (a, _) = EDGE_CORNERS[e as usize];
        let along = IVec3::AXES[edge_axis(e as usize)];
        let from = cell + corner_offset(a);
        let (fa, fb) = (value(from), value(from + along));
        let t = (fa / (fa - fb)).clamp(VERTEX_MARGIN, 1.0 - VERTEX_MARGIN);
        from.as_vec3() + along.as_vec3() * t
    };
    let case = cases::table()[signs as usize].triangles();
    for (slot, t) in out.iter_mut().zip(case) {
        *slot = t.map(vertex);
    }
    case.len()
}

/// [`distance_in_cells_around`] for every node of the block flagged in `wanted` (local
/// offsets), each at most its entry of `best` on the way in (a bound it already has):
/// each crossed cell around them is cut once for all its wanted corners, where the
/// node-by-node search cuts it again for each — the same triangles, so the same
/// distances, bit for bit (a minimum does not depend on its order).
pub(crate) fn distances_in_cells_around(
    halo: &Halo,
    wanted: &[u64; 8],
    best: &mut [f32; crate::grid::BLOCK_NODES],
) {
    // Cells by their lowest corner, local -1..=7 on each axis.
    const SIDE: i32 = BLOCK_DIM + 1;
    let index = |cell: IVec3| ((cell.x + 1) * SIDE + cell.y + 1) * SIDE + cell.z + 1;
    let mut cells = [0u64; ((SIDE * SIDE * SIDE) as usize).div_ceil(64)];
    for offset in crate::grid::mask_offsets(*wanted) {
        let l = crate::grid::offset_coords(offset);
        for c in 0..8 {
            let i = index(l - IVec3::ONE + corner_offset(c)) as usize;
            cells[i / 64] |= 1 << (i % 64);
        }
    }
    let is_wanted = |n: IVec3| {
        n.cmpge(IVec3::ZERO).all() && n.cmplt(IVec3::splat(BLOCK_DIM)).all() && {
            let o = node_offset(n.x, n.y, n.z);
            wanted[o / 64] >> (o % 64) & 1 == 1
        }
    };
    let mut triangles = [[Vec3::ZERO; 3]; cases::MAX_TRIANGLES];
    let mut boxes = [(Vec3::ZERO, Vec3::ZERO); cases::MAX_TRIANGLES];
    for i in crate::grid::mask_offsets(cells) {
        let i = i as i32;
        let cell = IVec3::new(i / (SIDE * SIDE), i / SIDE % SIDE, i % SIDE) - IVec3::ONE;
        let cut = cut_cell(halo, cell, &mut triangles);
        if cut == 0 {
            continue;
        }
        for (aabb, t) in boxes.iter_mut().zip(&triangles[..cut]) {
            *aabb = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        }
        for k in 0..8 {
            let n = cell + corner_offset(k);
            if !is_wanted(n) {
                continue;
            }
            let (p, slot) = (n.as_vec3(), &mut best[node_offset(n.x, n.y, n.z)]);
            for (&[a, b, c], &(lo, hi)) in triangles.iter().zip(&boxes).take(cut) {
                // A triangle whose box lies farther than the best so far cannot lower
                // it (the margin covers rounding: the minimum stays bit for bit).
                let outside = (lo - p).max(p - hi).max(Vec3::ZERO);
                if outside.length_squared() > *slot * *slot * (1.0 + 1e-4) {
                    continue;
                }
                *slot = slot.min(crate::mesh::point_triangle_distance(p, a, b, c));
            }
        }
    }
}

/// Meshes a grid copied from VDB, `value` mapping its values into [-1, 1] with the surface
/// at 0 and negative inside: cut in world space when the voxels are the world's axes
/// scaled, else in index space and then carried by the grid's full transform.
pub fn mesh_vdb(data: GridData, value: impl Fn(f32) -> f32 + Sync) -> Mesh {
    let mut grid = SparseGrid::<f32>::new();
    let sides = grid.import_with_sides(&data, value);
    // Its copy in the grid is all that is read from here on.
    let xf = data.transform;
    drop(data);
    // Not a skin's tube: the grid's values may jump from deep inside to its background
    // (liquid filling a dense grid to its walls, as Mantaflow's `phi`), so every node of
    // every block is visited, and the blocks beyond such jumps are stored.
    store_blocks_across_crossings(&mut grid, &sides);
    grid.blocks_mut()
        .iter_mut()
        .for_each(|b| b.active = [u64::MAX; 8]);
    let mut polygonizer = Polygonizer {
        mesh_only: true,
        ..Polygonizer::default()
    };
    let mut mesh = Mesh::default();
    if let Some((dx, origin)) = xf.scale_translate() {
        // Voxels along the axes: vertices land in world space as the cubes are cut.
        let index = IndexToWorld {
            origin: Vec3::from(origin.map(|c| c as f32)),
            dx: dx as f32,
        };
        polygonizer.run(&grid, index, &mut mesh, &mut Crossings::default());
        return mesh;
    }
    let index = IndexToWorld {
        origin: Vec3::ZERO,
        dx: 1.0,
    };
    polygonizer.run(&grid, index, &mut mesh, &mut Crossings::default());
    let to_world =
        |p: Vec3| Vec3::from(xf.index_to_world(p.as_dvec3().to_array()).map(|c| c as f32));
    let origin = to_world(Vec3::ZERO);
    mesh.positions
        .par_iter_mut()
        .for_each(|p| *p = to_world(*p));
    mesh.normals
        .par_iter_mut()
        .for_each(|n| *n = (to_world(*n) - origin).normalize_or_zero());
    let axes = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| to_world(a) - origin);
    if axes[0].cross(axes[1]).dot(axes[2]) < 0.0 {
        // A mirroring transform turns the winding inside out.
        mesh.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    }
    mesh
}

/// Stores the unstored blocks a crossed cube starts in, so that the polygonizer visits
/// every crossed cube, and marks inside the unstored blocks their halos read:
/// - each unstored block across a face, edge or corner from nodes of the other side (an
///   outside tile next to inside nodes, as beyond a dense grid's walls; an inside tile next
///   to outside nodes);
/// - tiles of both sides that touch with no leaf between (pruned values of both signs, as
///   in Mantaflow's `phi`), both of them.
fn store_blocks_across_crossings(grid: &mut SparseGrid<f32>, sides: &TileSides) {
    let stored = &*grid;
    let mut wanted: Vec<IVec3> = stored
        .blocks()
        .par_iter()
        .flat_map_iter(|block| {
            // The blocks across the faces, edges and corners where inside / outside nodes lie.
            let rows: [u16; 64] = std::array::from_fn(|i| {
                let start = i * BLOCK_DIM as usize;
                row_bits(&block.values[start..start + BLOCK_DIM as usize], inside)
            });
            let row = |x: i32, y: i32| rows[(x * BLOCK_DIM + y) as usize];
            let nodes = [sides_of_rows(row), sides_of_rows(|x, y| !row(x, y) & 0xFF)];
            let coord = block.coord;
            AROUND.into_iter().filter_map(move |d| {
                let c = coord + d;
                // Nodes of the other side than the tile's, where the tile touches the block
                // (a leaf's neighbours are marked inside when they are).
                let other = nodes[usize::from(stored.inside_tiles().contains(&c))];
                (other & around_bit(d) != 0 && stored.find(c).is_none()).then_some(c)
            })
        })
        .collect();
    let tiles: Vec<(IVec3, bool)> = stored
        .exposed_inside_tiles()
        .into_iter()
        .map(|c| (c, true))
        .chain(sides.tile_blocks())
        .collect();
    wanted.extend(stored.tile_borders(&tiles, |c| sides.unmarked_inside(c)));
    wanted.sort_unstable_by_key(|c| c.to_array());
    wanted.dedup();
    let unmarked_inside = |grid: &SparseGrid<f32>, c: IVec3| {
        grid.find(c).is_none() && !grid.inside_tiles().contains(&c) && sides.unmarked_inside(c)
    };
    // Stored filled with their side; then their halos read their neighbours' sides.
    for &c in &wanted {
        if unmarked_inside(grid, c) {
            grid.set_tile(c, true);
        }
    }
    grid.reserve_blocks(wanted.len());
    for &c in &wanted {
        grid.touch(c);
    }
    for &c in &wanted {
        for n in neighbour_steps().map(|d| c + d) {
            if unmarked_inside(grid, n) {
                grid.set_tile(n, true);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::offset_coords;
    use crate::grid::{Fixed16, BLOCK_NODES};
    use hashbrown::HashMap;

    #[test]
    fn distance_in_cells_around_is_the_mesh_distance_within_a_voxel() {
        use crate::target::{sample, Sphere, Target};
        let dx = 0.05;
        let sphere = Sphere {
            center: Vec3::new(0.013, -0.021, 0.007),
            radius: 0.41,
        };
        let data = sample::level_set(&sphere, dx, 3.0);
        let mut grid = SparseGrid::<f32>::new();
        grid.import(&data, |v| v);
        let mesh = mesh_vdb(data, |v| v);
        let brute = |p: Vec3| {
            mesh.triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| mesh.positions[v as usize] / dx);
                    crate::mesh::point_triangle_distance(p, a, b, c)
                })
                .fold(f32::INFINITY, f32::min)
        };
        let mut halo = Box::<Halo>::default();
        let mut checked = 0;
        for block in grid.blocks() {
            halo.gather(&grid, block);
            for offset in 0..BLOCK_NODES {
                let l = offset_coords(offset);
                let ijk = block.coord * BLOCK_DIM + l;
                if sphere.distance(ijk.as_vec3() * dx).abs() > 1.5 * dx {
                    continue;
                }
                let exact = brute(ijk.as_vec3());
                if exact < 1.0 {
                    let found = distance_in_cells_around(&halo, l);
                    assert!(
                        (found - exact).abs() < 1e-4,
                        "{ijk}: {found} against {exact}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    #[test]
    fn distances_by_block_are_those_node_by_node_bit_for_bit() {
        use crate::target::{sample, Sphere};
        let sphere = Sphere {
            center: Vec3::new(0.013, -0.021, 0.007),
            radius: 0.33,
        };
        let data = sample::level_set(&sphere, 0.05, 3.0);
        let mut grid = SparseGrid::<f32>::new();
        grid.import(&data, |v| v);
        // Roughened in steps of 1/32, so that thin parts, necks and nodes at exactly 0
        // occur.
        for block in grid.blocks_mut() {
            let base = block.coord * BLOCK_DIM;
            for (offset, v) in block.values.iter_mut().enumerate() {
                let p = base + offset_coords(offset);
                let h = [73_856_093, 19_349_663, 83_492_791]
                    .iter()
                    .zip(p.to_array())
                    .fold(0u32, |h, (k, c)| h ^ (c as u32).wrapping_mul(*k));
                *v = ((*v + (h % 17) as f32 / 40.0 - 0.2) * 32.0).round() / 32.0;
            }
        }
        let mut halo = Box::<Halo>::default();
        let (mut compared, mut finite) = (0, 0);
        for (b, block) in grid.blocks().iter().enumerate() {
            halo.gather(&grid, block);
            // Every other node wanted, every third block with a bound to stay under.
            let bound = if b % 3 == 0 { 0.4 } else { f32::INFINITY };
            let mut wanted = [0u64; 8];
            let mut best = [f32::NAN; BLOCK_NODES];
            for offset in (b % 2..BLOCK_NODES).step_by(2) {
                wanted[offset / 64] |= 1 << (offset % 64);
                best[offset] = bound;
            }
            distances_in_cells_around(&halo, &wanted, &mut best);
            for offset in 0..BLOCK_NODES {
                let l = offset_coords(offset);
                if wanted[offset / 64] >> (offset % 64) & 1 == 0 {
                    assert!(best[offset].is_nan(), "an unwanted node was written");
                    continue;
                }
                let one = distance_in_cells_around(&halo, l).min(bound);
                assert_eq!(best[offset].to_bits(), one.to_bits(), "{l} in block {b}");
                compared += 1;
                finite += usize::from(one.is_finite() && one < 0.4);
            }
        }
        assert!(compared > 5000 && finite > 1000, "{compared} {finite}");
    }

    /// A repeatable rough potential on nodes `lo..hi`: a wavy field a third of a voxel
    /// steep, plus noise, in steps of 1/16 (so many nodes sit at exactly 0), +1 outside.
    fn rough(seed: u64, lo: IVec3, hi: IVec3) -> impl Fn(IVec3) -> f32 {
        move |p: IVec3| {
            if p.cmplt(lo).any() || p.cmpge(hi).any() {
                return 1.0;
            }
            let q = (p - lo).as_vec3();
            let centre = (hi - lo).as_vec3() * 0.5;
            let wave = (q.x * 0.7).sin() + (q.y * 0.5 + seed as f32).cos() + (q.z * 0.9).sin();
            let smooth = ((q - centre).length() - 6.0 + wave) / 3.0;
            let mut h = (p.x as u64).wrapping_mul(73_856_093)
                ^ (p.y as u64).wrapping_mul(19_349_663)
                ^ (p.z as u64).wrapping_mul(83_492_791)
                ^ seed.wrapping_mul(2_654_435_761);
            h ^= h >> 13;
            h = h.wrapping_mul(0x5bd1_e995);
            let noise = ((h >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.4;
            ((smooth + noise) * 16.0).round().clamp(-16.0, 16.0) / 16.0
        }
    }

    /// Triangles as position triples, each rotated to start at its smallest corner (so
    /// the winding is kept), sorted.
    fn canonical(mesh: &Mesh) -> Vec<[[u32; 3]; 3]> {
        let mut out: Vec<[[u32; 3]; 3]> = mesh
            .triangles
            .iter()
            .map(|t| {
                let c = t.map(|i| mesh.positions[i as usize].to_array().map(f32::to_bits));
                let first = (0..3).min_by_key(|&k| c[k]).unwrap();
                [c[first], c[(first + 1) % 3], c[(first + 2) % 3]]
            })
            .collect();
        out.sort_unstable();
        out
    }

    /// Marching cubes over every cube of the box at once, with no blocks, halos or edge
    /// tables: the same case table and vertex placement.
    fn dense(value: &dyn Fn(IVec3) -> f32, lo: IVec3, hi: IVec3, xf: IndexToWorld) -> Mesh {
        let mut mesh = Mesh::default();
        let mut vertex: HashMap<(IVec3, usize), u32> = HashMap::new();
        for x in lo.x - 1..hi.x + 1 {
            for y in lo.y - 1..hi.y + 1 {
                for z in lo.z - 1..hi.z + 1 {
                    let l = IVec3::new(x, y, z);
                    let mut signs = 0u8;
                    for c in 0..8 {
                        if inside(value(l + corner_offset(c))) {
                            signs |= 1 << c;
                        }
                    }
                    for t in cases::table()[signs as usize].triangles() {
                        let tri = t.map(|e| {
                            let (a, _) = EDGE_CORNERS[e as usize];
                            let (node, axis) = (l + corner_offset(a), edge_axis(e as usize));
                            *vertex.entry((node, axis)).or_insert_with(|| {
                                let (fa, fb) = (value(node), value(node + IVec3::AXES[axis]));
                                let t = (fa / (fa - fb)).clamp(VERTEX_MARGIN, 1.0 - VERTEX_MARGIN);
                                let along = IVec3::AXES[axis].as_vec3();
                                mesh.positions.push(xf.apply(node.as_vec3() + along * t));
                                mesh.positions.len() as u32 - 1
                            })
                        });
                        mesh.triangles.push(tri);
                    }
                }
            }
        }
        mesh
    }

    fn block_by_block_matches_dense<P: Potential>() {
        let xf = IndexToWorld {
            origin: Vec3::new(0.25, -1.0, 0.5),
            dx: 0.1,
        };
        for seed in 0..6u64 {
            // Boxes straddling blocks at odd offsets, negative coordinates included.
            let lo = IVec3::new(-11, 3, -6) + IVec3::splat(seed as i32);
            let hi = lo + IVec3::new(19, 17, 21);
            let value = rough(seed, lo, hi);
            let mut grid: SparseGrid<P> = SparseGrid::new();
            let (blo, bhi) = (lo >> IVec3::splat(3), (hi - IVec3::ONE) >> IVec3::splat(3));
            for x in blo.x..=bhi.x {
                for y in blo.y..=bhi.y {
                    for z in blo.z..=bhi.z {
                        grid.touch(IVec3::new(x, y, z));
                    }
                }
            }
            for block in grid.blocks_mut() {
                let base = block.coord * BLOCK_DIM;
                for offset in 0..BLOCK_NODES {
                    block.values[offset] = P::from_f32(value(base + offset_coords(offset)));
                }
            }
            crate::grid::tube::upkeep(&mut grid);
            let mut mesh = Mesh::default();
            Polygonizer::default().run(&grid, xf, &mut mesh, &mut Crossings::default());
            let zeros = (lo.x..hi.x)
                .flat_map(|x| (lo.y..hi.y).flat_map(move |y| (lo.z..hi.z).map(move |z| (x, y, z))))
                .filter(|&(x, y, z)| value(IVec3::new(x, y, z)) == 0.0)
                .count();
            assert!(zeros > 20, "seed {seed}: only {zeros} exact zeros");
            let reference = dense(&|p| P::from_f32(value(p)).to_f32(), lo, hi, xf);
            assert!(mesh.triangles.len() > 500, "seed {seed}");
            assert_eq!(canonical(&mesh), canonical(&reference), "seed {seed}");
            let check = mesh.check();
            assert!(check.is_clean(), "seed {seed}: {check}");
        }
    }

    #[test]
    fn rough_f32_potentials_mesh_the_same_block_by_block_and_in_one_dense_pass() {
        block_by_block_matches_dense::<f32>();
    }

    #[test]
    fn rough_fixed16_potentials_mesh_the_same_block_by_block_and_in_one_dense_pass() {
        block_by_block_matches_dense::<Fixed16>();
    }

    #[test]
    fn blocks_are_stored_across_the_faces_edges_and_corners_where_the_other_side_lies() {
        let stored = |inside_nodes: &[IVec3]| {
            let mut grid = SparseGrid::<f32>::new();
            grid.touch(IVec3::ZERO);
            for l in inside_nodes {
                grid.blocks_mut()[0].values[node_offset(l.x, l.y, l.z)] = -0.5;
            }
            store_blocks_across_crossings(&mut grid, &TileSides::default());
            let mut coords: Vec<IVec3> = grid.blocks().iter().map(|b| b.coord).collect();
            coords.sort_by_key(|c| c.to_array());
            coords
        };
        // Inside nodes on the +x and +y faces, not on their edge: no block across the edge.
        let faces = stored(&[IVec3::new(7, 3, 3), IVec3::new(3, 7, 3)]);
        assert_eq!(faces, vec![IVec3::ZERO, IVec3::Y, IVec3::X]);
        // One on the edge reaches the block across it too.
        let edge = stored(&[IVec3::new(7, 7, 3)]);
        assert_eq!(
            edge,
            vec![IVec3::ZERO, IVec3::Y, IVec3::X, IVec3::new(1, 1, 0)]
        );
        // Every cube a crossing cuts lies in stored blocks: the mesh is closed.
        let mut grid = SparseGrid::<f32>::new();
        grid.touch(IVec3::ZERO);
        grid.blocks_mut()[0].values[node_offset(7, 7, 7)] = -0.5;
        store_blocks_across_crossings(&mut grid, &TileSides::default());
        assert_eq!(grid.block_count(), 8);
        grid.blocks_mut()
            .iter_mut()
            .for_each(|b| b.active = [u64::MAX; 8]);
        let mut mesh = Mesh::default();
        let xf = IndexToWorld {
            origin: Vec3::ZERO,
            dx: 1.0,
        };
        Polygonizer::default().run(&grid, xf, &mut mesh, &mut Crossings::default());
        assert_eq!(mesh.triangles.len(), 8);
        assert!(mesh.check().is_clean());
    }

    #[test]
    fn a_vdb_sphere_meshes_outward_in_world_space_under_any_transform() {
        use crate::target::{sample, Sphere};
        let dx = 0.05;
        let sphere = Sphere {
            center: Vec3::new(0.1, -0.2, 0.3),
            radius: 0.5,
        };
        let base = sample::level_set(&sphere, dx, 3.0);
        let (c, s) = (0.6f64, 0.8f64);
        let d = 0.02f64; // another voxel size, so that the index space must be mapped
        #[rustfmt::skip]
        let transforms: [[f64; 16]; 4] = [
            [d, 0.0, 0.0, 0.0,  0.0, d, 0.0, 0.0,  0.0, 0.0, d, 0.0,  1.0, 2.0, -3.0, 1.0],
            [d * c, d * s, 0.0, 0.0,  -d * s, d * c, 0.0, 0.0,  0.0, 0.0, d, 0.0,  1.0, 2.0, -3.0, 1.0],
            [-d, 0.0, 0.0, 0.0,  0.0, d, 0.0, 0.0,  0.0, 0.0, d, 0.0,  1.0, 2.0, -3.0, 1.0],
            [-d, 0.0, 0.0, 0.0,  0.0, -d, 0.0, 0.0,  0.0, 0.0, -d, 0.0,  1.0, 2.0, -3.0, 1.0],
        ];
        for matrix in transforms {
            let mut data = base.clone();
            data.transform.matrix = matrix;
            // The sphere's centre and radius in the new world.
            let index = (sphere.center / dx).as_dvec3().to_array();
            let centre = Vec3::from(data.transform.index_to_world(index).map(|v| v as f32));
            let radius = sphere.radius / dx * d as f32;
            let mesh = mesh_vdb(data, |v| v / (3.0 * dx));
            assert!(mesh.check().is_clean(), "{matrix:?}");
            let (area, volume) = mesh.area_and_volume();
            let exact = 4.0 / 3.0 * std::f64::consts::PI * f64::from(radius).powi(3);
            assert!(
                (volume / exact - 1.0).abs() < 0.01,
                "{matrix:?}: {volume} for {exact}"
            );
            assert!(area > 0.0);
            let worst = mesh
                .positions
                .iter()
                .map(|p| ((*p - centre).length() - radius).abs())
                .fold(0.0, f32::max);
            assert!(worst < 0.05 * d as f32, "{matrix:?}: {worst}");
            // Normals point away from the centre.
            let inward = mesh
                .positions
                .iter()
                .zip(&mesh.normals)
                .filter(|(p, n)| (**p - centre).dot(**n) <= 0.0)
                .count();
            assert_eq!(inward, 0, "{matrix:?}");
        }
    }

    /// Tiles alone, no leaf: pruned uniform values of both signs that meet (Mantaflow's
    /// `phi` holds such), meshed closed midway between their nodes.
    #[test]
    fn tiles_of_both_sides_meeting_with_no_leaf_between_are_meshed_closed() {
        use crate::mesh::MeshCheck;
        use crate::volume::{GridClass, Tile, Transform};
        let tiles = |background: f32, tiles: &[([i32; 3], u32, f32)]| {
            let mut data = GridData::empty(
                "phi",
                GridClass::LevelSet,
                background,
                Transform::uniform(1.0, [0.0; 3]),
            );
            for &(origin, dim, value) in tiles {
                data.tiles.push(Tile {
                    origin,
                    dim,
                    value,
                    active: true,
                });
            }
            let mesh = mesh_vdb(data, |v| v);
            let check = mesh.check();
            // A cavity alone is wound inward, as it should be.
            let closed = MeshCheck {
                inward: false,
                ..check
            };
            assert!(closed.is_clean(), "{tiles:?}: {check}");
            assert_eq!(check.inward, background < 0.0);
            assert_eq!(
                (mesh.components(), mesh.euler_characteristic()),
                (1, 2),
                "{tiles:?}"
            );
            mesh.area_and_volume().1
        };
        // One inside block in an outside world: a cube of 8 voxels, its edges chamfered.
        let cube = tiles(1.0, &[([8, 16, -8], 8, -1.0)]);
        assert!(cube > 0.9 * 512.0 && cube <= 512.0, "{cube}");
        // Beside an outside tile, across an edge only, the same.
        assert_eq!(
            tiles(1.0, &[([8, 16, -8], 8, -1.0), ([16, 24, -8], 8, 1.0)]),
            cube
        );
        // An inside tile of 128³ alone, met across its faces.
        let big = tiles(1.0, &[([128, 0, -128], 128, -1.0)]);
        let side = 128.0f64;
        assert!(big > 0.95 * side.powi(3) && big <= side.powi(3), "{big}");
        // An outside block in an inside world: a cavity, wound inward.
        assert_eq!(tiles(-1.0, &[([8, 16, -8], 8, 1.0)]), -cube);
    }
}
