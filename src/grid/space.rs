//! Where the grid is in the world: its nodes' positions and world-space boxes.

use glam::Vec3;

/// An axis-aligned box in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The lowest corner.
    pub min: Vec3,
    /// The highest corner.
    pub max: Vec3,
}

impl Aabb {
    pub fn union(self, other: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    pub fn padded(self, by: f32) -> Aabb {
        Aabb {
            min: self.min - Vec3::splat(by),
            max: self.max + Vec3::splat(by),
        }
    }
}

/// Index space → world space.
#[derive(Debug, Clone, Copy)]
pub struct IndexToWorld {
    /// Where node (0, 0, 0) lies, world units.
    pub origin: Vec3,
    /// The voxel size, world units.
    pub dx: f32,
}

impl IndexToWorld {
    #[inline]
    pub fn apply(&self, ijk: Vec3) -> Vec3 {
        self.origin + ijk * self.dx
    }
}
