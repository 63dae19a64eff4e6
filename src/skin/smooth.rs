//! Smoothing at the particle scale (issue 49), once a frame as the skin settles: the
//! surface of a particle density is pebbled by its particles, which the carry (§7) and the
//! attraction (§3.4) hand on to the skin every frame. Explicit steps of the mean-curvature
//! flow of the potential's level sets (the tension of §3.4 alone, taken once a frame
//! outside the sub-steps, so it never adds one) damp those bumps: a diffusion of the
//! surface over `time` voxels² (bumps of wavelength λ decay as exp(−4π²·time/λ²)).
//!
//! What the particles say is kept:
//! - thin features are spared — each node is smoothed by a weight that is 1 where the
//!   liquid reaches deeper than [`DEEP`] within [`REACH`] voxels or where the skin is
//!   flat, 0 where it is thin and curved: a droplet of one particle, a sheet's rim;
//!   the middle of a flat sheet is smoothed, and keeps its thickness (curvature flow
//!   moves a flat level set not at all, where the Laplacian would thin it);
//! - the skin stays within [`NEAR_TARGET`] voxels of the frame's target (or where it
//!   was), so that a bump the smoothing takes never leaves particles outside, nor a
//!   rounded corner;
//! - the bulk's broad shape: the flow's moves averaged over a few voxels (a rim
//!   rounded, not a bump flattened) are given back where the flow made them, so that a
//!   liquid at rest keeps its shape frame after frame ([`give_back_broad_moves`]);
//! - the volume: what is left of what the flow took is given back by a uniform offset
//!   ([`Skin::settle_holding`]).

use glam::Vec3;
use rayon::prelude::*;

use super::band;
use super::{smoothstep, Skin};
use crate::grid::{
    mask_offsets, mask_rows, node_offset, offset_coords, Halo, Potential, SparseGrid, BLOCK_DIM,
    BLOCK_NODES,
};
use crate::target::Target;

/// Half-depth (scaled potential, f = φ/(wΔx)) under which a feature is thin and spared
/// where curved: a droplet of one particle reaches 1.24 voxel deep at cell = r, a
/// single-layer sheet 1.35 voxel (f ≈ −0.41, −0.45 with w = 3).
const THIN: f32 = 0.45;
/// Depth beyond which the liquid is bulk and smoothed fully (1.8 voxels).
const DEEP: f32 = 0.6;
/// Bending ([`bending`], per voxel) under which a thin part is smoothed fully (the flat
/// middle of a sheet), and over which it is spared (a droplet of one particle: 1.1; a
/// sheet's rim: 0.74; the neck between two particles more).
const FLAT: f32 = 0.35;
const CURVED: f32 = 0.6;
/// Pieces of the skin smaller than this (voxels³) are not smoothed: droplets of up to
/// about 25 particles at cell = r.
const SMALL_PIECE: f32 = 200.0;
/// How far around a node its depth is sought, in voxels.
const REACH: usize = 3;
/// Each step's share of the six neighbours' tangential mean, below the 1 where the
/// checkerboard mode stops being damped; `STEP/6` voxels² of diffusion a step.
const STEP: f32 = 0.8;
/// How far inside the frame's target the smoothing may take the skin, in voxels, and
/// over how much further its inward moves fade out: a particle more than a radius
/// outside the skin would show.
const NEAR_TARGET: f32 = 2.0;
const SOFT: f32 = 1.0;
/// Nodes next to the skin, where its place is decided (|f| below this, 1.5 voxels at
/// w = 3): the only ones the flow moves.
const NEXT_TO_SKIN: f32 = 0.5;
/// The least |∇f|² the flow divides by: a quarter of a distance's slope (1/w) at w = 3.
const SLOPE_FLOOR: f32 = 0.25 * 0.25 / 9.0;
/// The variance of the average the flow's broad moves are taken over
/// ([`give_back_broad_moves`]), per voxel² of flow: σ = 4.5 voxels at cell = r (the
/// default `--smooth 1`, 8/3 voxels² of flow), 4.5 radii at any cell.
const BROAD: f32 = 7.5;
/// The share of the broad moves given back. The moves averaged over the shell next to
/// the skin fall short of the skin's own (a node leaving the shell stops moving): 1.3
/// of their average gives a sphere back its shrinking (within 0.02 voxel) and holds a
/// settled pool's top (+0.01 r after 12 frames; 1: +0.20 r, 1.5: −0.13 r).
const GIVE_BACK: f32 = 1.3;
/// How far outward of where the flow found it the give-back may take a node, in voxels:
/// uncapped, the bulk's broad moves pushed a gap's sides into each other at the default
/// cell (r/2, where a frame's flow moves the skin a voxel or two), leaving the demo
/// splash's level set features under a voxel (`tests/cli_demo.rs`); with no move outward
/// at all, the bumps' valleys stayed where the flow left them and their tips came back
/// (the dam break's bumps 2.38° against 1.89° without the give-back).
const OUTWARD_CAP: f32 = 0.25;
/// The depth (0 at [`THIN`], 1 at [`DEEP`]) from which the broad moves are given back,
/// in full from [`DEEP`] on. From 0, a sheet one particle thick, whose middle reaches
/// that deep here and there, thickened 12 % as its rims receded; from 0.8 the dam
/// break's wave's run keeps more of its bumps (1.71° against 1.68°).
const BULK: f32 = 0.5;

impl<P: Potential> Skin<P> {
    /// Smooths the potential over `time` voxels² of curvature flow (steps of
    /// `STEP/6`), within [`NEAR_TARGET`] of `near`'s surface when given, its broad moves
    /// on the bulk given back, then meshes it again. Nothing when `time` is 0.
    pub(super) fn smooth(&mut self, time: f32, near: Option<&dyn Target>) {
        self.smooth_giving_back(time, near, true);
    }

    /// [`Skin::smooth`], the broad moves given back or not (the flow's own law, tested).
    fn smooth_giving_back(&mut self, time: f32, near: Option<&dyn Target>, give_back: bool) {
        if time <= 0.0 || self.grid.block_count() == 0 {
            return;
        }
        let band = self.params.band_width * self.params.dx;
        let limit = near.map(|target| Limit {
            distances: target_distances(&self.grid, target, (self.xf, band)),
            inside: NEAR_TARGET * self.params.dx / band,
            soft: SOFT * self.params.dx / band,
        });
        let (mut weights, depths) = thin_weights(&self.grid, &mut self.rates);
        spare_small_pieces(&self.grid, &self.mesh, self.xf, &mut weights);
        let before: Option<Vec<[P; BLOCK_NODES]>> =
            give_back.then(|| self.grid.blocks().iter().map(|b| b.values).collect());
        let movable = movable(&weights);
        let mut left = time / (STEP / 6.0);
        while left > 1e-3 {
            let step = STEP * left.min(1.0);
            curvature_step(
                &mut self.grid,
                (&weights, &movable, limit.as_ref()),
                step,
                &mut self.rates,
            );
            left -= 1.0;
        }
        if let Some(before) = before {
            let scale = (time, self.params.band_width);
            give_back_broad_moves(&mut self.grid, &before, (&weights, &depths), scale);
        }
        // The flow moves each level set at its own curvature, so the potential is no
        // longer a distance: made one again next to the skin (from its cells where the
        // slope strayed) and beyond (upwind sweeps across the band), before the volume
        // is measured and held. (The steps move the skin less than the band is wide:
        // the limit, or a voxel or two.)
        // The tube follows the skin where it moved (the polygonizer meshes its cells),
        // the band a distance again before the volume is measured and offset (and once
        // more after: `Skin::settle_holding`).
        self.refit_band();
        self.polygonize();
    }

    /// Removes the pieces under a voxel³ that the flow or the offset after it left (a
    /// bump's tip pinched off: no particle makes one so small) from the potential. The
    /// mesh is left stale: only the settle calls this, and its restore meshes next
    /// (on 27 of the double dam break's 36 frames a mesh nothing read).
    pub(super) fn drop_crumbs(&mut self) {
        let xf = self.xf;
        let crumb = f64::from(xf.dx).powi(3);
        // The inside nodes around the crumbs' vertices set just outside.
        for p in vertices_of_pieces(&self.mesh, |v| v.abs() < crumb) {
            let cell = ((p - xf.origin) / xf.dx).floor().as_ivec3();
            for n in 0..8 {
                let ijk = cell + glam::IVec3::new(n / 4, n / 2 % 2, n % 2);
                if let Some((id, offset)) = node(&self.grid, ijk) {
                    let block = self.grid.block_mut(id);
                    if block.values[offset].to_f32() < 0.0 {
                        block.values[offset] = P::from_f32(1e-3);
                    }
                }
            }
        }
    }
}

/// The vertices of the pieces of `mesh` whose enclosed volume passes `keep`.
fn vertices_of_pieces(mesh: &crate::mesh::Mesh, keep: impl Fn(f64) -> bool) -> Vec<Vec3> {
    let labels = crate::mesh::piece_labels(mesh);
    let mut volumes: hashbrown::HashMap<u32, f64> = hashbrown::HashMap::new();
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
        *volumes.entry(labels[t[0] as usize]).or_default() += a.dot(b.cross(c)) / 6.0;
    }
    mesh.positions
        .iter()
        .zip(labels)
        .filter(|(_, label)| volumes.get(label).is_some_and(|v| keep(*v)))
        .map(|(p, _)| *p)
        .collect()
}

/// The stored block and offset of node `ijk`, if its block is stored.
fn node<P: Potential>(
    grid: &SparseGrid<P>,
    ijk: glam::IVec3,
) -> Option<(crate::grid::BlockId, usize)> {
    let coord = crate::grid::block_of(ijk);
    let local = ijk - coord * BLOCK_DIM;
    grid.find(coord)
        .map(|id| (id, node_offset(local.x, local.y, local.z)))
}

impl<P: Potential> Skin<P> {
    /// After the skin moved by more than the band's upkeep follows (the flow, a large
    /// offset): the tube follows it (the polygonizer meshes its cells) and the potential
    /// is made a distance again — next to the skin from its cells where the slope is not
    /// a distance's, and beyond by upwind sweeps across the band — for the volume's
    /// offset, a uniform move of a distance. The export re-distances every node next to
    /// the skin exactly (`Skin::settle_holding`): doing it here too cost about 4 % of
    /// the double dam break's CPU, for seven nodes in eight whose slope the flow had left
    /// within [`band::KEPT_WITHIN`] of a distance's.
    pub(super) fn refit_band(&mut self) {
        crate::grid::tube::upkeep(&mut self.grid);
        let w = self.params.band_width;
        band::redistance(&mut self.grid, w, &mut self.rates);
        for _ in 0..2 * w.ceil() as usize {
            band::renormalize(&mut self.grid, w, 0.0, &mut self.rates);
        }
    }
}

/// How far inward of its target the smoothing may take the skin: scaled distances per
/// node ([`target_distances`]), where the inward moves start to fade and over how much
/// they fade out.
struct Limit {
    distances: Vec<[f32; BLOCK_NODES]>,
    inside: f32,
    soft: f32,
}

impl Limit {
    /// The share of an inward move `moved` (> 0: f grows) a node at `f` keeps, its target
    /// at `d`: all of it until the skin lies `inside` within the target there, none
    /// `soft` further.
    #[inline]
    fn inward(&self, f: f32, d: f32, moved: f32) -> f32 {
        let excess = f - d - self.inside;
        if moved > 0.0 && excess > 0.0 {
            moved * (1.0 - excess / self.soft).max(0.0)
        } else {
            moved
        }
    }
}

/// Zeroes the weights around the pieces of `mesh` smaller than [`SMALL_PIECE`] voxels³:
/// droplets of a few particles, which a frame's flow would shrink away whatever their
/// thickness (a ball of R voxels goes in R²/4 voxels² of it).
fn spare_small_pieces<P: Potential>(
    grid: &SparseGrid<P>,
    mesh: &crate::mesh::Mesh,
    xf: crate::grid::IndexToWorld,
    weights: &mut [[f32; BLOCK_NODES]],
) {
    let small = f64::from(SMALL_PIECE) * f64::from(xf.dx).powi(3);
    for p in vertices_of_pieces(mesh, |v| v < small) {
        let cell = ((p - xf.origin) / xf.dx).floor().as_ivec3();
        for n in 0..64 {
            let ijk = cell + glam::IVec3::new(n / 16 - 1, n / 4 % 4 - 1, n % 4 - 1);
            if let Some((id, offset)) = node(grid, ijk) {
                weights[id.0 as usize][offset] = 0.0;
            }
        }
    }
}

/// Each active node's distance to the target's surface (scaled as f; NaN where the
/// node is not next to the skin or the target says nothing), blocks in the grid's order.
fn target_distances<P: Potential>(
    grid: &SparseGrid<P>,
    target: &dyn Target,
    (xf, band): (crate::grid::IndexToWorld, f32),
) -> Vec<[f32; BLOCK_NODES]> {
    grid.blocks()
        .par_iter()
        .map(|block| {
            let mut d = [f32::NAN; BLOCK_NODES];
            let base = block.coord * BLOCK_DIM;
            for offset in mask_offsets(block.active) {
                if block.values[offset].to_f32().abs() < NEXT_TO_SKIN {
                    let x: Vec3 = xf.apply((base + offset_coords(offset)).as_vec3());
                    d[offset] = target.distance(x) / band;
                }
            }
            d
        })
        .collect()
}

/// Each node's weight in 0..=1 next to the skin (0 farther, where the flow moves
/// nothing), blocks in the grid's order: 1 where the liquid reaches deeper than [`DEEP`]
/// within [`REACH`] voxels or the skin is flat there, 0 where it is both thin and curved
/// (a droplet, a sheet's rim), smooth between. And how deep the liquid reaches there,
/// 0 (thinner than [`THIN`]) to 255 (deeper than [`DEEP`]): the bulk, whose broad moves
/// are given back.
fn thin_weights<P: Potential>(
    grid: &SparseGrid<P>,
    scratch: &mut Vec<[f32; BLOCK_NODES]>,
) -> (Vec<[f32; BLOCK_NODES]>, Vec<[u8; BLOCK_NODES]>) {
    let low = cube_least(grid, scratch);
    let reached = cube_reaches_outside(grid);
    let mut weights = vec![[0.0f32; BLOCK_NODES]; grid.block_count()];
    let mut depths = vec![[0u8; BLOCK_NODES]; grid.block_count()];
    let sides = low.blocks().par_iter().zip(reached.par_iter());
    weights
        .par_iter_mut()
        .zip(depths.par_iter_mut())
        .zip(grid.blocks().par_iter().zip(sides))
        .for_each_init(
            Box::<Halo>::default,
            |halo, ((w, depth), (block, (lo, reached)))| {
                let mut gathered = false;
                for offset in mask_offsets(block.active) {
                    // Only nodes next to the skin ever move (`curvature_step`).
                    if block.values[offset].to_f32().abs() >= NEXT_TO_SKIN {
                        continue;
                    }
                    let lo = lo.values[offset].to_f32();
                    // Only the skin's own neighbourhood moves: a shallow dip of the
                    // potential deep inside (or outside) would close into a bubble.
                    if lo >= 0.0 || reached[offset / 64] >> (offset % 64) & 1 == 0 {
                        continue;
                    }
                    let deep = smoothstep((-lo - THIN) / (DEEP - THIN));
                    depth[offset] = (deep * 255.0).round() as u8;
                    if deep >= 1.0 {
                        w[offset] = 1.0;
                        continue;
                    }
                    if !gathered {
                        halo.gather(grid, block);
                        gathered = true;
                    }
                    let l = offset_coords(offset);
                    let bend = bending(|x, y, z| halo.at(l.x + x, l.y + y, l.z + z));
                    let flat = smoothstep((CURVED - bend) / (CURVED - FLAT));
                    w[offset] = deep.max(flat);
                }
            },
        );
    (weights, depths)
}

/// The least value over the cube of side 2·REACH + 1 around each active node (REACH
/// sweeps over the 27 nodes around, row by row): a cube reaches REACH deep whatever the
/// normal (six neighbours would reach only REACH/√3 along a diagonal). The greatest's
/// sign is [`cube_reaches_outside`]'s.
fn cube_least<P: Potential>(
    grid: &SparseGrid<P>,
    scratch: &mut Vec<[f32; BLOCK_NODES]>,
) -> SparseGrid<P> {
    let mut least = grid.clone();
    for _ in 0..REACH {
        band::each_halo(&least, scratch, |halo, block, out| {
            for (x, y, _) in block.active_rows() {
                let start = Halo::index(x, y, -1);
                let mut m: [f32; 10] = halo.values[start..start + 10]
                    .try_into()
                    .expect("a halo row is ten values");
                for dx in -1..=1 {
                    for dy in -1..=1 {
                        let start = Halo::index(x + dx, y + dy, -1);
                        for (m, &v) in m.iter_mut().zip(&halo.values[start..start + 10]) {
                            *m = m.min(v);
                        }
                    }
                }
                let start = node_offset(x, y, 0);
                for z in 0..8 {
                    out[start + z] = m[z].min(m[z + 1]).min(m[z + 2]);
                }
            }
        });
        band::write_back(&mut least, scratch, false);
    }
    least
}

/// Bit n of each block: a node at or above 0 lies in the cube of side 2·REACH + 1
/// around its node n — the sign of the greatest value over it (as [`cube_least`] takes
/// the least), carried as bits: the same REACH steps over the 27 nodes around, through the active nodes alone (the
/// others keep their own), a stored block's neighbours beyond the grid read as their
/// tiles.
fn cube_reaches_outside<P: Potential>(grid: &SparseGrid<P>) -> Vec<[u64; 8]> {
    let outside = |v: P| v.to_f32() >= 0.0;
    let mut bits: Vec<[u64; 8]> = grid
        .blocks()
        .par_iter()
        .map(|block| {
            let mut m = [0u64; 8];
            for (o, &v) in block.values.iter().enumerate() {
                m[o / 64] |= u64::from(outside(v)) << (o % 64);
            }
            m
        })
        .collect();
    const D: i32 = BLOCK_DIM;
    for _ in 0..REACH {
        let next: Vec<[u64; 8]> = grid
            .blocks()
            .par_iter()
            .zip(bits.par_iter())
            .map(|(block, own)| {
                let around = grid.neighbourhood_of(block);
                // The bits of the block at step n of AROUND: row (x, y)'s eight nodes
                // along z are byte 8·x + y.
                let row_of = |n: usize, x: i32, y: i32| -> u16 {
                    let byte = |m: &[u64; 8]| (m[x as usize] >> (8 * y) & 0xFF) as u16;
                    match around[n] {
                        Ok(id) => byte(&bits[id.0 as usize]),
                        Err(tile) => 0xFF * u16::from(outside(tile)),
                    }
                };
                // Rows over local x, y in -1..=8, z in -1..=8 as bits 0..=9.
                let mut rows = [[0u16; 10]; 10];
                for (i, plane) in rows.iter_mut().enumerate() {
                    let x = i as i32 - 1;
                    let (bx, lx) = (x.div_euclid(D), x.rem_euclid(D));
                    for (j, row) in plane.iter_mut().enumerate() {
                        let y = j as i32 - 1;
                        let (by, ly) = (y.div_euclid(D), y.rem_euclid(D));
                        let n = |bz: i32| ((bx + 1) * 9 + (by + 1) * 3 + bz + 1) as usize;
                        *row = row_of(n(0), lx, ly) << 1
                            | row_of(n(-1), lx, ly) >> 7
                            | (row_of(n(1), lx, ly) & 1) << 9;
                    }
                }
                let mut out = *own;
                for x in 0..D as usize {
                    for y in 0..D as usize {
                        let mut any = 0u16;
                        for plane in &rows[x..x + 3] {
                            for &r in &plane[y..y + 3] {
                                any |= r | r << 1 | r >> 1;
                            }
                        }
                        let grown = u64::from(any >> 1 & 0xFF);
                        let shift = 8 * y;
                        let active = block.active[x] >> shift & 0xFF;
                        let kept = own[x] >> shift & 0xFF & !active;
                        out[x] = out[x] & !(0xFF << shift) | (grown & active | kept) << shift;
                    }
                }
                out
            })
            .collect();
        bits = next;
    }
    bits
}

/// How bent the level set through a node is, per voxel: √(κ₁² + κ₂²), the norm of its
/// shape operator P·H·P/|∇f| (P the projection on the tangent plane, H the Hessian):
/// 0 on a plane, √2/R on a sphere, 1/R on a cylinder, and large on a saddle's neck,
/// whose mean curvature may vanish.
fn bending(at: impl Fn(i32, i32, i32) -> f32) -> f32 {
    let c = at(0, 0, 0);
    let g = 0.5
        * Vec3::new(
            at(1, 0, 0) - at(-1, 0, 0),
            at(0, 1, 0) - at(0, -1, 0),
            at(0, 0, 1) - at(0, 0, -1),
        );
    let norm = g.length();
    if norm < 1e-6 {
        return 0.0;
    }
    let second = |a: i32, b: i32| -> f32 {
        let e = |i: i32| match i {
            0 => (1, 0, 0),
            1 => (0, 1, 0),
            _ => (0, 0, 1),
        };
        let (ea, eb) = (e(a), e(b));
        if a == b {
            at(ea.0, ea.1, ea.2) - 2.0 * c + at(-ea.0, -ea.1, -ea.2)
        } else {
            let (x, y, z) = (ea.0 + eb.0, ea.1 + eb.1, ea.2 + eb.2);
            let (u, v, w) = (ea.0 - eb.0, ea.1 - eb.1, ea.2 - eb.2);
            0.25 * (at(x, y, z) - at(u, v, w) - at(-u, -v, -w) + at(-x, -y, -z))
        }
    };
    let h = glam::Mat3::from_cols_array_2d(&[
        [second(0, 0), second(0, 1), second(0, 2)],
        [second(1, 0), second(1, 1), second(1, 2)],
        [second(2, 0), second(2, 1), second(2, 2)],
    ]);
    let n = g / norm;
    let p = glam::Mat3::IDENTITY - glam::Mat3::from_cols(n * n.x, n * n.y, n * n.z);
    let shape = p * h * p;
    let sum: f32 = (0..3).map(|i| shape.col(i).length_squared()).sum();
    sum.sqrt() / norm
}

/// Gives back the part of the flow's moves on the bulk that is broad (a body's rims
/// rounded, its shrinking as a whole), keeping the part at the particles' scale (the
/// bumps): the moves the flow made next to the skin, averaged by a Gaussian of
/// σ² = [`BROAD`] × `time` (4.5 voxels at cell = r: bumps two particles apart average to
/// nothing), are taken back, [`GIVE_BACK`] of them, the band shifted by them as a whole.
/// A move counts in proportion to the liquid's depth there (thin sheets and droplets as
/// the flow left them: given back there, a sheet's rims receded a radius). At rest the
/// flow would otherwise round the rims a little more every frame, the volume hold
/// lifting the flats to make up for it: a settled pool's top rose 0.66 r in 12 frames
/// (issue 49).
fn give_back_broad_moves<P: Potential>(
    grid: &mut SparseGrid<P>,
    before: &[[P; BLOCK_NODES]],
    (weights, depths): (&[[f32; BLOCK_NODES]], &[[u8; BLOCK_NODES]]),
    (time, band_width): (f32, f32),
) {
    let moved =
        |b: usize, o: usize| weights[b][o] > 0.0 && before[b][o].to_f32().abs() < NEXT_TO_SKIN;
    let bulk =
        |b: usize, o: usize| ((f32::from(depths[b][o]) / 255.0 - BULK) / (1.0 - BULK)).max(0.0);
    // The bulk's moves (first), the nodes the flow moved (second) and their bulk share
    // (third), averaged alike: a normalised convolution over the band, the nodes beyond
    // counting as none; the average move scaled by the bulk's share around, so that a
    // thin part next to the bulk is shifted less.
    let mut sums: Vec<Sums> = grid
        .blocks()
        .par_iter()
        .enumerate()
        .map(|(b, block)| {
            let mut s = [[0.0f32; 3]; BLOCK_NODES];
            for o in mask_offsets(block.active).filter(|&o| moved(b, o)) {
                let m = block.values[o].to_f32() - before[b][o].to_f32();
                s[o] = [bulk(b, o) * m, 1.0, bulk(b, o)];
            }
            s
        })
        .collect();
    // Boxes of 2·reach + 1 nodes along each axis, a variance of reach·(reach + 1)/3 each:
    // two where they reach far enough (a tent; each box is a pass over the band, and a
    // third, nearer a Gaussian, cost 2 % of the double dam break's time).
    let variance = BROAD * time;
    let reach = ((((1.0 + 6.0 * variance).sqrt() - 1.0) / 2.0).round() as i32).clamp(1, 8);
    let boxes = ((3.0 * variance / (reach * (reach + 1)) as f32).round() as usize).max(1);
    for axis in [0usize, 1, 2] {
        let runs = runs_along(grid, axis);
        for _ in 0..boxes {
            // The axis a constant of each pass: its nodes' offsets are then computed
            // without a branch (matched per node, 8 % of the give-back's instructions).
            match axis {
                0 => box_along::<P, 0>(grid, &mut sums, &runs, reach),
                1 => box_along::<P, 1>(grid, &mut sums, &runs, reach),
                _ => box_along::<P, 2>(grid, &mut sums, &runs, reach),
            }
        }
    }
    grid.blocks_mut()
        .par_iter_mut()
        .zip(sums.par_iter().zip(before.par_iter()))
        .for_each(|(block, (sums, before))| {
            for o in mask_offsets(block.active) {
                let ([m, w, bulk], f) = (sums[o], block.values[o].to_f32());
                if w > 1e-4 {
                    // Never more than OUTWARD_CAP outward of where the node was before the
                    // flow: a gap's sides, which the flow moved apart, would be pushed
                    // into each other by the bulk's moves around them.
                    let floor = f.min(before[o].to_f32()) - OUTWARD_CAP / band_width;
                    let shifted = (f - GIVE_BACK * m / w * (bulk / w)).max(floor);
                    block.values[o] = P::from_f32(shifted.clamp(-1.0, 1.0));
                }
            }
        });
}

/// A block's running averages in [`give_back_broad_moves`]: the bulk's moves, the nodes
/// the flow moved, their bulk share.
type Sums = [[f32; 3]; BLOCK_NODES];

/// The stored blocks in runs along `axis`: each run's blocks in order, one after the
/// other along the axis (a block missing ends a run: a box of at most 17 nodes reaches
/// no further than the block next to it).
fn runs_along<P: Potential>(grid: &SparseGrid<P>, axis: usize) -> Vec<Vec<usize>> {
    let mut keyed: Vec<([i32; 3], usize)> = grid
        .blocks()
        .iter()
        .enumerate()
        .map(|(i, block)| {
            let c = block.coord.to_array();
            let (u, v) = ([1, 0, 0][axis], [2, 2, 1][axis]);
            ([c[u], c[v], c[axis]], i)
        })
        .collect();
    keyed.sort_unstable();
    let mut runs: Vec<Vec<usize>> = Vec::new();
    for (i, (key, block)) in keyed.iter().enumerate() {
        let follows = i > 0 && {
            let before = keyed[i - 1].0;
            before[..2] == key[..2] && before[2] + 1 == key[2]
        };
        match (follows, runs.last_mut()) {
            (true, Some(run)) => run.push(*block),
            _ => runs.push(vec![*block]),
        }
    }
    runs
}

/// The units of a unit in the fixed point [`box_along`] sums in: quanta of 2⁻³², finer
/// than an f32's at the moves' scale; a line's sums (under 2 a node) stay far within i64.
const FIXED: f64 = 4294967296.0;

/// The sums of [`give_back_broad_moves`], written by one run of blocks each.
struct SharedSums(*mut Sums);
// SAFETY: each run of [`runs_along`] holds its own blocks (every block is in exactly one
// run), so the runs filtered in parallel never touch the same block's sums.
unsafe impl Sync for SharedSums {}

/// One box filter of 2·`reach` + 1 nodes (reach ≤ 8) along `AXIS`, in place, over the
/// `runs` of blocks along it; nodes beyond the band hold none.
fn box_along<P: Potential, const AXIS: usize>(
    grid: &SparseGrid<P>,
    sums: &mut [Sums],
    runs: &[Vec<usize>],
    reach: i32,
) {
    const D: usize = BLOCK_DIM as usize;
    let scale = 1.0 / (FIXED * (2 * reach + 1) as f64);
    let reach = reach as usize;
    let shared = SharedSums(sums.as_mut_ptr());
    let shared = &shared;
    runs.par_iter().for_each(|run| {
        // SAFETY: the blocks of `run` are this closure's alone (`SharedSums`), and each
        // index is a block's, within `sums`.
        let block_sums = |b: usize| unsafe { &mut *shared.0.add(b) };
        // Sums along the line in fixed point, exact: a window's sum is the same whatever
        // the order it is taken in, so a drop's skin does not depend on where it lies on
        // the grid (a float running sum would round differently as the blocks fall), and
        // a running sum costs one subtraction a node whatever the reach.
        let mut prefix = vec![[0i64; 3]; D * run.len() + 1];
        for u in 0..BLOCK_DIM {
            for v in 0..BLOCK_DIM {
                let at = |t: usize| {
                    let t = t as i32;
                    match AXIS {
                        0 => node_offset(t, u, v),
                        1 => node_offset(u, t, v),
                        _ => node_offset(u, v, t),
                    }
                };
                // Most lines hold no move (the flow moves a shell of about three nodes
                // across a band of blocks): their averages are 0 already, as they are
                // beyond `reach` of the line's first and last moves.
                let value = |i: usize| block_sums(run[i / D])[at(i % D)];
                let len = D * run.len();
                let Some(first) = (0..len).find(|&i| value(i) != [0.0; 3]) else {
                    continue;
                };
                let last = (first..len)
                    .rfind(|&i| value(i) != [0.0; 3])
                    .unwrap_or(first);
                // prefix[i + 1] − prefix[first] sums the line's nodes first..=i.
                for i in first..=last {
                    let q = value(i).map(|x| (f64::from(x) * FIXED) as i64);
                    prefix[i + 1 - first] = [0, 1, 2].map(|c| prefix[i - first][c] + q[c]);
                }
                let sum_to = |i: usize| prefix[i.clamp(first, last + 1) - first];
                for i in first.saturating_sub(reach)..(last + reach + 1).min(len) {
                    let (b, t) = (run[i / D], i % D);
                    let block = &grid.blocks()[b];
                    let (low, high) = (sum_to(i.saturating_sub(reach)), sum_to(i + reach + 1));
                    // The average spreads over the band only: the blocks stored beyond it
                    // depend on where the skin lies on the grid, and so would it.
                    let o = at(t);
                    let in_band = block.active[o / 64] >> (o % 64) & 1 == 1
                        && block.values[o].to_f32().abs() < 1.0;
                    block_sums(b)[o] = match in_band {
                        true => [0, 1, 2].map(|c| ((high[c] - low[c]) as f64 * scale) as f32),
                        false => [0.0; 3],
                    };
                }
            }
        }
    });
}

/// The nodes each block's flow may move (a weight above 0: next to the skin and not
/// spared; only these ever change), as masks like the blocks' active ones.
fn movable(weights: &[[f32; BLOCK_NODES]]) -> Vec<[u64; 8]> {
    weights
        .par_iter()
        .map(|w| {
            let mut mask = [0u64; 8];
            for (o, &w) in w.iter().enumerate() {
                mask[o / 64] |= u64::from(w > 0.0) << (o % 64);
            }
            mask
        })
        .collect()
}

/// One explicit step of weighted mean-curvature flow over the `movable` nodes:
/// f += step/6 · weight · |∇f|κ, the Laplacian less its part along the normal, so that
/// a flat sheet keeps its thickness (the Laplacian would diffuse its two sides into each
/// other) and the band's clamped ends do not move the skin; inward moves fade where the
/// skin lies deeper in its target than the `limit` allows. Only the blocks and rows with
/// a movable node are gathered, computed and written, not every active node tested each
/// step: the flow 12 % faster on the double dam break, where it takes 9 % of the CPU.
/// (A compact list of the movable nodes, each with its stencil's 18 neighbours' indices,
/// was barely faster: 72 bytes a node read each step.)
fn curvature_step<P: Potential>(
    grid: &mut SparseGrid<P>,
    (weights, movable, limit): (&[[f32; BLOCK_NODES]], &[[u64; 8]], Option<&Limit>),
    step: f32,
    scratch: &mut Vec<[f32; BLOCK_NODES]>,
) {
    scratch.resize(grid.block_count(), [0.0; BLOCK_NODES]);
    scratch
        .par_iter_mut()
        .zip(grid.blocks().par_iter().zip(weights))
        .zip(movable)
        .enumerate()
        .filter(|(_, (_, movable))| **movable != [0; 8])
        .for_each_init(
            Box::<Halo>::default,
            |halo, (b, ((out, (block, w)), movable))| {
                halo.gather(grid, block);
                let distances = limit.map(|l| &l.distances[b]);
                for (x, y, _) in mask_rows(*movable) {
                    let start = node_offset(x, y, 0);
                    let moved = tangential_laplacian_row(halo, x, y);
                    for z in 0..8 {
                        let f = halo.at(x, y, z as i32);
                        // Only the level sets near the skin move: deeper ones, near a
                        // body's middle, shrink fast where the slope vanishes and would
                        // reach the skin (the band is made a distance again afterwards).
                        let near = f32::from(u8::from(f.abs() < NEXT_TO_SKIN));
                        let mut m = step / 6.0 * w[start + z] * moved[z] * near;
                        if let (Some(limit), Some(d)) = (limit, distances) {
                            let d = d[start + z];
                            if d.is_finite() {
                                m = limit.inward(f, d, m);
                            }
                        }
                        out[start + z] = (f + m).clamp(-1.0, 1.0);
                    }
                }
            },
        );
    let blocks = grid.blocks_mut().par_iter_mut().zip(scratch.par_iter());
    blocks
        .zip(movable)
        .filter(|(_, movable)| **movable != [0; 8])
        .for_each(|((block, values), movable)| {
            for offset in mask_offsets(*movable) {
                block.values[offset] = P::from_f32(values[offset]);
            }
        });
}

/// |∇f|κ (the Laplacian without its normal part) at local nodes (x, y, 0..8), computed
/// together so that the row vectorises: κ|∇f| = (|∇f|²Δf − ∇fᵀH∇f)/|∇f|², 0 where ∇f
/// vanishes.
fn tangential_laplacian_row(halo: &Halo, x: i32, y: i32) -> [f32; 8] {
    let mut rows = [[[0.0f32; 10]; 3]; 3];
    for (i, plane) in rows.iter_mut().enumerate() {
        for (j, row) in plane.iter_mut().enumerate() {
            let start = Halo::index(x + i as i32 - 1, y + j as i32 - 1, -1);
            row.copy_from_slice(&halo.values[start..start + 10]);
        }
    }
    let mut out = [0.0f32; 8];
    for (z, out) in out.iter_mut().enumerate() {
        let at = |dx: usize, dy: usize, dz: usize| rows[dx][dy][z + dz];
        let c = at(1, 1, 1);
        let fx = 0.5 * (at(2, 1, 1) - at(0, 1, 1));
        let fy = 0.5 * (at(1, 2, 1) - at(1, 0, 1));
        let fz = 0.5 * (at(1, 1, 2) - at(1, 1, 0));
        let fxx = at(2, 1, 1) - 2.0 * c + at(0, 1, 1);
        let fyy = at(1, 2, 1) - 2.0 * c + at(1, 0, 1);
        let fzz = at(1, 1, 2) - 2.0 * c + at(1, 1, 0);
        let fxy = 0.25 * (at(2, 2, 1) - at(2, 0, 1) - at(0, 2, 1) + at(0, 0, 1));
        let fyz = 0.25 * (at(1, 2, 2) - at(1, 2, 0) - at(1, 0, 2) + at(1, 0, 0));
        let fxz = 0.25 * (at(2, 1, 2) - at(2, 1, 0) - at(0, 1, 2) + at(0, 1, 0));
        let g2 = fx * fx + fy * fy + fz * fz;
        let numerator = fx * fx * (fyy + fzz) + fy * fy * (fxx + fzz) + fz * fz * (fxx + fyy)
            - 2.0 * (fx * fy * fxy + fy * fz * fyz + fx * fz * fxz);
        // A slope under a quarter of a distance's (a body's middle, a saddle) moves no
        // faster than at a quarter: the flow of level sets barely defined there.
        *out = numerator / g2.max(SLOPE_FLOOR);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skin::SkinParams;
    use crate::target::Sphere;

    /// A sphere of R voxels under `time` voxels² of curvature flow: R² − 4·time (its
    /// radius' exact law), measured on the mesh's volume; smoothed, its shrinking (a
    /// broad move) is given back, its radius kept within 0.05 voxel.
    #[test]
    fn a_sphere_shrinks_as_curvature_flow_says_and_is_given_it_back() {
        let dx = 0.05;
        let radius_voxels = 16.0;
        let sphere = Sphere {
            center: Vec3::splat(0.013),
            radius: radius_voxels * dx,
        };
        let new = || -> Skin<f32> {
            Skin::new(
                &sphere,
                SkinParams {
                    dx,
                    ..SkinParams::default()
                },
            )
        };
        let (mut skin, mut given_back) = (new(), new());
        let radius = |s: &Skin<f32>| {
            (3.0 * s.stats().volume / (4.0 * std::f64::consts::PI)).cbrt() / f64::from(dx)
        };
        let r0 = radius(&skin);
        // Half a voxel: the flow moves only the nodes within 1.5 voxels of the skin.
        let time = 4.0;
        skin.smooth_giving_back(time, None, false);
        given_back.smooth(time, None);
        let (r1, r2) = (radius(&skin), radius(&given_back));
        let expected = (r0 * r0 - 4.0 * f64::from(time)).sqrt();
        eprintln!(
            "radius {r0:.3} → {r1:.3} voxels, curvature flow says {expected:.3}; \
             {r2:.3} given back"
        );
        assert!((r1 - expected).abs() < 0.05, "{r1} against {expected}");
        assert!((r2 - r0).abs() < 0.05, "{r2} against {r0}");
    }

    /// A crumb (a piece of a few thousandths of a voxel³ beside the skin, as the flow
    /// leaves of a pinched tip) is gone once the skin settles, from the potential and
    /// from the mesh the settle leaves; the skin itself stays.
    #[test]
    fn a_crumb_beside_the_skin_is_dropped_as_it_settles() {
        let dx = 0.05;
        let sphere = Sphere {
            center: Vec3::splat(0.013),
            radius: 0.5,
        };
        let mut skin: Skin<f32> = Skin::new(
            &sphere,
            SkinParams {
                dx,
                smoothing: 1.0,
                ..SkinParams::default()
            },
        );
        // 1.7 voxels outside the sphere along x, barely inside.
        let crumb = glam::IVec3::new(12, 0, 0);
        let (id, offset) = node(&skin.grid, crumb).expect("a node of the band");
        skin.grid.block_mut(id).values[offset] = -0.01;
        skin.polygonize();
        assert_eq!(skin.mesh.components(), 2);
        let volume = skin.stats().volume;
        skin.settle();
        assert_eq!(skin.mesh.components(), 1);
        assert!(skin.grid.value(crumb) > 0.0);
        let kept = skin.stats().volume / volume;
        assert!((kept - 1.0).abs() < 0.01, "volume {kept} of what it was");
    }
}
