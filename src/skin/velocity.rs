//! The surface's velocity at a frame, for motion blur: a liquid's surface changes its
//! vertices every frame, so renderers blur it by a velocity per vertex (Houdini's `v`,
//! USD's `velocities`), which must carry each point of this frame's surface onto the next.
//!
//! A point of the skin moves with the material around it plus the skin's own motion
//! across the material (the attraction correcting the carried shape, a target growing or
//! thinning): `v = u + s·n`, `u` the material's velocity over a frame, `s` the skin's
//! normal speed relative to it. `s` is measured over the frame that ended here: the
//! material now at `x` was at `y` a frame before; had the skin moved with it, `y` would lie
//! on the frame before's surface at the level `x` has now, so `(φ₋₁(y) − φₓ)/Δt` is
//! how far the skin went past the material, per second, along its normal.

use glam::Vec3;
use rayon::prelude::*;

use crate::flow::{Flow, FlowMap, Traced};
use crate::grid::Aabb;
use crate::target::Target;

/// What is known of the material's motion at a frame.
#[derive(Clone, Copy)]
pub enum Motion<'a> {
    /// Where the material was a frame before (particles matched from frame to frame,
    /// [`FlowMap`]): its secant velocity over that frame, the one a blur of the frame
    /// before to this one would use and, for a steady motion, the next.
    Map(&'a dyn FlowMap),
    /// The material's velocity at this frame (a cache's `vel`, an analytic flow): traced
    /// a frame ahead for `u` (a spin's secant, not its tangent, lands on the next frame's
    /// shape) and a frame back for where the material came from.
    Flow(&'a dyn Flow),
    /// Nothing: the skin's motion is its own (a target followed by attraction alone).
    Still,
}

/// What [`surface_velocities`] needs besides the points: the material's motion, the skin
/// a frame before (a signed distance, trusted up to its reach), the frame's duration
/// and the voxel. Kept by the frame loop for every output that asks.
#[derive(Clone, Copy)]
pub struct SurfaceMotion<'a> {
    /// The material's motion over the frame.
    pub motion: Motion<'a>,
    /// The skin a frame before, and how far its distance is trusted (world units).
    pub before: Option<(&'a dyn Target, f32)>,
    /// The frame's length, seconds.
    pub duration: f32,
    /// The voxel size, world units.
    pub dx: f32,
}

impl SurfaceMotion<'_> {
    /// [`surface_velocities`] at `points`.
    pub fn at(&self, points: &[Vec3], normals: &[Vec3], levels: Option<&[f32]>) -> Vec<Vec3> {
        surface_velocities(
            points,
            normals,
            levels,
            self.motion,
            self.before,
            self.duration,
            self.dx,
        )
    }
}

/// The velocity (world units per second) of the surface through `points`, each with the
/// skin's unit outward `normals` there and its level (`levels[i]`, world units: zero on
/// the surface, a node's signed distance off it), given the material's `motion` and the
/// skin a frame (`duration` seconds) before as a signed distance, trusted up to its
/// `reach` (its band: beyond it a level set reads only "far"); without it the material's
/// velocity alone. `dx` is the voxel: a trace steps at most that far.
pub fn surface_velocities(
    points: &[Vec3],
    normals: &[Vec3],
    levels: Option<&[f32]>,
    motion: Motion<'_>,
    before: Option<(&dyn Target, f32)>,
    duration: f32,
    dx: f32,
) -> Vec<Vec3> {
    let bounds = Aabb {
        min: Vec3::splat(f32::MIN),
        max: Vec3::splat(f32::MAX),
    };
    points
        .par_iter()
        .zip(normals.par_iter())
        .enumerate()
        .map(|(i, (&x, &n))| {
            let (u, from) = match motion {
                Motion::Map(map) => match map.departure(x, duration) {
                    Some(y) => ((x - y) / duration, y),
                    None => (Vec3::ZERO, x),
                },
                Motion::Flow(flow) => {
                    let traced = Traced {
                        flow,
                        bounds,
                        step: dx,
                    };
                    let ahead = traced.departure(x, -duration).unwrap_or(x);
                    let back = traced.departure(x, duration).unwrap_or(x);
                    ((ahead - x) / duration, back)
                }
                Motion::Still => (Vec3::ZERO, x),
            };
            let Some((before, reach)) = before else {
                return u;
            };
            let level = levels.map_or(0.0, |l| l[i]);
            let then = before.distance(from);
            // Past the band the frame before says only "far": no correction known.
            if !then.is_finite() || then.abs() >= reach {
                return u;
            }
            u + n * ((then - level) / duration)
        })
        .collect()
}
