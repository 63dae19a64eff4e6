//! A costly flow (a staggered velocity grid, or the mean of two) sampled once per frame at
//! the skin's own nodes, then read by trilinear interpolation: the advection's traces and
//! the backtracked target ask for the velocity about six times per node and sub-step.
//!
//! A node's velocity is a pure function of where the node is, whichever blocks happen to
//! be stored: a node outside the stored blocks is sampled on the spot, so that a resumed or
//! chunked run, whose band may hold other blocks, reads the same velocities bit for bit.

use glam::{IVec3, Vec3};
use hashbrown::HashMap;
use rayon::prelude::*;

use super::Flow;
use crate::grid::IndexToWorld;
use crate::grid::BLOCK_NODES;
use crate::grid::{block_of, node_offset, offset_coords, Potential, SparseGrid, BLOCK_DIM};

/// `flow` at the nodes of the lattice `xf`, in blocks of 8³ around a skin's band.
pub struct OnNodes<'a> {
    flow: &'a dyn Flow,
    xf: IndexToWorld,
    blocks: HashMap<IVec3, Box<[Vec3; BLOCK_NODES]>>,
}

impl<'a> OnNodes<'a> {
    pub fn new(flow: &'a dyn Flow, xf: IndexToWorld) -> Self {
        OnNodes {
            flow,
            xf,
            blocks: HashMap::new(),
        }
    }

    /// Samples the blocks holding `grid`'s active nodes and the neighbours their traces
    /// may reach (a trace moves under a voxel per sub-step, and its cell one more), those
    /// not sampled yet.
    pub(crate) fn cover<P: Potential>(&mut self, grid: &SparseGrid<P>) {
        self.cover_reaching(grid, 1);
    }

    /// [`OnNodes::cover`] for traces that move up to `reach` voxels from `grid`'s active
    /// nodes (a whole frame's): every block within `reach` + 1 nodes of them, where
    /// otherwise each cell of a trace past the blocks would sample its eight corners on
    /// the spot.
    pub(crate) fn cover_reaching<P: Potential>(&mut self, grid: &SparseGrid<P>, reach: u32) {
        let extent = reach as i32 + 1;
        let mut wanted: Vec<IVec3> = grid
            .blocks()
            .par_iter()
            .filter(|b| b.active_count() > 0)
            .flat_map_iter(|b| {
                // The active nodes' span per axis, grown by the extent.
                let (mut lo, mut hi) = (IVec3::splat(BLOCK_DIM), IVec3::splat(-1));
                for offset in b.active_offsets() {
                    let l = offset_coords(offset);
                    (lo, hi) = (lo.min(l), hi.max(l));
                }
                // The neighbours (in blocks) whose nodes meet that span.
                let first = (lo - extent).div_euclid(IVec3::splat(BLOCK_DIM));
                let last = (hi + extent).div_euclid(IVec3::splat(BLOCK_DIM));
                let coord = b.coord;
                (first.x..=last.x).flat_map(move |x| {
                    (first.y..=last.y).flat_map(move |y| {
                        (first.z..=last.z).map(move |z| coord + IVec3::new(x, y, z))
                    })
                })
            })
            .filter(|c| !self.blocks.contains_key(c))
            .collect();
        wanted.sort_unstable_by_key(|c| c.to_array());
        wanted.dedup();
        let (flow, xf) = (self.flow, self.xf);
        let sampled: Vec<(IVec3, Box<[Vec3; BLOCK_NODES]>)> = wanted
            .into_par_iter()
            .map(|coord| {
                let base = coord * BLOCK_DIM;
                let mut values = Box::new([Vec3::ZERO; BLOCK_NODES]);
                for (offset, v) in values.iter_mut().enumerate() {
                    *v = flow.velocity(xf.apply((base + offset_coords(offset)).as_vec3()));
                }
                (coord, values)
            })
            .collect();
        self.blocks.extend(sampled);
    }

    #[inline]
    fn node(&self, ijk: IVec3) -> Vec3 {
        let coord = block_of(ijk);
        match self.blocks.get(&coord) {
            Some(values) => {
                let l = ijk - coord * BLOCK_DIM;
                values[node_offset(l.x, l.y, l.z)]
            }
            None => self.flow.velocity(self.xf.apply(ijk.as_vec3())),
        }
    }
}

impl Flow for OnNodes<'_> {
    fn velocity(&self, p: Vec3) -> Vec3 {
        let q = (p - self.xf.origin) / self.xf.dx;
        let b = floor(q);
        let t = q - b.as_vec3();
        let coord = block_of(b);
        let local = b - coord * BLOCK_DIM;
        let mut corners = [Vec3::ZERO; 8];
        // The eight corners in one block unless the cell straddles a block face.
        match self.blocks.get(&coord) {
            Some(values) if local.cmplt(IVec3::splat(BLOCK_DIM - 1)).all() => {
                let o = node_offset(local.x, local.y, local.z);
                for (c, corner) in corners.iter_mut().enumerate() {
                    *corner = values[o + CORNER_OFFSETS[c]];
                }
            }
            _ => {
                for (c, corner) in corners.iter_mut().enumerate() {
                    let d = IVec3::new(c as i32 & 1, c as i32 >> 1 & 1, c as i32 >> 2 & 1);
                    *corner = self.node(b + d);
                }
            }
        }
        let lerp = |a: Vec3, b: Vec3, t: f32| a + (b - a) * t;
        let x = [0, 2, 4, 6].map(|c| lerp(corners[c], corners[c + 1], t.x));
        let y = [lerp(x[0], x[1], t.y), lerp(x[2], x[3], t.y)];
        lerp(y[0], y[1], t.z)
    }
}

/// Offsets in a block of corner c = (x, y, z) bits (x lowest) from the cell's lower node.
const CORNER_OFFSETS: [usize; 8] = {
    let mut offsets = [0; 8];
    let mut c = 0;
    while c < 8 {
        offsets[c] = (c & 1) * 64 + (c >> 1 & 1) * 8 + (c >> 2 & 1);
        c += 1;
    }
    offsets
};

/// The lattice point at or below `q` (`f32::floor` is a library call without SSE4.1).
#[inline]
fn floor(q: Vec3) -> IVec3 {
    let i = q.as_ivec3();
    i - IVec3::from(i.as_vec3().cmpgt(q)).abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flow::Rigid;
    use crate::target::{sample, Sphere};

    const DX: f32 = 0.05;

    /// A rigid motion: linear, so trilinear interpolation of its nodes is exact.
    const TURNING: Rigid = Rigid {
        center: Vec3::new(0.2, -0.1, 0.3),
        linear: Vec3::new(1.0, 0.5, -0.25),
        angular: Vec3::new(0.3, 2.0, -1.0),
    };

    fn lattice() -> IndexToWorld {
        IndexToWorld {
            origin: Vec3::ZERO,
            dx: DX,
        }
    }

    fn skin_grid(dx: f32) -> SparseGrid<f32> {
        let sphere = Sphere {
            center: Vec3::splat(0.1),
            radius: 0.5,
        };
        let data = sample::level_set(&sphere, dx, 3.0);
        let mut grid = SparseGrid::from_vdb(&data, |v| v / (3.0 * dx));
        crate::grid::tube::upkeep(&mut grid);
        grid
    }

    #[test]
    fn a_linear_flow_is_read_back_and_every_point_reads_the_same_with_any_cover() {
        let (dx, xf, rigid) = (DX, lattice(), TURNING);
        let mut covered = OnNodes::new(&rigid, xf);
        covered.cover(&skin_grid(dx));
        assert!(!covered.blocks.is_empty());
        let bare = OnNodes::new(&rigid, xf);
        for i in 0..2000 {
            let s = i as f32;
            let p = Vec3::new((s * 0.37).sin(), (s * 0.53).cos(), (s * 0.71).sin()) * 0.7;
            let (a, b) = (covered.velocity(p), bare.velocity(p));
            // Stored or sampled on the spot, a node is the same number.
            assert_eq!(a.to_array(), b.to_array(), "at {p}");
            // A rigid motion is linear: trilinear interpolation gives it back.
            assert!((a - rigid.velocity(p)).length() < 1e-5, "at {p}");
        }
    }

    #[test]
    fn a_frames_reach_is_covered_and_reads_the_same() {
        let (dx, xf, rigid) = (DX, lattice(), TURNING);
        let grid = skin_grid(dx);
        let (mut near, mut far) = (OnNodes::new(&rigid, xf), OnNodes::new(&rigid, xf));
        near.cover(&grid);
        far.cover_reaching(&grid, 12);
        assert!(far.blocks.len() > near.blocks.len());
        // Every cell a trace meets within 12 voxels of an active node is stored.
        let mut lcg = 1u64;
        for b in grid.blocks().iter().filter(|b| b.active_count() > 0) {
            for offset in b.active_offsets().step_by(37) {
                lcg = lcg
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let unit = |shift: u32| ((lcg >> shift) & 0xffff) as f32 / 65535.0 - 0.5;
                let dir = Vec3::new(unit(16), unit(32), unit(48)).normalize_or(Vec3::X);
                let node = b.coord * BLOCK_DIM + offset_coords(offset);
                let q = node.as_vec3() + dir * 12.0;
                let cell = floor(q);
                for c in 0..8 {
                    let corner = cell + IVec3::new(c & 1, c >> 1 & 1, c >> 2 & 1);
                    assert!(
                        far.blocks.contains_key(&block_of(corner)),
                        "{node} + 12 voxels"
                    );
                }
                let p = xf.apply(q);
                assert_eq!(far.velocity(p).to_array(), near.velocity(p).to_array());
            }
        }
    }
}
