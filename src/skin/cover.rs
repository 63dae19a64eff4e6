//! Particles left outside (issue 49). The smoothing rounds what it smooths, within a limit
//! inside the frame's density ([`Skin::smooth`]), and the skin's memory adds up what each
//! frame rounds: a liquid's edge that moves several voxels a frame (a collapsing column's
//! corner, a sheet's film on a wall) ended up more than a radius inside its particles.
//! So before each frame's smoothing, around every particle the skin leaves outside, it
//! takes the frame's density's surface where that lies farther out, as it does around
//! spray ([`super::Spray`]): the skin keeps its particles under it, and the smoothing
//! then evens what was taken back.

use glam::Vec3;
use rayon::prelude::*;

use super::{smoothstep, Skin};
use crate::grid::Potential;
use crate::target::Target;

/// A frame's particles, which its settled skin keeps under it ([`Skin::settle_holding`]):
/// around each whose centre the skin leaves more than `from` out (world units), the skin
/// takes the target's surface where that lies farther out, wholly within `inner` of it,
/// blending back to its own by `outer`; by a share that grows smoothly from 0 to 1 as
/// the centre lies `from` to `full` out (a particle that leaves and re-enters the cover
/// from frame to frame does not switch it on and off: the surface would flicker).
/// Empty, nothing is covered.
#[derive(Clone, Debug, Default)]
pub struct Cover {
    /// The particles' positions.
    pub points: Vec<Vec3>,
    /// How far outside the skin a particle's centre lies where its cover starts.
    pub from: f32,
    /// How far outside the skin a particle's centre lies where it is covered wholly.
    pub full: f32,
    /// How near an uncovered particle the skin is the target's surface (times the share).
    pub inner: f32,
    /// How near an uncovered particle the target's surface weighs at all.
    pub outer: f32,
}

impl<P: Potential> Skin<P> {
    /// Takes `target`'s surface, where it lies farther out than the skin, around the
    /// particles of `cover` the skin leaves outside. Whether anything changed (the mesh
    /// and the band's distance left to the caller).
    pub(super) fn cover_particles(&mut self, target: &dyn Target, cover: &Cover) -> bool {
        let (uncovered, shares) = self.outside_of(&cover.points, (cover.from, cover.full));
        let reach = (cover.inner, cover.outer);
        self.take_target_around(target, &uncovered, Some(&shares), reach, true)
    }

    /// The points farther than `from` (world units) outside the skin, by its potential's
    /// trilinear interpolation, in their order, and each one's share of the cover: from 0
    /// there to 1 at `full`, smoothly.
    fn outside_of(&self, points: &[Vec3], (from, full): (f32, f32)) -> (Vec<Vec3>, Vec<f32>) {
        let xf = self.xf;
        let scale = self.params.band_width * self.params.dx;
        points
            .par_iter()
            .filter_map(|&p| {
                let out = self.grid.trilinear((p - xf.origin) / xf.dx) * scale;
                let s = ((out - from) / (full - from)).clamp(0.0, 1.0);
                (s > 0.0).then_some((p, smoothstep(s)))
            })
            .unzip()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skin::SkinParams;
    use crate::target::{BoxShape, Sphere};

    /// A skin on a ball, its target a cube whose corners stick out of the ball, and
    /// particles in two of the cube's corners and on its faces: the corners' particles,
    /// outside the ball, end up under the skin, which bulges out to the cube there and
    /// nowhere else; the faces' particles, already inside, change nothing.
    #[test]
    fn particles_left_outside_are_covered_and_nothing_else_moves() {
        let dx = 0.05;
        let ball = Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        };
        let mut skin: Skin<f32> = Skin::new(
            &ball,
            SkinParams {
                dx,
                ..SkinParams::default()
            },
        );
        // The cube's corners 1.5 voxels outside the ball, their particles 0.8 voxel.
        let half = 0.62;
        let cube = BoxShape {
            center: Vec3::ZERO,
            half_size: Vec3::splat(half),
        };
        let corner = Vec3::splat(half - 0.02);
        let faces = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| a * (half - 0.02));
        let cover = Cover {
            points: [corner, -corner].into_iter().chain(faces).collect(),
            from: 0.25 * dx,
            full: 0.5 * dx,
            inner: 3.0 * dx,
            outer: 5.0 * dx,
        };
        let before: Vec<f32> = skin.grid.stored_values().collect();
        assert!(skin.cover_particles(&cube, &cover));
        skin.polygonize();
        let w = skin.params.band_width * dx;
        for p in &cover.points {
            let f = skin.grid.trilinear((*p - skin.xf.origin) / dx) * w;
            assert!(f < 0.0, "{p} is {f} outside");
        }
        // Away from the two corners nothing moved; near them only outward.
        let mut moved = 0;
        for (block, was) in skin.grid.blocks().iter().zip(before.chunks(512)) {
            for (offset, (&now, &was)) in block.values.iter().zip(was).enumerate() {
                let ijk = block.coord * 8 + crate::grid::offset_coords(offset);
                let at = skin.xf.apply(ijk.as_vec3());
                let near = (at - corner).length().min((at + corner).length());
                if near > cover.outer {
                    assert_eq!(now, was, "{at}");
                } else {
                    assert!(now <= was, "{at}: {was} → {now}");
                    moved += usize::from(now < was);
                }
            }
        }
        assert!(moved > 0);
        // The skin on one piece still, bulging at two corners.
        assert_eq!(skin.mesh.components(), 1);
        // Nothing outside: nothing taken.
        let inside = Cover {
            points: faces.to_vec(),
            ..cover
        };
        assert!(!skin.cover_particles(&cube, &inside));
    }
}
