//! The tube of active nodes (paper §4.1, §4.5): every node with |f| < 1 and its six
//! neighbours (or its 26, when a flow carries the skin). After an update, blocks next to a
//! band node are woken (stored, at their tile's side) and blocks left with no active node
//! retire into inside / outside tiles.

use glam::IVec3;
use rayon::prelude::*;

use super::{
    around_bit, mask_offsets, Halo, Potential, SparseGrid, BLOCK_DIM, BLOCK_NODES, HALO_DIM,
};

#[inline]
fn in_band(f: f32) -> bool {
    f.abs() < 1.0
}

/// How far the tube reaches past the band.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reach {
    /// The six face neighbours: the surface may move half a voxel a step (the paper's
    /// tube; the attraction's steps move it at most the safety factor, 0.5).
    Faces,
    /// All 26 neighbours: the surface may move a voxel a step in any direction. A flow
    /// moves it up to 0.9 voxel a step; across the faces' tube a diagonal front gains
    /// only 1/√3 voxel a step, and the nodes it reaches were never advected.
    Cube,
}

/// After an update: every node with |f| < 1 gets its six neighbours stored (a woken node
/// starts at its tile's side, ±1); the active set becomes those nodes and their
/// neighbours; blocks left with no active node retire into inside / outside tiles.
pub fn upkeep<P: Potential>(grid: &mut SparseGrid<P>) {
    upkeep_reaching(grid, Reach::Faces);
}

/// [`upkeep`] with the tube reaching `reach` past the band.
pub fn upkeep_reaching<P: Potential>(grid: &mut SparseGrid<P>, reach: Reach) {
    let wake = wake_list(grid);
    upkeep_from(grid, reach, &wake, None::<Sweep<'_, NoSweep>>);
}

/// The blocks each block's band nodes reach (see [`blocks_reached`]), for [`upkeep_from`].
pub(crate) fn wake_list<P: Potential>(grid: &SparseGrid<P>) -> Vec<(IVec3, u32)> {
    grid.blocks()
        .par_iter()
        .map(|block| (block.coord, blocks_reached(&block.values)))
        .collect()
}

/// The type of an absent [`Sweep`].
pub(crate) type NoSweep = fn(&Halo, i32, i32) -> [f32; 8];

/// A pass over each block's new active nodes run with the tube's own: `update(halo, x, y)`
/// gives the new values of the row of local nodes (x, y, 0..8) from the values before the
/// pass (Jacobi); only the active ones are kept.
pub(crate) struct Sweep<'a, F> {
    /// The update of a row of nodes.
    pub update: F,
    /// Reused for the values swept.
    pub scratch: &'a mut Vec<[f32; BLOCK_NODES]>,
}

/// Runs a row update (see [`Sweep`]) over the rows of `mask` into `out`.
pub(crate) fn sweep_rows(
    update: impl Fn(&Halo, i32, i32) -> [f32; 8],
    halo: &Halo,
    mask: [u64; 8],
    out: &mut [f32; BLOCK_NODES],
) {
    for (x, y, _) in super::mask_rows(mask) {
        let start = super::node_offset(x, y, 0);
        out[start..start + 8].copy_from_slice(&update(halo, x, y));
    }
}

/// The tube's upkeep from a [`wake_list`] (taken as the values were written, where a
/// caller has them in cache): wakes the blocks reached, sets each block's active mask,
/// runs `sweep` over the new active nodes from the same halo, and retires blocks left
/// without one. (The sweep sees blocks about to retire as stored: all their nodes are at
/// ±1, as their tiles will be.)
pub(crate) fn upkeep_from<P: Potential, F>(
    grid: &mut SparseGrid<P>,
    reach: Reach,
    wake: &[(IVec3, u32)],
    sweep: Option<Sweep<'_, F>>,
) where
    F: Fn(&Halo, i32, i32) -> [f32; 8] + Sync,
{
    for &(coord, reached) in wake {
        match reach {
            Reach::Faces => {
                for axis in IVec3::AXES {
                    for step in [-axis, axis] {
                        if reached & around_bit(step) != 0 {
                            grid.touch(coord + step);
                        }
                    }
                }
            }
            Reach::Cube => {
                for step in super::AROUND {
                    if reached & around_bit(step) != 0 {
                        grid.touch(coord + step);
                    }
                }
            }
        }
    }

    grid.refresh_neighbourhoods();
    let grid_ref = &*grid;
    match sweep {
        None => {
            let masks: Vec<[u64; 8]> = grid_ref
                .blocks()
                .par_iter()
                .map_init(Box::<Halo>::default, |halo, block| {
                    halo.gather(grid_ref, block);
                    dilated_band(halo, reach)
                })
                .collect();
            grid.blocks_mut()
                .par_iter_mut()
                .zip(masks)
                .for_each(|(block, mask)| block.active = mask);
        }
        Some(Sweep { update, scratch }) => {
            scratch.resize(grid_ref.block_count(), [0.0; BLOCK_NODES]);
            let masks: Vec<[u64; 8]> = scratch
                .par_iter_mut()
                .zip(grid_ref.blocks().par_iter())
                .map_init(Box::<Halo>::default, |halo, (out, block)| {
                    halo.gather(grid_ref, block);
                    let mask = dilated_band(halo, reach);
                    sweep_rows(&update, halo, mask, out);
                    mask
                })
                .collect();
            let scratch = &**scratch;
            grid.blocks_mut()
                .par_iter_mut()
                .zip(masks)
                .zip(scratch.par_iter())
                .for_each(|((block, mask), values)| {
                    block.active = mask;
                    for offset in mask_offsets(mask) {
                        block.values[offset] = P::from_f32(values[offset]);
                    }
                });
        }
    }
    grid.retire_blocks(|b| b.active_count() == 0);
    // For the passes until the next upkeep.
    grid.refresh_neighbourhoods();
}

/// In-band bits of a run of values along z: bit k for value k.
#[inline]
fn band_bits<P: Potential>(values: &[P]) -> u16 {
    super::row_bits(values, in_band)
}

/// The blocks around a block (bit n for [`super::AROUND`]'s step n, its own left out)
/// that its band nodes' neighbours reach: across the faces, edges and corners those nodes
/// lie on (the face steps alone for a tube of face neighbours).
pub(crate) fn blocks_reached<P: Potential>(values: &[P; BLOCK_NODES]) -> u32 {
    super::sides_where(values, in_band)
}

/// The active mask of a block: its nodes in the band or with a neighbour in it (across a
/// face, or any of the 26 as `reach` says), as bit rows along z (mask word x, bit 8·y + z,
/// matching the node offsets).
fn dilated_band(halo: &Halo, reach: Reach) -> [u64; 8] {
    const ROWS: usize = HALO_DIM;
    let mut rows = [[0u16; ROWS]; ROWS];
    for (hx, plane) in rows.iter_mut().enumerate() {
        for (hy, row) in plane.iter_mut().enumerate() {
            let start = Halo::index(hx as i32 - 1, hy as i32 - 1, -1);
            *row = band_bits(&halo.values[start..start + ROWS]);
        }
    }
    let mut mask = [0u64; 8];
    for (x, word) in mask.iter_mut().enumerate() {
        for y in 0..BLOCK_DIM as usize {
            let (i, j) = (x + 1, y + 1);
            let r = rows[i][j];
            let near = match reach {
                Reach::Faces => {
                    r | r << 1
                        | r >> 1
                        | rows[i - 1][j]
                        | rows[i + 1][j]
                        | rows[i][j - 1]
                        | rows[i][j + 1]
                }
                Reach::Cube => (i - 1..=i + 1)
                    .flat_map(|a| rows[a][j - 1..=j + 1].iter())
                    .fold(0, |near, &q| near | q | q << 1 | q >> 1),
            };
            *word |= u64::from((near >> 1) & 0xFF) << (8 * y);
        }
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::{blocks_reached, dilated_band, in_band, Reach};
    use crate::grid::AROUND;
    use crate::grid::{node_offset, offset_coords, Halo, BLOCK_NODES};
    use glam::IVec3;

    /// A repeatable pseudo-random potential in [-1.5, 1.5], a third of it in the band.
    fn scattered(seed: u64) -> impl FnMut() -> f32 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32) * 3.0 - 1.5
        }
    }

    #[test]
    fn bit_row_dilation_matches_the_node_by_node_rule() {
        for seed in 0..20 {
            let mut next = scattered(seed);
            let mut halo = Halo::default();
            halo.values.iter_mut().for_each(|v| *v = next());
            let faces = dilated_band(&halo, Reach::Faces);
            let cube = dilated_band(&halo, Reach::Cube);
            for offset in 0..BLOCK_NODES {
                let l = offset_coords(offset);
                let at = |p: IVec3| in_band(halo.at(p.x, p.y, p.z));
                let near = at(l) || IVec3::AXES.iter().any(|&e| at(l - e) || at(l + e));
                assert_eq!(faces[offset >> 6] >> (offset & 63) & 1 == 1, near, "{l}");
                let near = AROUND.iter().any(|&e| at(l + e));
                assert_eq!(cube[offset >> 6] >> (offset & 63) & 1 == 1, near, "{l}");
            }
        }
    }

    #[test]
    fn a_band_node_reaches_the_blocks_across_the_faces_edges_and_corner_it_lies_on() {
        let mut block = [1.0f32; BLOCK_NODES];
        let reached = |values: &[f32; BLOCK_NODES]| {
            let bits = blocks_reached(values);
            AROUND
                .iter()
                .enumerate()
                .filter(|(n, _)| bits >> n & 1 == 1)
                .map(|(_, s)| *s)
                .collect::<Vec<IVec3>>()
        };
        assert!(reached(&block).is_empty());
        block[node_offset(3, 4, 5)] = 0.0; // inside: reaches no other block
        assert!(reached(&block).is_empty());
        block[node_offset(0, 4, 5)] = 0.5; // on the −x face
        assert_eq!(reached(&block), vec![IVec3::new(-1, 0, 0)]);
        block[node_offset(0, 4, 5)] = 1.0;
        block[node_offset(7, 0, 5)] = -0.5; // on the +x −y edge
        let mut edge = reached(&block);
        edge.sort_by_key(|s| s.to_array());
        assert_eq!(
            edge,
            vec![
                IVec3::new(0, -1, 0),
                IVec3::new(1, -1, 0),
                IVec3::new(1, 0, 0)
            ]
        );
        block[node_offset(7, 0, 5)] = 1.0;
        block[node_offset(7, 7, 7)] = 0.2; // on the + + + corner
        let corner = reached(&block);
        assert_eq!(corner.len(), 7);
        assert!(corner
            .iter()
            .all(|s| s.min_element() >= 0 && *s != IVec3::ZERO));
    }

    #[test]
    fn a_band_node_on_one_face_reaches_the_block_across_it() {
        for (l, face) in [
            (IVec3::new(0, 3, 3), 0),
            (IVec3::new(7, 3, 3), 1),
            (IVec3::new(3, 0, 3), 2),
            (IVec3::new(3, 7, 3), 3),
            (IVec3::new(3, 3, 0), 4),
            (IVec3::new(3, 3, 7), 5),
        ] {
            let mut values = [1.0f32; BLOCK_NODES];
            values[node_offset(l.x, l.y, l.z)] = 0.2;
            let across = [
                -IVec3::X,
                IVec3::X,
                -IVec3::Y,
                IVec3::Y,
                -IVec3::Z,
                IVec3::Z,
            ][face];
            let n = AROUND.iter().position(|&s| s == across).unwrap();
            assert_eq!(blocks_reached(&values), 1 << n, "{l}");
        }
        let mut values = [-1.0f32; BLOCK_NODES];
        values[node_offset(3, 4, 5)] = 0.0;
        assert_eq!(blocks_reached(&values), 0);
    }
}
