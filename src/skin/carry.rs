//! The skin carried over a whole frame by a known flow map (paper §7): every node of the
//! new band takes the potential where its material was a frame before — one
//! semi-Lagrangian trace a frame, however far the liquid moved. Stepping a velocity
//! instead costs a sub-step per voxel of motion (the advection's one-node halo), 25–40 a
//! frame on a real dam break, and smooths the skin at every one of them.

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use super::{band, Skin, StepLimit, StepStats, Stopped, ADVECTION_CFL};
use crate::flow::{Flow, FlowMap, OnNodes, Traced};
use crate::grid::tube::Reach;
use crate::grid::Aabb;
use crate::grid::{block_of, node_offset, Potential, SparseGrid, AROUND, BLOCK_DIM, BLOCK_NODES};
use crate::stencil::{floor_ivec3, limited_tricubic};
use crate::target::Target;

/// A box of the old grid's nodes, copied once for the nodes of a new block whose
/// departure points all lie in it: their 4³ stencils then read without hashing.
struct Window {
    origin: IVec3,
    size: IVec3,
    values: Vec<f32>,
}

/// The largest window copied (nodes): a block whose material came from a wider region
/// (a strongly stretching flow) reads the grid node by node instead.
const WINDOW_MAX: i32 = 32 * 32 * 32;

impl Window {
    fn new() -> Self {
        Window {
            origin: IVec3::ZERO,
            size: IVec3::ZERO,
            values: Vec::new(),
        }
    }

    /// Copies the nodes `lo..=hi` of `grid`, block by block (tiles as their side).
    fn fill<P: Potential>(&mut self, grid: &SparseGrid<P>, lo: IVec3, hi: IVec3) {
        self.origin = lo;
        self.size = hi - lo + IVec3::ONE;
        let n = (self.size.x * self.size.y * self.size.z) as usize;
        self.values.clear();
        self.values.resize(n, 1.0);
        let (blo, bhi) = (block_of(lo), block_of(hi));
        for bx in blo.x..=bhi.x {
            for by in blo.y..=bhi.y {
                for bz in blo.z..=bhi.z {
                    let coord = IVec3::new(bx, by, bz);
                    let from = (coord * BLOCK_DIM).max(lo);
                    let to = (coord * BLOCK_DIM + IVec3::splat(BLOCK_DIM - 1)).min(hi);
                    let block = grid.find(coord).map(|id| &grid.block(id).values);
                    let tile = grid.tile_value(coord).to_f32();
                    for x in from.x..=to.x {
                        for y in from.y..=to.y {
                            let row = self.index(IVec3::new(x, y, from.z));
                            let out = &mut self.values[row..row + (to.z - from.z + 1) as usize];
                            match block {
                                Some(values) => {
                                    let l = IVec3::new(x, y, from.z) - coord * BLOCK_DIM;
                                    let start = node_offset(l.x, l.y, l.z);
                                    for (o, v) in out.iter_mut().zip(&values[start..]) {
                                        *o = v.to_f32();
                                    }
                                }
                                None => out.fill(tile),
                            }
                        }
                    }
                }
            }
        }
    }

    #[inline]
    fn index(&self, ijk: IVec3) -> usize {
        let l = ijk - self.origin;
        ((l.x * self.size.y + l.y) * self.size.z + l.z) as usize
    }

    #[inline]
    fn at(&self, ijk: IVec3) -> f32 {
        self.values[self.index(ijk)]
    }
}

/// Sets every node of the blocks from index `first` on to the old potential where its
/// material was (`departures` of a block's nodes from its first node, in node units;
/// `None`: outside).
fn carry_blocks<P: Potential>(
    grid: &mut SparseGrid<P>,
    first: usize,
    old: &SparseGrid<P>,
    departures: &(impl Fn(IVec3, &mut Vec<Option<Vec3>>) + Sync),
) {
    grid.blocks_mut()[first..].par_iter_mut().for_each_init(
        || (Window::new(), Vec::with_capacity(BLOCK_NODES)),
        |(window, from), block| {
            let base = block.coord * BLOCK_DIM;
            departures(base, from);
            let (mut lo, mut hi) = (IVec3::MAX, IVec3::MIN);
            for u in from.iter().flatten() {
                let b = floor_ivec3(*u);
                lo = lo.min(b - IVec3::ONE);
                hi = hi.max(b + IVec3::splat(2));
            }
            let span = (hi - lo + IVec3::ONE).max(IVec3::ZERO);
            let windowed = lo.cmple(hi).all() && span.x * span.y * span.z <= WINDOW_MAX;
            if windowed {
                window.fill(old, lo, hi);
            }
            for (v, u) in block.values.iter_mut().zip(from.iter()) {
                let f = match u {
                    Some(u) if windowed => limited_tricubic(|ijk| window.at(ijk), *u),
                    Some(u) => limited_tricubic(|ijk| old.value(ijk), *u),
                    None => 1.0,
                };
                *v = P::from_f32(f.clamp(-1.0, 1.0));
            }
        },
    );
}

/// Voxels past the band up to which a frame's trace reads a costly flow from nodes
/// sampled once ([`Skin::carry_in_flow`]).
const MAX_CACHED_REACH: u32 = 2 * BLOCK_DIM as u32;

impl<P: Potential> Skin<P> {
    /// Carries the skin by `map` over `duration` seconds (§7 in one trace): the new band
    /// holds, at each node, the old potential where the node's material was; where no
    /// material is near, the outside. A block is stored when its material came from the
    /// old band, else it is a tile of the side it came from. The skin keeps its volume
    /// (`keep_volume`). The clock is not moved: [`Skin::advance`] then attracts the
    /// carried skin to the frame's target over the same `duration`.
    pub fn carry(&mut self, map: &dyn FlowMap, duration: f32) {
        self.carry_gaining(map, duration, 0.0);
    }

    fn carry_gaining(&mut self, map: &dyn FlowMap, duration: f32, gain: f64) {
        let (dx, w) = (self.params.dx, self.params.band_width);
        let xf = self.xf;
        let volume = self.volume;
        let old = std::mem::take(&mut self.grid);
        let to_nodes = |p: Vec3| (p - xf.origin) / dx;
        // Where the material at a node (index space) was, in the old grid's index space.
        let departure_at = |ijk: Vec3| {
            map.departure(xf.apply(ijk), duration)
                .filter(|p| p.is_finite())
                .map(to_nodes)
        };
        let departures = |base: IVec3, out: &mut Vec<Option<Vec3>>| {
            map.block_departures(xf.apply(base.as_vec3()), dx, duration, out);
            for u in out.iter_mut() {
                *u = u.filter(|p| p.is_finite()).map(to_nodes);
            }
        };

        // Every block of the material's box (and one around), by where its material came
        // from: 1 stored, −1 inside tile, 0 outside. A block is a tile only when its centre
        // and, next to the old band, its eight corners all came from tiles of one side —
        // else part of it came from the band, and a tile would move the skin to its faces.
        let coords = super::seed::blocks_around(&map.parts(), map.bounds(), xf, w);
        // Where the material at node `ijk` came from: 1 a stored block, −1 an inside
        // tile, 0 outside; and whether a stored block is next to it. `None`: no material.
        let origin = |ijk: Vec3| -> Option<(i8, bool)> {
            let from = block_of(departure_at(ijk)?.floor().as_ivec3());
            if old.find(from).is_some() {
                return Some((1, true));
            }
            let side = if old.inside_tiles().contains(&from) {
                -1
            } else {
                0
            };
            let near = AROUND.iter().any(|&d| old.find(from + d).is_some());
            Some((side, near))
        };
        let side_at = |ijk: Vec3| origin(ijk).map_or(0, |(side, _)| side);
        let classified: Vec<(IVec3, i8)> = coords
            .into_par_iter()
            .map(|c| {
                let corner = (c * BLOCK_DIM).as_vec3();
                let kind = match origin(corner + Vec3::splat(3.5)) {
                    // No material near the centre: a droplet or a sheet's edge elsewhere in
                    // the block still needs it stored. The particles' velocity reaches 2.5
                    // radii, the voxel is at most a radius: a lattice of every other node
                    // meets every particle's reach.
                    None => {
                        let mut lattice = (0..64).map(|k| {
                            let step = IVec3::new(k >> 4, (k >> 2) & 3, k & 3) * 2 + IVec3::ONE;
                            corner + step.as_vec3()
                        });
                        i8::from(lattice.any(|p| side_at(p) != 0))
                    }
                    Some((1, _)) => 1,
                    Some((side, false)) => side,
                    Some((side, true)) => {
                        let alike = (0..8).all(|k| {
                            let step = IVec3::new(k >> 2, (k >> 1) & 1, k & 1) * (BLOCK_DIM - 1);
                            side_at(corner + step.as_vec3()) == side
                        });
                        if alike {
                            side
                        } else {
                            1
                        }
                    }
                };
                (c, kind)
            })
            .filter(|&(_, kind)| kind != 0)
            .collect();
        let mut grid = SparseGrid::new();
        for &(c, kind) in &classified {
            if kind > 0 {
                grid.touch(c);
            } else {
                grid.set_tile(c, true);
            }
        }
        band::start_consistently(&mut grid);
        carry_blocks(&mut grid, 0, &old, &departures);
        // The surface may cross into blocks whose centres came from tiles: store them,
        // carried too, until every crossed cell is (as a start does).
        for _ in 0..4 {
            let missing = band::unstored_crossed(&grid);
            if missing.is_empty() {
                break;
            }
            let first = grid.block_count();
            for c in missing {
                grid.touch(c);
            }
            carry_blocks(&mut grid, first, &old, &departures);
        }
        drop(old);
        band::clamp_at_crossings(&mut grid, w, &mut self.rates);
        // A flow stretches and squeezes the distance it carries: made a distance again by
        // one sweep run with the tube's upkeep (from the same halos), the nodes within 1.5
        // voxels of the skin kept as carried, as the advection's are (measured on the
        // flow-map tests before the volume was kept: sphere gliding 8 frames −0.15 %
        // volume, Zalesak one turn −0.26 %; with those nodes redistanced −0.56 / −0.62 %;
        // no sweep −0.04 / −0.85 %).
        let wake = crate::grid::tube::wake_list(&grid);
        let sweep = crate::grid::tube::Sweep {
            update: band::renormalizing(w, 1.5 / w),
            scratch: &mut self.rates,
        };
        crate::grid::tube::upkeep_from(&mut grid, Reach::Faces, &wake, Some(sweep));
        self.grid = grid;
        self.polygonize();
        self.keep_volume(volume + gain);
    }

    /// Carries the skin by a velocity over `duration` seconds in one trace (§7 over a
    /// whole frame): each new node's material traced back through `flow` (RK4, a voxel a
    /// step), the potential read there once. Sub-steps of the advection read it once per
    /// voxel of motion and each smooths the skin: a splash's crown, a sheet one or two
    /// voxels thick, erodes under them within a few frames. The carried skin then gains
    /// `gain` in volume (world units) and no more: what the target gained over the frame
    /// where that is known (a solver's level set, whose liquid the velocity alone does not
    /// account for), otherwise what the flow carries out through the skin (its flux over
    /// `duration`: nothing for a liquid's divergence-free velocity, the swelling of a
    /// breathing shape). Stops where the sub-steps would ([`Skin::limit_substeps`]),
    /// naming the flow's speed.
    pub fn carry_in_flow(
        &mut self,
        flow: &dyn Flow,
        duration: f32,
        gain: Option<f64>,
    ) -> Result<(), Stopped> {
        let dx = self.params.dx;
        let mut nodes = flow.costly().then(|| OnNodes::new(flow, self.xf));
        if let Some(nodes) = &mut nodes {
            nodes.cover(&self.grid);
        }
        let Some(bounds) = self.band_bounds() else {
            return Ok(());
        };
        let speed = match &nodes {
            Some(nodes) => self.sample_flow(nodes),
            None => self.sample_flow(flow),
        };
        let voxels = f64::from(speed) * f64::from(duration) / f64::from(dx);
        let needed = (voxels / f64::from(ADVECTION_CFL)).ceil();
        if let Some(most) = self.max_substeps {
            if !needed.is_finite() || needed > f64::from(most) {
                return Err(Stopped {
                    needed,
                    limit: StepLimit::Flow { speed, voxels },
                });
            }
        }
        // Cached as far as the traces go, up to two blocks (past them a trace's cells are
        // sampled on the spot, the same numbers, so that the cache's memory stays near
        // the band's).
        let flow: &dyn Flow = match &mut nodes {
            Some(nodes) => {
                let reach = voxels.ceil().clamp(1.0, f64::from(MAX_CACHED_REACH)) as u32;
                nodes.cover_reaching(&self.grid, reach);
                &*nodes
            }
            None => flow,
        };
        let gain =
            gain.unwrap_or_else(|| f64::from(duration) * self.mesh.flux(|x| flow.velocity(x)));
        let map = Traced {
            flow,
            bounds: bounds.padded(speed * duration + 2.0 * dx),
            step: dx,
        };
        self.carry_gaining(&map, duration, gain);
        Ok(())
    }

    /// One frame of a cache in its flow, as `skin` runs it: carried in one trace
    /// ([`Skin::carry_in_flow`]), gaining what the target gained since the frame before,
    /// whose target enclosed `volume_before` (the flow's flux when either volume is
    /// unknown), then attracted to the frame's `target` over the same `duration`. The
    /// stats say where the carry stopped, if it did.
    pub fn follow(
        &mut self,
        target: &dyn Target,
        flow: &dyn Flow,
        duration: f64,
        volume_before: Option<f64>,
    ) -> StepStats {
        let gain = volume_before
            .zip(target.volume())
            .map(|(before, now)| now - before);
        match self.carry_in_flow(flow, duration as f32, gain) {
            Ok(()) => self.advance(target, duration),
            Err(stopped) => StepStats {
                stopped: Some(stopped),
                ..self.stats_with(self.count_topology)
            },
        }
    }

    /// The box of the band's blocks, world units; `None` without blocks.
    fn band_bounds(&self) -> Option<Aabb> {
        let (lo, hi) = self
            .grid
            .blocks()
            .iter()
            .fold((IVec3::MAX, IVec3::MIN), |(lo, hi), b| {
                (lo.min(b.coord), hi.max(b.coord))
            });
        (lo.cmple(hi).all()).then(|| Aabb {
            min: self.xf.apply((lo * BLOCK_DIM).as_vec3()),
            max: self.xf.apply(((hi + IVec3::ONE) * BLOCK_DIM).as_vec3()),
        })
    }

    /// Moves the whole skin along its normals by the uniform offset that gives it back
    /// `volume` (the liquid is incompressible, so a carry keeps its volume). The map is
    /// known exactly only at the particles; the skin lies about a radius beyond the outer
    /// ones, where the motion is extended: on the SPlisHSPlasH dam break that gained
    /// 2–4 % a frame with the particles' mean motion over the density's support (Shepard),
    /// 0 with this offset (0.06 voxel a frame on average, 0.25 at most there); over the
    /// nearer particles the velocity now averages (2.5 radii), the shot's volume reached
    /// 1.069 without the offset, 1.042 with it.
    pub(super) fn keep_volume(&mut self, volume: f64) {
        // The shift is a fraction of a voxel and the band reaches w voxels past the skin:
        // the tube is kept until the attraction's upkeep.
        if self.shift_to_volume(volume) != 0.0 {
            self.polygonize();
        }
    }

    /// [`Skin::keep_volume`]'s offset applied to the values alone (the mesh, area and
    /// volume left as they were): how far it moved the skin outward, in voxels (0 when
    /// nothing moved).
    pub(super) fn shift_to_volume(&mut self, volume: f64) -> f32 {
        let (dx, w) = (self.params.dx, self.params.band_width);
        if volume <= 0.0 || self.area <= 0.0 {
            return 0.0;
        }
        // Outward by δ: φ − δ, with f = φ / (wΔx).
        let delta = ((volume - self.volume) / self.area) as f32;
        let shift = delta / (w * dx);
        if shift.abs() < 1e-6 {
            return 0.0;
        }
        self.grid.blocks_mut().par_iter_mut().for_each(|block| {
            for v in block.values.iter_mut() {
                let f = v.to_f32();
                if f.abs() < 1.0 {
                    *v = P::from_f32((f - shift).clamp(-1.0, 1.0));
                }
            }
        });
        delta / dx
    }
}
