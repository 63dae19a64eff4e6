//! What the skin is attracted to (paper §3.4): VDB level sets and fog volumes, analytic
//! shapes, skeleton blobs, and unions of them.

mod backtracked;
mod collider;
mod mesh_shape;
mod particles;
pub mod sample;
mod shapes;
mod vdb;

use glam::Vec3;

use crate::grid::Aabb;

pub use backtracked::Backtracked;
pub use collider::{liquid_origin, meet_collider, ColliderGrid};
pub use mesh_shape::{MeshShape, OpenMesh};
pub use particles::{
    fluid_iso, iso_for_radius, kernel, rest_density, Density, DensityGrid,
    DEFAULT_SMOOTHING_LENGTH, MAX_SMOOTHING_LENGTH, SPRAY_LINK, SPRAY_MOST, VELOCITY_SUPPORT_RADII,
};
pub use shapes::{Blobs, BoxShape, Skeleton, Sphere, Torus, Union};
pub use vdb::{FogTarget, LevelSetTarget};

/// The gradient of `target`'s distance at `p`, by central differences of step `h`.
pub fn gradient(target: &dyn Target, p: Vec3, h: f32) -> Vec3 {
    let d = |e: Vec3| target.distance(p + e * h) - target.distance(p - e * h);
    Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z)) / (2.0 * h)
}

/// A target surface. `distance` is signed, negative inside, in world units: exact for
/// level sets and analytic shapes; for density fields, (iso − G)/|∇G|, the first-order
/// distance to the iso-surface, so that α is a rate (1/s) whatever the target.
pub trait Target: Sync + Send {
    fn distance(&self, p: Vec3) -> f32;
    /// Whether `p` is inside: `distance(p) < 0`, sooner where that is cheaper to know.
    fn inside(&self, p: Vec3) -> bool {
        self.distance(p) < 0.0
    }
    /// [`Target::inside`] at each node of one block, the node at offset `o` (OpenVDB's
    /// leaf order) at `corner + dx·offset_coords(o)`; node by node unless a target knows
    /// better (a grid sharing the nodes reads them without interpolating).
    fn block_inside(&self, corner: Vec3, dx: f32, out: &mut [bool; crate::grid::BLOCK_NODES]) {
        for (o, inside) in out.iter_mut().enumerate() {
            *inside = self.inside(corner + crate::grid::offset_coords(o).as_vec3() * dx);
        }
    }
    /// A box holding the whole inside of the target.
    fn bounds(&self) -> Aabb;
    /// False only when no point of `region` is inside the target, so that a seed can skip
    /// it without sampling it.
    fn may_be_inside(&self, _region: Aabb) -> bool {
        true
    }
    /// Boxes that together hold the target's whole inside and surface: by default its
    /// bounds. Sparse targets (particles, level sets of separate parts) list their own
    /// pieces, so that a start or a seed costs what the target holds, not its bounding box
    /// (two drops 20 m apart are two drops, not 8 000 m³).
    fn parts(&self) -> Vec<Aabb> {
        vec![self.bounds()]
    }
    /// Boxes that together hold the target's surface: by default its parts. A collider
    /// is met only near its surface ([`meet_collider`]); a closed mesh lists the cells
    /// its triangles pass through, not its whole inside.
    fn surface_parts(&self) -> Vec<Aabb> {
        self.parts()
    }
    /// The volume it encloses, world units, where that is cheap to know (a level set's
    /// voxels): a frame carried by a velocity follows its change ([`crate::skin::Skin::carry_in_flow`]).
    fn volume(&self) -> Option<f64> {
        None
    }
}

impl<T: Target + ?Sized> Target for &T {
    fn distance(&self, p: Vec3) -> f32 {
        (**self).distance(p)
    }
    fn inside(&self, p: Vec3) -> bool {
        (**self).inside(p)
    }
    fn block_inside(&self, corner: Vec3, dx: f32, out: &mut [bool; crate::grid::BLOCK_NODES]) {
        (**self).block_inside(corner, dx, out)
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn may_be_inside(&self, region: Aabb) -> bool {
        (**self).may_be_inside(region)
    }
    fn parts(&self) -> Vec<Aabb> {
        (**self).parts()
    }
    fn surface_parts(&self) -> Vec<Aabb> {
        (**self).surface_parts()
    }
    fn volume(&self) -> Option<f64> {
        (**self).volume()
    }
}

impl<T: Target + ?Sized + Send> Target for std::sync::Arc<T> {
    fn distance(&self, p: Vec3) -> f32 {
        (**self).distance(p)
    }
    fn inside(&self, p: Vec3) -> bool {
        (**self).inside(p)
    }
    fn block_inside(&self, corner: Vec3, dx: f32, out: &mut [bool; crate::grid::BLOCK_NODES]) {
        (**self).block_inside(corner, dx, out)
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn may_be_inside(&self, region: Aabb) -> bool {
        (**self).may_be_inside(region)
    }
    fn parts(&self) -> Vec<Aabb> {
        (**self).parts()
    }
    fn surface_parts(&self) -> Vec<Aabb> {
        (**self).surface_parts()
    }
    fn volume(&self) -> Option<f64> {
        (**self).volume()
    }
}

impl<T: Target + ?Sized> Target for Box<T> {
    fn distance(&self, p: Vec3) -> f32 {
        (**self).distance(p)
    }
    fn inside(&self, p: Vec3) -> bool {
        (**self).inside(p)
    }
    fn block_inside(&self, corner: Vec3, dx: f32, out: &mut [bool; crate::grid::BLOCK_NODES]) {
        (**self).block_inside(corner, dx, out)
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn may_be_inside(&self, region: Aabb) -> bool {
        (**self).may_be_inside(region)
    }
    fn parts(&self) -> Vec<Aabb> {
        (**self).parts()
    }
    fn surface_parts(&self) -> Vec<Aabb> {
        (**self).surface_parts()
    }
    fn volume(&self) -> Option<f64> {
        (**self).volume()
    }
}

/// First-order distance to the iso-surface `g = iso` of a density `g` (larger inside):
/// (iso − g(p)) / |∇g(p)|, with a central-difference gradient of step `h`.
pub(crate) fn density_distance(g: impl Fn(Vec3) -> f32, iso: f32, p: Vec3, h: f32) -> f32 {
    let grad = Vec3::new(
        g(p + Vec3::X * h) - g(p - Vec3::X * h),
        g(p + Vec3::Y * h) - g(p - Vec3::Y * h),
        g(p + Vec3::Z * h) - g(p - Vec3::Z * h),
    ) / (2.0 * h);
    let value = iso - g(p);
    // Far from the surface the gradient fades; cap the estimate instead of dividing by ~0.
    let norm = grad.length().max(value.abs() * 0.25).max(1e-6);
    value / norm
}
