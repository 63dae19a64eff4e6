//! Spray (issue 49): drops of a few particles flown off the liquid. The skin's own state
//! filters the target in time, which a drop that has just left (the skin still joined to
//! it by a neck) or has just flown in does not wait for: near spray particles the skin
//! takes the frame's target's surface, as a per-frame mesher would, and keeps its own
//! elsewhere.

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use super::Skin;
use crate::grid::{block_of, node_offset, Potential, BLOCK_DIM};
use crate::target::Target;

/// Spray particles (drops of a few flown off the liquid,
/// [`crate::target::Density::finding_spray`]): within `inner` (world units) of one, the
/// skin takes the frame's target's surface as it settles
/// ([`Skin::settle_holding`]), blending back to its own by `outer`.
#[derive(Clone, Debug, Default)]
pub struct Spray {
    /// The spray particles' positions.
    pub points: Vec<Vec3>,
    /// How near a spray particle the skin is the target's surface wholly.
    pub inner: f32,
    /// How near a spray particle the target's surface weighs at all.
    pub outer: f32,
}

impl<P: Potential> Skin<P> {
    /// Within `spray.inner` of any spray particle the potential becomes `target`'s
    /// distance estimate; out to `spray.outer` it blends smoothly back to the skin's.
    /// Whether anything changed (the band's crossed cells are then stored, the mesh and
    /// the band's distance left to the caller).
    pub(super) fn take_target_near(&mut self, target: &dyn Target, spray: &Spray) -> bool {
        let reach = (spray.inner, spray.outer);
        self.take_target_around(target, &spray.points, None, reach, false)
    }

    /// Within `inner` of any of `points` the potential becomes `target`'s distance
    /// estimate (only where that lies farther out when `outward_only`); out to `outer` it
    /// blends smoothly back to the skin's; each point's weight scaled by its share when
    /// `shares` are given. Whether anything changed (the band's crossed cells are then
    /// stored, the mesh and the band's distance left to the caller).
    pub(super) fn take_target_around(
        &mut self,
        target: &dyn Target,
        points: &[Vec3],
        shares: Option<&[f32]>,
        (inner, outer): (f32, f32),
        outward_only: bool,
    ) -> bool {
        if points.is_empty() {
            return false;
        }
        let (dx, w) = (self.params.dx, self.params.band_width);
        let xf = self.xf;
        let reach = (outer / dx).ceil() as i32;
        let blend = (outer - inner).max(f32::MIN_POSITIVE);
        // Each node's weight (the greatest any point gives it) and the target's
        // distance there, in parallel; the same whatever the threads.
        let mut nodes: Vec<(IVec3, f32)> = points
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, &p)| {
                let share = shares.map_or(1.0, |s| s[i]);
                let c = ((p - xf.origin) / dx).round().as_ivec3();
                let side = 2 * reach + 1;
                (0..side * side * side).filter_map(move |n| {
                    let e = IVec3::new(n / (side * side), n / side % side, n % side);
                    let ijk = c + e - IVec3::splat(reach);
                    let d = (xf.apply(ijk.as_vec3()) - p).length();
                    let t = ((outer - d) / blend).clamp(0.0, 1.0);
                    (t > 0.0).then_some((ijk, share * t * t * (3.0 - 2.0 * t)))
                })
            })
            .collect();
        nodes.par_sort_unstable_by(|(a, s), (b, t)| {
            a.to_array().cmp(&b.to_array()).then(t.total_cmp(s))
        });
        nodes.dedup_by_key(|(ijk, _)| *ijk);
        let goals: Vec<f32> = nodes
            .par_iter()
            .map(|&(ijk, _)| {
                let d = target.distance(xf.apply(ijk.as_vec3()));
                (d / (w * dx)).clamp(-1.0, 1.0)
            })
            .collect();
        let mut changed = Vec::new();
        for ((ijk, t), goal) in nodes.into_iter().zip(goals) {
            let coord = block_of(ijk);
            let local = ijk - coord * BLOCK_DIM;
            let id = self.grid.touch(coord);
            let v = &mut self.grid.blocks_mut()[id.0 as usize].values
                [node_offset(local.x, local.y, local.z)];
            let f = v.to_f32();
            // Outward is down: the potential is negative inside.
            let toward = match outward_only {
                true => (goal - f).min(0.0),
                false => goal - f,
            };
            let new = f + t * toward;
            if new != f {
                *v = P::from_f32(new);
                // Sorted by node, a block's nodes mostly follow one another; repeats are
                // harmless (a set is made of them).
                if changed.last() != Some(&coord) {
                    changed.push(coord);
                }
            }
        }
        if changed.is_empty() {
            return false;
        }
        self.store_crossed_cells(&changed);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skin::SkinParams;
    use crate::target::{Sphere, Union};

    /// A skin on a ball, told that a drop 3 voxels off it is spray: within the inner
    /// reach it holds the target's distance (the drop whole, apart), past the outer
    /// reach what it held.
    #[test]
    fn near_spray_the_skin_is_the_target_elsewhere_its_own() {
        let dx = 0.1;
        let ball = Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        };
        let drop = Sphere {
            center: Vec3::new(1.5, 0.013, 0.021),
            radius: 0.2,
        };
        let mut skin: Skin<f32> = Skin::new(
            &ball,
            SkinParams {
                dx,
                ..SkinParams::default()
            },
        );
        let before: Vec<(IVec3, f32)> = (-14..=14)
            .flat_map(|x| (-14..=14).map(move |y| IVec3::new(x, y, 0)))
            .map(|ijk| (ijk, skin.grid.value(ijk)))
            .collect();
        let target = Union(vec![Box::new(ball), Box::new(drop)]);
        let spray = Spray {
            points: vec![drop.center],
            inner: 0.3,
            outer: 0.45,
        };
        assert!(skin.take_target_near(&target, &spray));
        skin.polygonize();
        assert_eq!(skin.mesh.components(), 2);
        let w = skin.params.band_width * dx;
        for (ijk, was) in before {
            let p = skin.xf.apply(ijk.as_vec3());
            let now = skin.grid.value(ijk);
            let d = p.distance(drop.center);
            if d <= spray.inner {
                let goal = (target.distance(p) / w).clamp(-1.0, 1.0);
                assert!((now - goal).abs() < 1e-6, "{ijk}: {now} against {goal}");
            } else if d >= spray.outer {
                assert_eq!(now, was, "{ijk}");
            }
        }
        // No spray, nothing taken.
        let none = Spray::default();
        assert!(!skin.take_target_near(&target, &none));
    }
}
