//! The density rasterized onto the skin's grid once per frame (§6.1 at scale): each block
//! of 8³ nodes that a particle's support reaches sums the kernels of those particles —
//! parallel by block and gathered, so no locks and the same sums on every run — and the
//! skin then reads G, ∇G and the velocity by trilinear interpolation: exact at the nodes,
//! O(Δx²) between them. Cost O(particles·(h/Δx)³) once a frame, then O(band) a sub-step,
//! where summing at each query cost 27 hashed cells per node and sub-step.

use glam::{IVec3, Vec3};
use hashbrown::HashMap;
use rayon::prelude::*;

use super::Density;
use crate::flow::{Flow, FlowMap};
use crate::grid::Aabb;
use crate::grid::{offset_coords, AROUND, BLOCK_NODES};
use crate::stencil::floor_ivec3;
use crate::target::Target;
use crate::volume::{GridClass, GridData, Transform, MASK_WORDS};

const DIM: i32 = 8;
const NODES: usize = 512;

#[inline]
fn offset(local: IVec3) -> usize {
    (local.x * 64 + local.y * 8 + local.z) as usize
}

/// One block of rasterized nodes.
struct Block {
    coord: IVec3,
    /// G, ∂G/∂x, ∂G/∂y and ∂G/∂z, each over the block's nodes (rows along z are the
    /// splat's vectors); `None` once the block is deep and compacted ([`Compacted`]).
    field: Option<Box<[[f32; NODES]; 4]>>,
    /// Σ W·v per component and Σ W, with the velocity's kernel
    /// ([`super::VELOCITY_SUPPORT_RADII`]), when the particles carry velocities and the
    /// block is not compacted.
    momentum: Option<Box<[[f32; NODES]; 4]>>,
    /// What a compacted block keeps of its nodes.
    compacted: Compacted,
    /// This block and its 26 neighbours have G > iso at every node: the surface is more
    /// than a block away (see [`DensityGrid::distance`]).
    deep: bool,
    /// Some node has G > iso.
    inside: bool,
}

/// What a deep block keeps of its nodes once compacted (most of a large liquid's blocks:
/// its bulk, more than a block from the surface, where no skin reads the nodes): the
/// least G at them and the momentum's mean. Read back as that G with no gradient and
/// that momentum at every node, which keeps the block inside and, where a
/// neighbour's cells interpolate it (seven voxels or more inside the surface), the
/// distance capped at the support and the velocity the bulk's.
#[derive(Clone, Copy, Default)]
struct Compacted {
    least: f32,
    momentum: Option<[f32; 4]>,
}

impl Block {
    /// A block of no nodes yet, holding the momentum's channels when `velocities`.
    fn zeroed(coord: IVec3, velocities: bool) -> Self {
        Block {
            coord,
            field: Some(Box::new([[0.0; NODES]; 4])),
            momentum: velocities.then(|| Box::new([[0.0; NODES]; 4])),
            compacted: Compacted::default(),
            deep: false,
            inside: false,
        }
    }

    /// G at node `o`.
    #[inline]
    fn g(&self, o: usize) -> f32 {
        match &self.field {
            Some(f) => f[0][o],
            None => self.compacted.least,
        }
    }

    /// G and ∇G at node `o`.
    #[inline]
    fn field_at(&self, o: usize) -> [f32; 4] {
        match &self.field {
            Some(f) => [f[0][o], f[1][o], f[2][o], f[3][o]],
            None => [self.compacted.least, 0.0, 0.0, 0.0],
        }
    }

    /// Σ W·v and Σ W at node `o`, when the particles carry velocities.
    #[inline]
    fn momentum_at(&self, o: usize) -> Option<[f32; 4]> {
        match &self.momentum {
            Some(m) => Some([m[0][o], m[1][o], m[2][o], m[3][o]]),
            None => self.compacted.momentum,
        }
    }

    /// Whether G > `iso` at every node.
    fn full(&self, iso: f32) -> bool {
        match &self.field {
            Some(f) => f[0].iter().all(|&g| g > iso),
            None => true,
        }
    }

    /// Drops the nodes, keeping [`Compacted`]'s summary.
    fn compact(&mut self) {
        let Some(field) = self.field.take() else {
            return;
        };
        let least = field[0].iter().copied().fold(f32::INFINITY, f32::min);
        let momentum = self.momentum.take().map(|m| {
            std::array::from_fn(|c| {
                m[c].iter().map(|&v| f64::from(v)).sum::<f64>() as f32 / NODES as f32
            })
        });
        self.compacted = Compacted { least, momentum };
    }
}

/// A particle density sampled at the nodes of a grid of voxel `dx` (node ijk at ijk·dx,
/// as the skin's), a [`Target`] and, with velocities, a [`Flow`] of the same kernel.
pub struct DensityGrid {
    dx: f32,
    iso: f32,
    /// The largest support.
    h: f32,
    slots: HashMap<IVec3, u32>,
    blocks: Vec<Block>,
    velocities: bool,
    bounds: Aabb,
}

/// Where nodes are missing the density is 0.
const EMPTY: [f32; 4] = [0.0; 4];

impl DensityGrid {
    /// Sums `density`'s kernels at every node within a support of a particle.
    /// Every node kept.
    pub fn rasterize(density: &Density, dx: f32) -> Self {
        Self::rasterize_within(density, dx, u64::MAX, true)
            .expect("an unbounded budget holds any grid")
    }

    /// [`DensityGrid::rasterize`], refused before allocating more than `budget` bytes:
    /// `Err` holds the bytes it would take (a cloud whose kernels span many blocks each,
    /// tiny voxels or huge radii, with few neighbours to share them). Deep blocks are
    /// compacted ([`Compacted`]) unless `every_node` (to write the density out): their
    /// nodes are never held all at once, each dropped as soon as its block is found full
    /// and summed again if it is not deep after all.
    pub fn rasterize_within(
        density: &Density,
        dx: f32,
        budget: u64,
        every_node: bool,
    ) -> Result<Self, u64> {
        let compact = !every_node;
        if !density.has_spray() {
            return Self::rasterize_part(density, dx, budget, None, compact);
        }
        let mut bulk = Self::rasterize_part(density, dx, budget, Some(false), compact)?;
        let spray = Self::rasterize_part(density, dx, budget, Some(true), compact)?;
        bulk.union(spray);
        Ok(bulk)
    }

    /// [`DensityGrid::rasterize_within`] of the spray (`Some(true)`), the rest
    /// (`Some(false)`) or all particles (`None`).
    fn rasterize_part(
        density: &Density,
        dx: f32,
        budget: u64,
        part: Option<bool>,
        compact: bool,
    ) -> Result<Self, u64> {
        assert!(dx > 0.0, "voxel size must be positive");
        let cells = Cells::of(density, dx, part);
        let touched = touched_blocks(density, &cells, budget)?;
        let (order, list) = (&cells.order, &cells.list);
        let runs: HashMap<IVec3, (usize, usize)> = list
            .iter()
            .map(|&(start, end)| (order[start].0, (start, end)))
            .collect();
        let reach = (density.h / cells.side).ceil() as i32;
        // Particles piled on each other (a copied export, a broken one) cost each block
        // they reach as many splats as copies: merged first, once per crowded cell.
        let merged: HashMap<IVec3, Vec<Kernel>> = list
            .par_iter()
            .filter(|&&(start, end)| end - start > CROWDED_RUN)
            .map(|&(start, end)| {
                let indices = order[start..end].iter().map(|&(_, i)| i as usize);
                (order[start].0, merged_copies(density, indices))
            })
            .collect::<Vec<_>>()
            .into_iter()
            .collect();
        let velocities = density.has_velocities();
        let rasterized = |coord: IVec3| {
            let mut block = Block::zeroed(coord, velocities);
            let lo = (coord * DIM).as_vec3() * dx;
            let hi = (coord * DIM + IVec3::splat(DIM - 1)).as_vec3() * dx;
            // Neighbour blocks in a fixed order, particles in input order within
            // each: every node's sum is the same on every run.
            for x in -reach..=reach {
                for y in -reach..=reach {
                    for z in -reach..=reach {
                        let cell = coord + IVec3::new(x, y, z);
                        let Some(&(start, end)) = runs.get(&cell) else {
                            continue;
                        };
                        match merged.get(&cell) {
                            Some(kernels) => {
                                for &k in kernels {
                                    splat(&mut block, density, k, dx, lo, hi);
                                }
                            }
                            None => {
                                for &(_, i) in &order[start..end] {
                                    let k = Kernel::of(density, i as usize);
                                    splat(&mut block, density, k, dx, lo, hi);
                                }
                            }
                        }
                    }
                }
            }
            block
        };
        let iso = density.iso;
        let blocks = match compact {
            true => summed_compacting(&touched, rasterized, iso),
            false => touched.par_iter().map(|&coord| rasterized(coord)).collect(),
        };
        let slots: HashMap<IVec3, u32> = blocks
            .iter()
            .enumerate()
            .map(|(slot, b)| (b.coord, slot as u32))
            .collect();
        let mut grid = DensityGrid {
            dx,
            iso,
            h: density.h,
            slots,
            blocks,
            velocities,
            bounds: density.bounds,
        };
        grid.mark_deep();
        Ok(grid)
    }
}

/// How many blocks around a block must be full (G > iso at every node) for it to be
/// compacted: two, so that the skin's band (three voxels) and its carry's departures a
/// few voxels on never read a compacted node where the surface is near.
const COMPACT_REACH: i32 = 2;

/// The blocks at `touched` (sorted) summed by `rasterized`, slab by slab along x, each
/// block compacted ([`Compacted`]) as soon as the slabs around it are summed and every
/// block within [`COMPACT_REACH`] of it is full: a liquid's bulk is never held whole,
/// only a few slabs of it. The same blocks, in `touched`'s order, on every run.
fn summed_compacting(
    touched: &[IVec3],
    rasterized: impl Fn(IVec3) -> Block + Sync,
    iso: f32,
) -> Vec<Block> {
    let slots: HashMap<IVec3, usize> = touched.iter().enumerate().map(|(i, &c)| (c, i)).collect();
    let mut blocks: Vec<Block> = Vec::with_capacity(touched.len());
    let mut full: Vec<bool> = Vec::with_capacity(touched.len());
    // Blocks before `settled` are compacted or kept for good.
    let mut settled = 0;
    let settle = |blocks: &mut Vec<Block>, full: &[bool], from: usize, to: usize| {
        let r = COMPACT_REACH;
        blocks[from..to].par_iter_mut().for_each(|block| {
            let around = (-r..=r).all(|x| {
                (-r..=r).all(|y| {
                    (-r..=r).all(|z| {
                        slots
                            .get(&(block.coord + IVec3::new(x, y, z)))
                            .is_some_and(|&s| s < full.len() && full[s])
                    })
                })
            });
            if around {
                block.compact();
            }
        });
    };
    let mut start = 0;
    while start < touched.len() {
        let x = touched[start].x;
        let end = start + touched[start..].partition_point(|c| c.x == x);
        let slab: Vec<Block> = touched[start..end]
            .par_iter()
            .map(|&coord| rasterized(coord))
            .collect();
        full.extend(slab.iter().map(|b| b.full(iso)));
        blocks.extend(slab);
        // The slabs whose blocks have every neighbour within reach summed now.
        let ready = touched[settled..end].partition_point(|c| c.x <= x - COMPACT_REACH);
        settle(&mut blocks, &full, settled, settled + ready);
        settled += ready;
        start = end;
    }
    settle(&mut blocks, &full, settled, touched.len());
    blocks
}

/// The particles sorted by the block-sized cell they lie in (then by index), and the runs
/// of each cell in that order.
struct Cells {
    /// A block's side, world units.
    side: f32,
    /// (cell, particle index), sorted.
    order: Vec<(IVec3, u32)>,
    /// Each cell's run in `order`: start and end.
    list: Vec<(usize, usize)>,
}

impl Cells {
    fn of(density: &Density, dx: f32, part: Option<bool>) -> Self {
        let side = DIM as f32 * dx;
        let mut order: Vec<(IVec3, u32)> = density
            .particles
            .par_iter()
            .enumerate()
            .filter(|&(i, _)| part.map_or(true, |spray| density.is_spray(i) == spray))
            .map(|(i, &(p, _))| ((p / side).floor().as_ivec3(), i as u32))
            .collect();
        order.par_sort_unstable_by_key(|&(c, i)| (c.to_array(), i));
        let mut list: Vec<(usize, usize)> = Vec::new();
        let mut start = 0;
        for end in 0..order.len() {
            if order
                .get(end + 1)
                .map_or(true, |next| next.0 != order[end].0)
            {
                list.push((start, end + 1));
                start = end + 1;
            }
        }
        Cells { side, order, list }
    }

    /// The cell (block) of a point.
    fn key(&self, p: Vec3) -> IVec3 {
        (p / self.side).floor().as_ivec3()
    }
}

/// The blocks some particle's support reaches, sorted, once each; `Err` with the bytes
/// they (or the list that finds them) would take past `budget`.
fn touched_blocks(density: &Density, cells: &Cells, budget: u64) -> Result<Vec<IVec3>, u64> {
    let (order, list) = (&cells.order, &cells.list);
    // The blocks some particle's support box reaches, listed once per run of a cell
    // first: that list's size is known before it is made.
    let boxes: Vec<(IVec3, IVec3)> = list
        .par_iter()
        .map(|&(start, end)| {
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for &(_, i) in &order[start..end] {
                let (p, inv_h2) = density.particles[i as usize];
                let h = inv_h2.sqrt().recip();
                lo = lo.min(p - Vec3::splat(h));
                hi = hi.max(p + Vec3::splat(h));
            }
            (cells.key(lo), cells.key(hi))
        })
        .collect();
    let listed: u64 = boxes
        .iter()
        .map(|&(lo, hi)| {
            let n = (hi - lo + IVec3::ONE).as_u64vec3();
            n.x * n.y * n.z
        })
        .sum();
    let entry = std::mem::size_of::<IVec3>() as u64;
    if listed.saturating_mul(entry) > budget {
        return Err(listed.saturating_mul(entry));
    }
    let mut touched: Vec<IVec3> = boxes
        .par_iter()
        .flat_map_iter(|&(lo, hi)| {
            (lo.x..=hi.x).flat_map(move |x| {
                (lo.y..=hi.y).flat_map(move |y| (lo.z..=hi.z).map(move |z| IVec3::new(x, y, z)))
            })
        })
        .collect();
    touched.par_sort_unstable_by_key(|c| c.to_array());
    touched.dedup();
    let channels = if density.has_velocities() { 8 } else { 4 };
    let per_block = (channels * NODES * std::mem::size_of::<f32>()) as u64 + 64;
    let needed = touched.len() as u64 * per_block;
    if needed > budget {
        return Err(needed);
    }
    Ok(touched)
}

impl DensityGrid {
    /// The density's surface value.
    pub fn iso(&self) -> f32 {
        self.iso
    }

    /// Nodes stored (8³ per block).
    pub fn nodes(&self) -> usize {
        self.blocks.len() * NODES
    }

    /// Whether the particles carried velocities.
    pub fn has_velocities(&self) -> bool {
        self.velocities
    }

    /// Fills the interior voids of less than `max_volume` — regions below the iso that the
    /// outside cannot reach through the nodes, where a density whose kernel barely spans
    /// the particle spacing dips — raising them to 2·iso with no gradient, so that a skin
    /// started on the density is one solid. Returns the number of voids filled.
    pub fn fill_voids(&mut self, max_volume: f32) -> usize {
        let iso = self.iso;
        let below = |block: &Block, o: usize| block.g(o) <= iso;
        // Face neighbours: index 2·axis for −, 2·axis + 1 for +.
        let faces: Vec<[Option<u32>; 6]> = self
            .blocks
            .iter()
            .map(|b| {
                std::array::from_fn(|k| {
                    let step = if k % 2 == 0 { -1 } else { 1 };
                    self.slots
                        .get(&(b.coord + IVec3::AXES[k / 2] * step))
                        .copied()
                })
            })
            .collect();
        let neighbour = |slot: u32, local: IVec3, k: usize| -> Option<(u32, IVec3)> {
            let step = if k % 2 == 0 { -1 } else { 1 };
            let next = local + IVec3::AXES[k / 2] * step;
            if next.cmpge(IVec3::ZERO).all() && next.cmplt(IVec3::splat(DIM)).all() {
                Some((slot, next))
            } else {
                faces[slot as usize][k].map(|s| (s, next & (DIM - 1)))
            }
        };
        let local_of = |o: usize| IVec3::new(o as i32 >> 6, (o as i32 >> 3) & 7, o as i32 & 7);
        let mut seen = vec![[0u64; MASK_WORDS]; self.blocks.len()];
        let mark = |seen: &mut [[u64; MASK_WORDS]], slot: u32, o: usize| -> bool {
            let word = &mut seen[slot as usize][o >> 6];
            let fresh = *word >> (o & 63) & 1 == 0;
            *word |= 1 << (o & 63);
            fresh
        };
        // The outside: every node below the iso connected to a missing block.
        let mut stack: Vec<(u32, usize)> = Vec::new();
        for (slot, block) in self.blocks.iter().enumerate() {
            for o in 0..NODES {
                let local = local_of(o);
                let open = (0..6).any(|k| neighbour(slot as u32, local, k).is_none());
                if open && below(block, o) && mark(&mut seen, slot as u32, o) {
                    stack.push((slot as u32, o));
                }
            }
        }
        let flood = |stack: &mut Vec<(u32, usize)>,
                     seen: &mut [[u64; MASK_WORDS]],
                     mut visit: Box<dyn FnMut(u32, usize) + '_>| {
            while let Some((slot, o)) = stack.pop() {
                visit(slot, o);
                for k in 0..6 {
                    if let Some((s, l)) = neighbour(slot, local_of(o), k) {
                        let n = offset(l);
                        if below(&self.blocks[s as usize], n) && mark(seen, s, n) {
                            stack.push((s, n));
                        }
                    }
                }
            }
        };
        flood(&mut stack, &mut seen, Box::new(|_, _| {}));
        // What is left below the iso is enclosed: one void per connected region.
        let max_nodes = (max_volume / self.dx.powi(3)) as usize;
        let mut fill: Vec<(u32, usize)> = Vec::new();
        let mut voids = 0;
        for slot in 0..self.blocks.len() as u32 {
            for o in 0..NODES {
                if below(&self.blocks[slot as usize], o) && mark(&mut seen, slot, o) {
                    let mut region = Vec::new();
                    stack.push((slot, o));
                    flood(&mut stack, &mut seen, Box::new(|s, n| region.push((s, n))));
                    if region.len() <= max_nodes {
                        fill.extend(region);
                        voids += 1;
                    }
                }
            }
        }
        for (slot, o) in fill {
            // A void's nodes are below the iso: never in a compacted (full) block.
            let field = self.blocks[slot as usize]
                .field
                .as_mut()
                .expect("a block with nodes below the iso holds them");
            field[0][o] = 2.0 * iso;
            for gradient in &mut field[1..] {
                gradient[o] = 0.0;
            }
        }
        self.mark_deep();
        voids
    }

    /// The union of two densities of the same voxel and iso: at each node the greater
    /// G with its gradient, so that each one's surface is kept whole where they come near
    /// (their sum would join them) — spray kept apart from the liquid it flew from. The
    /// velocity is the mean over both's particles.
    pub fn union(&mut self, other: DensityGrid) {
        assert!(
            self.dx == other.dx && self.iso == other.iso,
            "one grid, one iso"
        );
        self.h = self.h.max(other.h);
        self.bounds = self.bounds.union(other.bounds);
        for block in other.blocks {
            let Some(&slot) = self.slots.get(&block.coord) else {
                self.slots.insert(block.coord, self.blocks.len() as u32);
                self.blocks.push(block);
                continue;
            };
            let mine = &mut self.blocks[slot as usize];
            // A compacted block is inside everywhere already: the greater G changes
            // nothing there, the momentum adds the other's mean.
            if let Some(field) = mine.field.as_mut() {
                for n in 0..NODES {
                    let theirs = block.field_at(n);
                    if theirs[0] > field[0][n] {
                        for c in 0..4 {
                            field[c][n] = theirs[c];
                        }
                    }
                }
            }
            if let Some(m) = mine.momentum.as_mut() {
                for n in 0..NODES {
                    if let Some(o) = block.momentum_at(n) {
                        for c in 0..4 {
                            m[c][n] += o[c];
                        }
                    }
                }
            } else if let Some(mean) = mine.compacted.momentum.as_mut() {
                let mut other = block;
                other.compact();
                if let Some(o) = other.compacted.momentum {
                    for c in 0..4 {
                        mean[c] += o[c];
                    }
                }
            }
        }
        self.mark_deep();
    }

    /// Marks the blocks with some node inside and the deep ones (full, and their 26
    /// neighbours too).
    fn mark_deep(&mut self) {
        let iso = self.iso;
        self.blocks
            .par_iter_mut()
            .for_each(|b| b.inside = (0..NODES).any(|o| b.g(o) > iso));
        let full: Vec<bool> = self.blocks.par_iter().map(|b| b.full(iso)).collect();
        let deep: Vec<bool> = self
            .blocks
            .par_iter()
            .map(|b| {
                AROUND.iter().all(|&d| {
                    self.slots
                        .get(&(b.coord + d))
                        .is_some_and(|&s| full[s as usize])
                })
            })
            .collect();
        for (block, deep) in self.blocks.iter_mut().zip(deep) {
            block.deep = deep;
        }
    }

    #[inline]
    fn block(&self, coord: IVec3) -> Option<&Block> {
        self.slots.get(&coord).map(|&s| &self.blocks[s as usize])
    }

    /// Trilinear interpolation at `p` of a per-node quantity (zero at missing nodes).
    #[inline]
    fn interpolate<const N: usize>(
        &self,
        p: Vec3,
        at: impl Fn(&Block, usize) -> [f32; N],
    ) -> [f32; N] {
        let (u, _, home) = self.locate(p);
        self.interpolate_near(u, home, at)
    }

    /// [`DensityGrid::interpolate`] at `u` (node units), `home` the block `u` lies in
    /// (looked up by the caller, who read it too).
    #[inline]
    fn interpolate_near<const N: usize>(
        &self,
        u: Vec3,
        home: Option<&Block>,
        at: impl Fn(&Block, usize) -> [f32; N],
    ) -> [f32; N] {
        let base = floor_ivec3(u);
        let t = u - base.as_vec3();
        let mut sum = [0.0f32; N];
        let mut add = |value: [f32; N], w: f32| {
            for (s, v) in sum.iter_mut().zip(value) {
                *s += w * v;
            }
        };
        let local = base & (DIM - 1);
        if local.cmplt(IVec3::splat(DIM - 1)).all() {
            // All eight corners in one block: `home`.
            let Some(block) = home else {
                return sum;
            };
            for corner in 0..8 {
                let c = IVec3::new(corner >> 2, (corner >> 1) & 1, corner & 1);
                add(at(block, offset(local + c)), weight(t, c));
            }
        } else {
            // Corners in two (or four, eight) blocks: each block looked up once. (From the
            // local coordinates: `base + 1` overflows at the saturated ends of i32.)
            let first = base >> 3;
            let apart = IVec3::select(local.cmpeq(IVec3::splat(DIM - 1)), IVec3::ONE, IVec3::ZERO);
            let mut blocks: [Option<Option<&Block>>; 8] = [None; 8];
            blocks[0] = Some(home);
            for corner in 0..8 {
                let c = IVec3::new(corner >> 2, (corner >> 1) & 1, corner & 1);
                let b: IVec3 = c * apart;
                let slot = (b.x << 2 | b.y << 1 | b.z) as usize;
                let block = *blocks[slot].get_or_insert_with(|| self.block(first + b));
                if let Some(block) = block {
                    add(at(block, offset((local + c) & (DIM - 1))), weight(t, c));
                }
            }
        }
        sum
    }

    /// G and ∇G at `p`.
    pub fn density_and_gradient(&self, p: Vec3) -> (f32, Vec3) {
        let [g, gx, gy, gz] = self.interpolate(p, |b, o| b.field_at(o));
        (g, Vec3::new(gx, gy, gz))
    }

    /// The density as a VDB fog volume named `density` (background 0, active where G > 0).
    pub fn to_fog_volume(&self) -> GridData {
        let transform = Transform::uniform(f64::from(self.dx), [0.0; 3]);
        let mut data = GridData::empty("density", GridClass::FogVolume, 0.0, transform);
        let mut blocks: Vec<&Block> = self.blocks.iter().collect();
        blocks.sort_unstable_by_key(|b| b.coord.to_array());
        for block in blocks {
            let mut mask = [0u64; MASK_WORDS];
            let values: [f32; NODES] = std::array::from_fn(|o| block.g(o));
            for (o, &g) in values.iter().enumerate() {
                if g > 0.0 {
                    mask[o >> 6] |= 1 << (o & 63);
                }
            }
            if mask.iter().any(|&w| w != 0) {
                data.push_leaf((block.coord * DIM).to_array(), &values, mask);
            }
        }
        data
    }
}

#[inline]
fn weight(t: Vec3, corner: IVec3) -> f32 {
    let pick = |t: f32, c: i32| if c == 1 { t } else { 1.0 - t };
    pick(t.x, corner.x) * pick(t.y, corner.y) * pick(t.z, corner.z)
}

/// ⌊x⌋ for |x| < 2³¹, inlined (`f32::floor` is a libm call without SSE4.1).
#[inline]
fn floor(x: f32) -> i32 {
    let i = x as i32;
    i - i32::from((i as f32) > x)
}

/// ⌈x⌉ for |x| < 2³¹.
#[inline]
fn ceil(x: f32) -> i32 {
    let i = x as i32;
    i + i32::from((i as f32) < x)
}

/// One particle's kernel as [`splat`] adds it: its position, 1/h², volume and velocity.
#[derive(Clone, Copy)]
struct Kernel {
    p: Vec3,
    inv_h2: f32,
    volume: f32,
    velocity: Option<Vec3>,
}

impl Kernel {
    fn of(density: &Density, i: usize) -> Self {
        let (p, inv_h2) = density.particles[i];
        Kernel {
            p,
            inv_h2,
            volume: density.volumes[i],
            velocity: density.velocities.get(i).copied(),
        }
    }
}

/// A run of more particles than this in one block's cell is looked at for particles on
/// top of each other ([`merged_copies`]).
const CROWDED_RUN: usize = 4096;

/// The kernels of `indices` (into `density`'s particles, in order) with the particles
/// that share a position and a support merged into one, in the order of their first:
/// their volumes summed, their velocity the volume-weighted mean (so that the density
/// and the momentum are the sums the copies would add). A particle without copies is
/// kept as it is.
fn merged_copies(density: &Density, indices: impl Iterator<Item = usize>) -> Vec<Kernel> {
    let mut kernels: Vec<Kernel> = Vec::new();
    let mut first: HashMap<(u32, u32, u32, u32), usize> = HashMap::new();
    // Each merged kernel's volume and momentum summed in f64: millions of copies'
    // volumes, each tiny, would lose their sum in f32.
    let mut sums: Vec<Option<(f64, glam::DVec3)>> = Vec::new();
    for i in indices {
        let k = Kernel::of(density, i);
        let key = (
            k.p.x.to_bits(),
            k.p.y.to_bits(),
            k.p.z.to_bits(),
            k.inv_h2.to_bits(),
        );
        let momentum =
            |k: &Kernel| k.velocity.unwrap_or(Vec3::ZERO).as_dvec3() * f64::from(k.volume);
        match first.get(&key) {
            Some(&at) => {
                let (volume, m) = sums[at]
                    .get_or_insert_with(|| (f64::from(kernels[at].volume), momentum(&kernels[at])));
                *volume += f64::from(k.volume);
                *m += momentum(&k);
            }
            None => {
                first.insert(key, kernels.len());
                kernels.push(k);
                sums.push(None);
            }
        }
    }
    for (k, sum) in kernels.iter_mut().zip(sums) {
        if let Some((volume, m)) = sum {
            k.volume = volume as f32;
            if let Some(v) = k.velocity.as_mut() {
                *v = (m / volume).as_vec3();
            }
        }
    }
    kernels
}

/// Adds a particle's kernel, gradient and momentum to the nodes of `block` within its
/// support: W = (1 − q²)³, ∇W = −6 (1 − q²)² (x − p) / h². `lo`, `hi`: the block's
/// corner nodes in world space.
#[inline]
fn splat(block: &mut Block, density: &Density, kernel: Kernel, dx: f32, lo: Vec3, hi: Vec3) {
    let Kernel {
        p,
        inv_h2,
        volume,
        velocity: v,
    } = kernel;
    let h = inv_h2.sqrt().recip();
    // Most particles of the neighbour blocks do not reach this one.
    if (p + Vec3::splat(h)).cmplt(lo).any() || (p - Vec3::splat(h)).cmpgt(hi).any() {
        return;
    }
    let origin = block.coord * DIM;
    let inv_dx = dx.recip();
    let range = |c: f32, o: i32| {
        let a = (ceil((c - h) * inv_dx) - o).max(0);
        let b = (floor((c + h) * inv_dx) - o).min(DIM - 1);
        a..=b
    };
    let (xs, ys) = (range(p.x, origin.x), range(p.y, origin.y));
    // Whole rows of 8 nodes along z, outside the support weighted 0: vectors, no branch.
    let rz: [f32; 8] = std::array::from_fn(|k| (origin.z + k as i32) as f32 * dx - p.z);
    let velocity_scale = density.velocity_q2_scale();
    let [g, gx, gy, gz] = &mut **block
        .field
        .as_mut()
        .expect("a block being summed holds its nodes");
    for x in xs {
        let rx = (origin.x + x) as f32 * dx - p.x;
        let qx = rx * rx * inv_h2;
        for y in ys.clone() {
            let ry = (origin.y + y) as f32 * dx - p.y;
            let qxy = qx + ry * ry * inv_h2;
            if qxy >= 1.0 {
                continue;
            }
            let row = (x * 64 + y * 8) as usize..(x * 64 + y * 8 + 8) as usize;
            let mut w = [0.0f32; 8];
            let mut c = [0.0f32; 8];
            for k in 0..8 {
                let s = (1.0 - qxy - rz[k] * rz[k] * inv_h2).max(0.0);
                w[k] = volume * s * s * s;
                c[k] = -6.0 * volume * s * s * inv_h2;
            }
            for (k, o) in row.clone().enumerate() {
                g[o] += w[k];
                gx[o] += c[k] * rx;
                gy[o] += c[k] * ry;
                gz[o] += c[k] * rz[k];
            }
            // The velocity's narrower kernel misses most rows of the density's.
            let within = qxy * velocity_scale < 1.0;
            if let (Some(m), Some(v), true) = (&mut block.momentum, v, within) {
                for (n, o) in row.enumerate() {
                    let s = (1.0 - (qxy + rz[n] * rz[n] * inv_h2) * velocity_scale).max(0.0);
                    let w = volume * s * s * s;
                    m[0][o] += w * v.x;
                    m[1][o] += w * v.y;
                    m[2][o] += w * v.z;
                    m[3][o] += w;
                }
            }
        }
    }
}

/// How deep `u` (node units) lies in the box of the 3³ blocks around block `c`: every
/// cell holding a surface point has a corner on each side of the iso, so where all the
/// nodes of those blocks are on one side the surface lies beyond the box, at least this
/// far (voxels).
fn depth_in_neighbourhood(c: IVec3, u: Vec3) -> f32 {
    let lo = (c * DIM - IVec3::splat(DIM)).as_vec3();
    let hi = (c * DIM + IVec3::splat(2 * DIM - 1)).as_vec3();
    (u - lo).min(hi - u).min_element()
}

impl Target for DensityGrid {
    /// First-order distance to the iso-density surface, (iso − G)/|∇G|, capped at h where
    /// the density fades. In a deep block, and where no particle reaches the 3³ blocks
    /// around, the distance to the neighbourhood's edge bounds it instead: a seed or a
    /// start skin then skips those blocks outright.
    fn distance(&self, p: Vec3) -> f32 {
        // The block `p` lies in, looked up once for the bound and the interpolation (a
        // skin's attraction reads the distance at its mesh's vertices every sub-step).
        let (u, c, home) = self.locate(p);
        if let Some(bound) = self.bound_by_block(c, u, home) {
            return bound;
        }
        let [g, gx, gy, gz] = self.interpolate_near(u, home, |b, o| b.field_at(o));
        let grad = Vec3::new(gx, gy, gz);
        let value = self.iso - g;
        let norm = grad.length().max(value.abs() / self.h).max(1e-12);
        (value / norm).clamp(-self.h, self.h)
    }
    /// The density alone against the iso: [`Target::distance`]'s sign without its
    /// gradient.
    fn inside(&self, p: Vec3) -> bool {
        let (u, c, home) = self.locate(p);
        match self.bound_by_block(c, u, home) {
            Some(bound) => bound < 0.0,
            None => self.interpolate_near(u, home, |b, o| [b.g(o)])[0] > self.iso,
        }
    }
    /// A block of a skin on this grid's own nodes and blocks (the particle runs' case)
    /// reads this grid's block: one lookup, no interpolation.
    fn block_inside(&self, corner: Vec3, dx: f32, out: &mut [bool; BLOCK_NODES]) {
        let Some(base) = self
            .node_at(corner, dx)
            .filter(|b| *b & (DIM - 1) == IVec3::ZERO)
        else {
            for (o, inside) in out.iter_mut().enumerate() {
                *inside = self.inside(corner + offset_coords(o).as_vec3() * dx);
            }
            return;
        };
        match self.block(base >> 3) {
            Some(block) if block.deep => out.fill(true),
            Some(block) => {
                for (o, inside) in out.iter_mut().enumerate() {
                    *inside = block.g(o) > self.iso;
                }
            }
            // Between nodes of no block the density is nil.
            None => out.fill(false),
        }
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn parts(&self) -> Vec<Aabb> {
        self.block_boxes()
    }
    /// Inside only where some node of the blocks around `region` has G > iso: the
    /// trilinear density between nodes never exceeds theirs.
    fn may_be_inside(&self, region: Aabb) -> bool {
        let lo: IVec3 = (region.min / self.dx).floor().as_ivec3() >> 3;
        let hi: IVec3 = (region.max / self.dx).ceil().as_ivec3() >> 3;
        (lo.x..=hi.x).any(|x| {
            (lo.y..=hi.y).any(|y| {
                (lo.z..=hi.z).any(|z| self.block(IVec3::new(x, y, z)).is_some_and(|b| b.inside))
            })
        })
    }
}

impl DensityGrid {
    /// This grid's node at `corner` when a skin of voxels `dx` with a node there shares
    /// this grid's nodes (the particle runs' case): its blocks are then read, not
    /// interpolated.
    fn node_at(&self, corner: Vec3, dx: f32) -> Option<IVec3> {
        let base = (corner / self.dx).round();
        let aligned = (dx - self.dx).abs() <= 1e-6 * self.dx
            && (corner - base * self.dx).abs().max_element() <= 1e-4 * self.dx;
        aligned.then(|| base.as_ivec3())
    }

    /// `p` in node units, its block's coordinate and that block, if stored.
    #[inline]
    fn locate(&self, p: Vec3) -> (Vec3, IVec3, Option<&Block>) {
        let u = p / self.dx;
        let c = floor_ivec3(u) >> 3;
        (u, c, self.block(c))
    }

    /// The distance at `u` (node units) where its block `c` (`home`) alone bounds it: in
    /// a deep block, and where no particle reaches the 3³ blocks around, the distance to
    /// the neighbourhood's edge.
    fn bound_by_block(&self, c: IVec3, u: Vec3, home: Option<&Block>) -> Option<f32> {
        match home {
            Some(block) if block.deep => Some(-depth_in_neighbourhood(c, u) * self.dx),
            None if AROUND.iter().all(|&d| self.block(c + d).is_none()) => {
                Some(depth_in_neighbourhood(c, u) * self.dx)
            }
            _ => None,
        }
    }

    /// The particles' kernel-weighted mean velocity at `p` (Shepard, Σ W·v / Σ W, with the
    /// velocity's kernel, [`super::VELOCITY_SUPPORT_RADII`]); `None` where no particle
    /// reaches or none carries a velocity.
    fn mean_velocity(&self, p: Vec3) -> Option<Vec3> {
        if !self.velocities {
            return None;
        }
        let [g, mx, my, mz] = self.interpolate(p, |b, o| match b.momentum_at(o) {
            Some(m) => [m[3], m[0], m[1], m[2]],
            None => EMPTY,
        });
        (g > super::MIN_VELOCITY_WEIGHT).then(|| Vec3::new(mx, my, mz) / g)
    }
}

/// The particles' velocity: their kernel-weighted mean; zero where no particle reaches.
impl Flow for DensityGrid {
    fn velocity(&self, p: Vec3) -> Vec3 {
        self.mean_velocity(p).unwrap_or(Vec3::ZERO)
    }
}

/// The particles' motion over a frame when their velocities are that frame's mean (each
/// particle's displacement from the frame before, per second:
/// [`crate::particles::motion::frame_velocities`]): the material at p was at p − Δt·u(p);
/// no material where no particle reaches.
impl FlowMap for DensityGrid {
    fn departure(&self, p: Vec3, duration: f32) -> Option<Vec3> {
        self.mean_velocity(p).map(|u| p - u * duration)
    }
    /// A skin on this grid's own nodes (the particle runs' case) reads each node's mean
    /// from its block, one lookup per block met, instead of eight corners interpolated.
    fn block_departures(&self, corner: Vec3, dx: f32, duration: f32, out: &mut Vec<Option<Vec3>>) {
        let base = self.node_at(corner, dx);
        let (true, Some(base)) = (self.velocities, base) else {
            out.clear();
            out.extend(
                (0..BLOCK_NODES)
                    .map(|o| self.departure(corner + offset_coords(o).as_vec3() * dx, duration)),
            );
            return;
        };
        let mut last: Option<(IVec3, Option<&Block>)> = None;
        out.clear();
        out.extend((0..BLOCK_NODES).map(|o| {
            let node = base + offset_coords(o);
            let coord = node >> 3;
            let block = match last {
                Some((c, b)) if c == coord => b,
                _ => {
                    let b = self.block(coord);
                    last = Some((coord, b));
                    b
                }
            };
            let m = block?.momentum_at(offset(node & (DIM - 1)))?;
            let g = m[3];
            (g > super::MIN_VELOCITY_WEIGHT).then(|| {
                let p = corner + offset_coords(o).as_vec3() * dx;
                p - Vec3::new(m[0], m[1], m[2]) / g * duration
            })
        }));
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn parts(&self) -> Vec<Aabb> {
        self.block_boxes()
    }
}

impl DensityGrid {
    /// Each block's box, up to the next block's first nodes (the density between them is
    /// interpolated): beyond them it is zero, and the field outside.
    fn block_boxes(&self) -> Vec<Aabb> {
        let side = DIM as f32 * self.dx;
        self.blocks
            .iter()
            .map(|b| {
                let min = b.coord.as_vec3() * side;
                Aabb {
                    min,
                    max: min + Vec3::splat(side),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::target::{fluid_iso, rest_density, DEFAULT_SMOOTHING_LENGTH};

    /// Particles of radius `r` on a lattice of spacing 2r in a ball of `radius`, jittered
    /// by up to ±0.15 r (repeatably), with a swirling velocity.
    fn ball(r: f32, radius: f32) -> (Vec<Vec3>, Vec<Vec3>) {
        let mut state = 99u64;
        let mut jitter = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.3 * r
        };
        let n = (radius / (2.0 * r)) as i32;
        let mut points = Vec::new();
        for x in -n..=n {
            for y in -n..=n {
                for z in -n..=n {
                    let p = IVec3::new(x, y, z).as_vec3() * 2.0 * r;
                    if p.length() <= radius {
                        points
                            .push(p + Vec3::new(jitter(), jitter(), jitter()) + Vec3::splat(0.013));
                    }
                }
            }
        }
        let velocities = points.iter().map(|p| Vec3::new(-p.y, p.x, 0.3)).collect();
        (points, velocities)
    }

    /// [`ball`]'s particles as a density of smoothing length `l` (support 2·l·r) with
    /// their velocities, normalized as the particle runs have it.
    fn ball_density(r: f32, l: f32, radius: f32) -> Density {
        let (points, velocities) = ball(r, radius);
        Density::new(points, 2.0 * l * r, fluid_iso(l))
            .normalized(l)
            .velocity_within(super::super::VELOCITY_SUPPORT_RADII, l)
            .with_velocities(&velocities)
    }

    #[test]
    fn block_departures_read_the_nodes_as_departure_interpolates_them() {
        let (r, l) = (0.05f32, 2.0f32);
        let exact = ball_density(r, l, 0.6);
        let grid = DensityGrid::rasterize(&exact, r);
        let (mut fast, mut slow) = (Vec::new(), Vec::new());
        let mut compared = 0;
        // Blocks of the grid's own nodes (one density block, or eight when shifted by
        // whole nodes), and one off the nodes, which takes the interpolating path.
        for corner in [
            IVec3::new(-8, 0, 0),
            IVec3::new(-3, 5, -14),
            IVec3::new(9, -12, 4),
        ] {
            for shift in [Vec3::ZERO, Vec3::splat(0.37 * r)] {
                let corner = corner.as_vec3() * r + shift;
                grid.block_departures(corner, r, 0.04, &mut fast);
                slow.clear();
                slow.extend(
                    (0..BLOCK_NODES)
                        .map(|o| grid.departure(corner + offset_coords(o).as_vec3() * r, 0.04)),
                );
                assert_eq!(fast.len(), BLOCK_NODES);
                for (a, b) in fast.iter().zip(&slow) {
                    match (a, b) {
                        (Some(a), Some(b)) => {
                            assert!((*a - *b).length() < 1e-3 * r, "{a} {b}");
                            compared += 1;
                        }
                        (None, None) => {}
                        _ => panic!("{a:?} against {b:?} at {corner}"),
                    }
                }
            }
        }
        assert!(compared > 1000, "{compared}");
    }

    #[test]
    fn particles_piled_on_each_other_rasterize_as_their_sum() {
        // Three points, 3 000 copies each, in one block's cell (over CROWDED_RUN): merged
        // into three kernels of 3 000 times the volume, the density and the momentum are
        // the copies' sums (the exact Density's, pair by pair).
        let r = 0.05f32;
        let points = [
            Vec3::new(0.11, 0.12, 0.13),
            Vec3::new(0.14, 0.12, 0.13),
            Vec3::new(0.11, 0.16, 0.12),
        ];
        let positions: Vec<Vec3> = (0..9000).map(|i| points[i % 3]).collect();
        let velocities: Vec<Vec3> = (0..9000)
            .map(|i| Vec3::new(i as f32 * 1e-4, 1.0, 0.0))
            .collect();
        let exact = Density::new(positions, 4.0 * r, fluid_iso(2.0)).with_velocities(&velocities);
        let merged = merged_copies(&exact, 0..9000);
        assert_eq!(merged.len(), 3, "one kernel a point");
        assert!(merged.iter().all(|k| (k.volume - 3000.0).abs() < 1e-3));
        let grid = DensityGrid::rasterize(&exact, r / 2.0);
        let mut compared = 0;
        for x in 0..16 {
            for y in 0..16 {
                for z in 0..16 {
                    let p = IVec3::new(x, y, z).as_vec3() * (r / 2.0);
                    let (g, grad) = exact.density_and_gradient(p);
                    let (gg, ggrad) = grid.density_and_gradient(p);
                    assert!(
                        (g - gg).abs() <= 1e-3 * g.max(1.0),
                        "{g} against {gg} at {p}"
                    );
                    assert!(
                        (grad - ggrad).length() <= 1e-3 * grad.length().max(1.0),
                        "{grad} {ggrad}"
                    );
                    if g > 0.0 {
                        let u = exact.velocity(p);
                        assert!((u - grid.velocity(p)).length() < 1e-4, "{u} at {p}");
                        compared += 1;
                    }
                }
            }
        }
        assert!(compared > 100, "{compared}");
    }

    #[test]
    fn block_inside_is_the_sign_of_the_distance() {
        let (r, l) = (0.05f32, 2.0f32);
        let (points, _) = ball(r, 0.6);
        let exact = Density::new(points, 2.0 * l * r, fluid_iso(l)).normalized(l);
        let grid = DensityGrid::rasterize(&exact, r);
        let (mut inside, mut outside) = (0, 0);
        // The grid's own blocks (one read each), blocks off them by whole nodes and off
        // the nodes (interpolated): deep inside, across the surface, beyond the particles.
        for corner in [
            IVec3::new(-8, 0, 0),
            IVec3::new(0, 0, 0),
            IVec3::new(8, -16, 0),
            IVec3::new(-3, 5, -14),
            IVec3::new(40, 40, 40),
        ] {
            for shift in [Vec3::ZERO, Vec3::splat(0.37 * r)] {
                let corner = corner.as_vec3() * r + shift;
                let mut fast = [false; BLOCK_NODES];
                grid.block_inside(corner, r, &mut fast);
                for (o, &fast) in fast.iter().enumerate() {
                    let p = corner + offset_coords(o).as_vec3() * r;
                    assert_eq!(fast, grid.inside(p), "block_inside at {p}");
                    assert_eq!(fast, grid.distance(p) < 0.0, "inside at {p}");
                    (inside, outside) = (inside + fast as usize, outside + !fast as usize);
                }
            }
        }
        assert!(
            inside > 1000 && outside > 1000,
            "{inside} in, {outside} out"
        );
    }

    /// A ball of liquid 13 blocks across: its bulk compacted (issue 53: a frame's density
    /// held near its surface, not through its volume), every node within two blocks of a
    /// block that is not full kept whole, and what the skin reads near the surface — G, its
    /// gradient, the distance and the velocity — the same as every node's grid's, bit for
    /// bit, from the surface to 16 voxels inside.
    #[test]
    fn a_deep_liquids_bulk_is_compacted_and_reads_the_same_near_its_surface() {
        let (r, l) = (0.05f32, 2.0f32);
        let (dx, h) = (r, 2.0 * l * r);
        let density = ball_density(r, l, 2.6);
        let whole = DensityGrid::rasterize(&density, dx);
        let compact = DensityGrid::rasterize_within(&density, dx, u64::MAX, false).unwrap();
        assert!(whole.blocks.iter().all(|b| b.field.is_some()));
        assert_eq!(whole.blocks.len(), compact.blocks.len());
        // Compacted: the blocks whose 5³ blocks around are all full in every node's grid.
        let full = |c: IVec3| whole.block(c).is_some_and(|b| b.full(whole.iso));
        let reach = -COMPACT_REACH..=COMPACT_REACH;
        let mut compacted = 0;
        for b in &compact.blocks {
            let deep = reach.clone().all(|x| {
                reach
                    .clone()
                    .all(|y| reach.clone().all(|z| full(b.coord + IVec3::new(x, y, z))))
            });
            assert_eq!(b.field.is_none(), deep, "block {}", b.coord);
            compacted += usize::from(deep);
        }
        assert!(
            compacted > 50,
            "{compacted} of {} blocks",
            compact.blocks.len()
        );
        let mut near = 0;
        for i in 0..6000 {
            let t = i as f32 * 0.618_034;
            let z = i as f32 / 6000.0 * 2.0 - 1.0;
            let dir = Vec3::new(
                t.cos() * (1.0 - z * z).sqrt(),
                t.sin() * (1.0 - z * z).sqrt(),
                z,
            );
            let depth = (i % 17) as f32 - 1.0;
            let p = dir * (2.6 + r - depth * dx) + Vec3::splat(0.013);
            let (g, grad) = compact.density_and_gradient(p);
            assert_eq!((g, grad), whole.density_and_gradient(p), "at {p}");
            assert_eq!(compact.distance(p), whole.distance(p), "at {p}");
            assert_eq!(compact.mean_velocity(p), whole.mean_velocity(p), "at {p}");
            near += 1;
        }
        assert_eq!(near, 6000);
        // Deep inside, the bulk reads as inside, its distance bounded by the blocks.
        let centre = Vec3::splat(0.013);
        assert!(compact.inside(centre) && compact.distance(centre) <= -h);
        assert!(compact.mean_velocity(centre).is_some());
    }

    #[test]
    fn rasterized_density_matches_the_exact_sum() {
        let (r, l) = (0.05f32, 2.0f32);
        let dx = r;
        let exact = ball_density(r, l, 0.6);
        let grid = DensityGrid::rasterize(&exact, dx);
        // Exact at the nodes, and between them within a small fraction of a voxel near
        // the surface.
        let mut worst_node = 0.0f32;
        let mut errors = Vec::new();
        let (mut worst_velocity, mut worst_node_velocity) = (0.0f32, 0.0f32);
        for i in 0..4000 {
            let t = i as f32 * 0.618_034;
            let dir = Vec3::new(
                t.cos() * (1.0 - (i as f32 / 4000.0).powi(2)).sqrt(),
                t.sin() * (1.0 - (i as f32 / 4000.0).powi(2)).sqrt(),
                i as f32 / 4000.0 * 2.0 - 1.0,
            )
            .normalize();
            let p = dir * (0.6 + r) + Vec3::splat(0.013) + dir * ((i % 7) as f32 - 3.0) * 0.5 * dx;
            let node = (p / dx).round() * dx;
            let (g, _) = grid.density_and_gradient(node);
            worst_node = worst_node.max((g - exact.density(node)).abs());
            let d = exact.distance(p);
            // Where the skin's zero crossings are: within a voxel of the surface.
            if d.abs() < dx {
                errors.push((grid.distance(p) - d).abs() / dx);
            }
            // The velocity's kernel is narrower than the density's (2.5 r): between nodes,
            // compared inside the surface (past it, at the kernel's rim, the nodes around
            // may have no particle while the point has one); at the nodes, where the
            // skin's carry reads it, everywhere.
            let v = grid.velocity(p);
            let u = exact.velocity(p);
            if d < 0.0 {
                worst_velocity = worst_velocity.max((v - u).length() / u.length().max(0.1));
            }
            let (v, u) = (grid.velocity(node), exact.velocity(node));
            worst_node_velocity = worst_node_velocity.max((v - u).length() / u.length().max(0.1));
        }
        let mean = errors.iter().sum::<f32>() / errors.len() as f32;
        let worst = errors.iter().copied().fold(0.0, f32::max);
        println!("node {worst_node:e}, distance mean {mean:.4} worst {worst:.4} voxel, velocity {worst_velocity:.4}, at nodes {worst_node_velocity:e}");
        assert!(worst_node < 1e-4, "{worst_node}");
        assert!(
            mean < 0.03 && worst < 0.15,
            "mean {mean} worst {worst} voxel"
        );
        // A mean over a few particles (2.5 r) is less smooth than the density: trilinear
        // between nodes, 7 % of the speed at worst here.
        assert!(worst_velocity < 0.08, "{worst_velocity}");
        assert!(worst_node_velocity < 1e-4, "{worst_node_velocity}");
    }

    #[test]
    fn voids_smaller_than_the_support_are_filled_larger_cavities_kept() {
        let (r, l) = (0.05f32, 2.0f32);
        let (dx, h) = (r, 2.0 * l * r);
        let support = 4.0 / 3.0 * std::f32::consts::PI * h.powi(3);
        let centre = Vec3::splat(0.013);
        for (hole, filled) in [(0.15, true), (0.4, false)] {
            let (points, _) = ball(r, 0.7);
            let points: Vec<Vec3> = points
                .into_iter()
                .filter(|p| (*p - centre).length() > hole)
                .collect();
            let density = Density::new(points, h, fluid_iso(l));
            let mut grid = DensityGrid::rasterize(&density, dx);
            assert!(grid.distance(centre) > 0.0, "hole {hole}: no void to fill");
            let out = centre + Vec3::X * 0.75;
            let before = grid.distance(out);
            let voids = grid.fill_voids(support);
            assert_eq!(voids, usize::from(filled), "hole {hole}");
            assert_eq!(grid.distance(centre) < 0.0, filled, "hole {hole}");
            // The outer surface stays where it was.
            assert_eq!(grid.distance(out), before);
        }
    }

    #[test]
    fn rest_density_and_fluid_iso_match_the_continuum() {
        for l in [1.5f32, 2.0, 3.0] {
            // Once the support spans more than a spacing the lattice's sum is the integral's.
            let rest = rest_density(l);
            let continuum = 64.0 * std::f32::consts::PI * l.powi(3) / 315.0;
            assert!(
                (rest / continuum - 1.0).abs() < 0.06,
                "l {l}: {rest} vs {continuum}"
            );
            // A continuum's boundary has half its density; the outer layers' larger
            // volumes raise it.
            let iso = fluid_iso(l) / rest;
            println!("l {l}: rest density {rest:.3}, fluid iso {iso:.3} of it");
            assert!((0.5..0.7).contains(&iso), "l {l}: {iso}");
        }
    }

    #[test]
    fn lone_particles_and_thin_sheets_keep_a_surface() {
        let (r, l) = (0.05f32, DEFAULT_SMOOTHING_LENGTH);
        let h = 2.0 * l * r;
        let lone = Density::new(vec![Vec3::ZERO], h, fluid_iso(l)).normalized(l);
        let radius = (0..400)
            .map(|k| k as f32 * 0.01 * r)
            .find(|&d| lone.distance(Vec3::X * d) > 0.0)
            .unwrap();
        println!("lone particle: surface at {:.3} r", radius / r);
        // The droplet holds the (2r)³ the particle stands for: radius (6/π)^⅓ r.
        let droplet = (6.0 / std::f32::consts::PI).cbrt();
        assert!((radius / r - droplet).abs() < 0.015, "{}", radius / r);
        // A sheet one particle thick: a surface on both sides, within two radii.
        let sheet: Vec<Vec3> = (-10..=10)
            .flat_map(|x| (-10..=10).map(move |y| Vec3::new(x as f32, y as f32, 0.0) * 2.0 * r))
            .collect();
        let sheet = Density::new(sheet, h, fluid_iso(l)).normalized(l);
        assert!(sheet.distance(Vec3::ZERO) < 0.0);
        assert!(sheet.distance(Vec3::Z * 2.0 * r) > 0.0);
        assert!(sheet.distance(-Vec3::Z * 2.0 * r) > 0.0);
    }

    /// A clump of three particles 3.5 radii over a pool: summed, the kernels' tails join
    /// it to the pool; found as spray, it is rasterized apart and united, so the density
    /// between them is below the iso, while in the clump and the pool it is as summed.
    #[test]
    fn spray_is_rasterized_apart_and_united() {
        let mut points = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                for k in 0..4 {
                    points.push(2.0 * Vec3::new(i as f32, j as f32, k as f32));
                }
            }
        }
        let top = Vec3::new(8.0, 8.0, 6.0);
        let clump = [0.0, 0.4, 0.8].map(|x| top + Vec3::new(x, 0.3 * x, 3.5 + 0.2 * x));
        points.extend(clump);
        let (l, dx) = (2.0, 0.25);
        let summed = Density::new(points.clone(), 4.0, fluid_iso(l)).normalized(l);
        let united = Density::new(points, 4.0, fluid_iso(l))
            .finding_spray(3.25, crate::target::SPRAY_MOST)
            .normalized(l);
        let (summed, united) = (
            DensityGrid::rasterize(&summed, dx),
            DensityGrid::rasterize(&united, dx),
        );
        let iso = fluid_iso(l);
        let gap = top + Vec3::new(0.0, 0.0, 1.75);
        let (joined, apart) = (
            summed.density_and_gradient(gap).0,
            united.density_and_gradient(gap).0,
        );
        assert!(
            joined > iso && apart < iso,
            "{joined} and {apart}, iso {iso}"
        );
        for p in [clump[1], Vec3::new(6.0, 6.0, 2.0)] {
            let (a, b) = (
                summed.density_and_gradient(p).0,
                united.density_and_gradient(p).0,
            );
            assert!(b > iso && (a - b).abs() < 0.02 * a, "{p}: {a} against {b}");
        }
        assert_eq!(united.has_velocities(), summed.has_velocities());
    }
}
