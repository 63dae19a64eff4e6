//! Advection of the potential by the material's velocity (paper §7): `∂f/∂t + u·∇f = 0`
//! over the tube, semi-Lagrangian with the MacCormack correction (second order where the
//! potential is smooth), limited to the values it interpolates between so that it never
//! creates a new extremum. Departure points are traced with the midpoint rule (second
//! order: an Euler trace drifts outward on a rotation and shrinks what it carries). The
//! CFL bound keeps |u|·dt under a voxel, so every departure point lies in a node's
//! one-node halo.

use crate::stencil::cubic_weights;
use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::flow::Flow;
use crate::grid::IndexToWorld;
use crate::grid::{
    offset_coords, Potential, SparseGrid, WideHalo, BLOCK_DIM, BLOCK_NODES, WIDE_DIM,
};

/// Scratch reused across steps, per node: the backward trace, the values before
/// advection, the bounds of the forward interpolation, and each pass's output.
#[derive(Default)]
pub(crate) struct Scratch {
    ahead: Vec<[Vec3; BLOCK_NODES]>,
    before: Vec<[f32; BLOCK_NODES]>,
    low: Vec<[f32; BLOCK_NODES]>,
    high: Vec<[f32; BLOCK_NODES]>,
    out: Vec<[f32; BLOCK_NODES]>,
}

/// Tricubic (Catmull-Rom) interpolation of the halo at local point `p` (each coordinate
/// in -1..=8), with the smallest and largest of the eight nodes of its cell, which bound
/// the result (a cubic may overshoot them; the limiter keeps what it adds in between).
#[inline]
fn interpolate(halo: &WideHalo, p: Vec3) -> (f32, f32, f32) {
    // floor(p) for p > −2, without a libm call: the halo starts at −2.
    let b = ((p + Vec3::splat(2.0)).as_ivec3() - IVec3::splat(2))
        .clamp(IVec3::splat(-1), IVec3::splat(7));
    let t = (p - b.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
    let (wx, wy, wz) = (cubic_weights(t.x), cubic_weights(t.y), cubic_weights(t.z));
    const X: usize = WIDE_DIM * WIDE_DIM;
    const Y: usize = WIDE_DIM;
    // The 4³ stencil from (b − 1); b − 1 ≥ −2 and b + 2 ≤ 9 keep it within the halo.
    let corner = WideHalo::index(b.x - 1, b.y - 1, b.z - 1);
    let values = &halo.values;
    let mut value = 0.0;
    for (i, wx) in wx.iter().enumerate() {
        let mut plane = 0.0;
        for (j, wy) in wy.iter().enumerate() {
            let start = corner + i * X + j * Y;
            let row: &[f32; 4] = values[start..start + 4].try_into().expect("4 nodes");
            plane += wy * (wz[0] * row[0] + wz[1] * row[1] + wz[2] * row[2] + wz[3] * row[3]);
        }
        value += wx * plane;
    }
    let cell = corner + X + Y + 1;
    let (mut low, mut high) = (f32::INFINITY, f32::NEG_INFINITY);
    for start in [cell, cell + Y, cell + X, cell + X + Y] {
        for &v in &values[start..start + 2] {
            low = low.min(v);
            high = high.max(v);
        }
    }
    (value.clamp(low, high), low, high)
}

/// Where the material at `x` (world) was `dt` seconds ago and where it will be `dt`
/// seconds on, by the midpoint rule (the velocity at `x` read once for both).
#[inline]
fn trace_both_ways(flow: &dyn Flow, x: Vec3, dt: f32) -> (Vec3, Vec3) {
    let half = flow.velocity(x) * (0.5 * dt);
    (
        x - flow.velocity(x - half) * dt,
        x + flow.velocity(x + half) * dt,
    )
}

/// Advects the active nodes of `grid` (voxels `xf`) by `dt` seconds of `flow`.
pub(crate) fn maccormack<P: Potential>(
    grid: &mut SparseGrid<P>,
    flow: &dyn Flow,
    xf: IndexToWorld,
    dt: f32,
    scratch: &mut Scratch,
) {
    let n = grid.block_count();
    let Scratch {
        ahead,
        before,
        low,
        high,
        out,
    } = scratch;
    for buffer in [&mut *before, &mut *low, &mut *high, &mut *out] {
        buffer.resize(n, [0.0; BLOCK_NODES]);
    }
    ahead.resize(n, [Vec3::ZERO; BLOCK_NODES]);

    // Forward: f̂(x) = f(x − u dt), remembering f and the interpolation's bounds.
    let grid_ref = &*grid;
    grid_ref
        .blocks()
        .par_iter()
        .zip(ahead.par_iter_mut())
        .zip(before.par_iter_mut().zip(out.par_iter_mut()))
        .zip(low.par_iter_mut().zip(high.par_iter_mut()))
        .for_each_init(
            Box::<WideHalo>::default,
            |halo, (((block, ahead), (before, out)), (low, high))| {
                halo.gather(grid_ref, block);
                for offset in 0..BLOCK_NODES {
                    let l = offset_coords(offset);
                    before[offset] = halo.at(l.x, l.y, l.z);
                    out[offset] = before[offset];
                }
                let base = block.coord * BLOCK_DIM;
                // Local index coordinates of a world point, relative to this block.
                let local = |w: Vec3| (w - xf.origin) / xf.dx - base.as_vec3();
                for offset in block.active_offsets() {
                    let x = xf.apply((base + offset_coords(offset)).as_vec3());
                    let (was, will_be) = trace_both_ways(flow, x, dt);
                    ahead[offset] = local(will_be);
                    let departure = local(was);
                    (out[offset], low[offset], high[offset]) = interpolate(halo, departure);
                }
            },
        );
    store(grid, out);

    // Backward: f̃(x) = f̂(x + u dt); corrected f̂ + (f − f̃)/2, kept within the bounds.
    let grid_ref = &*grid;
    grid_ref
        .blocks()
        .par_iter()
        .zip(ahead.par_iter())
        .zip(out.par_iter_mut())
        .enumerate()
        .for_each_init(
            Box::<WideHalo>::default,
            |halo, (b, ((block, ahead), out))| {
                halo.gather(grid_ref, block);
                for offset in block.active_offsets() {
                    let l = offset_coords(offset);
                    let (back, _, _) = interpolate(halo, ahead[offset]);
                    let f = halo.at(l.x, l.y, l.z) + 0.5 * (before[b][offset] - back);
                    out[offset] = f.clamp(low[b][offset], high[b][offset]);
                }
            },
        );
    store(grid, out);
}

fn store<P: Potential>(grid: &mut SparseGrid<P>, values: &[[f32; BLOCK_NODES]]) {
    grid.blocks_mut()
        .par_iter_mut()
        .zip(values.par_iter())
        .for_each(|(block, values)| {
            for (v, &f) in block.values.iter_mut().zip(values.iter()) {
                *v = P::from_f32(f.clamp(-1.0, 1.0));
            }
        });
}
