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
    offset_coords, Block, BlockId, Halo, Potential, SparseGrid, BLOCK_DIM, BLOCK_NODES,
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

        // Pass 1: the crossed edges owned by each block (lower node inside the block).
        for_each_block(
            self.work
                .par_iter_mut()
                .zip(crossings.tables.par_iter_mut()),
            grid,
            |(work, table), block, halo, _| {
                work.points.clear();
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
                        let along = IVec3::AXES[axis].as_vec3();
                        let at = |t: f32| xf.apply(base.as_vec3() + l.as_vec3() + along * t);
                        let g = gradient(halo, l).lerp(gradient(halo, m), t);
                        table.mark(offset, axis);
                        work.points.push(at(t));
                        work.positions
                            .push(at(t.clamp(VERTEX_MARGIN, 1.0 - VERTEX_MARGIN)));
                        work.normals.push(g.normalize_or_zero());
                    }
                }
            },
        );

        // Global vertex numbering, in block order.
        mesh.clear();
        crossings.points.clear();
        let mut first = 0;
        for (work, table) in self.work.iter().zip(crossings.tables.iter_mut()) {
            first = table.number_from(first);
            crossings.points.extend_from_slice(&work.points);
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

/// Triangles of the cube with lower corner `l` (local), from its sign case.
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

/// Meshes a grid copied from VDB, `value` mapping its values into [-1, 1] with the surface
/// at 0 and negative inside; in index space, then carried by the grid's full transform.
pub fn mesh_vdb(data: &GridData, value: impl Fn(f32) -> f32) -> Mesh {
    // Inside values are kept off -1, the band's edge, so that every inside node wakes its
    // missing neighbours: liquid filling a dense grid to its last voxel (Mantaflow's `phi`
    // against the domain's walls) is closed beyond it, not left open.
    let mut grid: SparseGrid<f32> =
        SparseGrid::from_vdb(data, |v| value(v).max(-1.0 + 1.0 / 1024.0));
    close_beyond_stored(&mut grid);
    crate::grid::tube::upkeep(&mut grid);
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

/// Stores the outside blocks across a face, edge or corner from inside nodes, just short of
/// the band's edge (+1), so that the tube reaches around a dense grid's faces, edges and
/// corners and their cells are meshed.
fn close_beyond_stored(grid: &mut SparseGrid<f32>) {
    let faces_inside = |block: &Block<f32>| {
        let mut faces = [[false; 2]; 3];
        for (o, v) in block.values.iter().enumerate() {
            if *v < 0.0 {
                let l = offset_coords(o);
                for axis in 0..3 {
                    faces[axis][0] |= l[axis] == 0;
                    faces[axis][1] |= l[axis] == BLOCK_DIM - 1;
                }
            }
        }
        faces
    };
    let wanted: Vec<IVec3> = grid
        .blocks()
        .par_iter()
        .flat_map_iter(|block| {
            let faces = faces_inside(block);
            let coord = block.coord;
            (0..27)
                .map(|n| IVec3::new(n / 9 - 1, (n / 3) % 3 - 1, n % 3 - 1))
                .filter(move |d| {
                    *d != IVec3::ZERO
                        && (0..3)
                            .filter(|&a| d[a] != 0)
                            .all(|a| faces[a][usize::from(d[a] > 0)])
                })
                .map(move |d| coord + d)
        })
        .filter(|c| grid.find(*c).is_none() && !grid.inside_tiles().contains(c))
        .collect();
    for coord in wanted {
        let id = grid.touch(coord);
        grid.blocks_mut()[id.0 as usize].values = [1.0 - 1.0 / 1024.0; BLOCK_NODES];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Fixed16;
    use hashbrown::HashMap;

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
}
