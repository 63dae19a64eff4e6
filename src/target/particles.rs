//! The density of a particle frame as a target (paper §6.1):
//! `G(X) = Σ W(|X − p_i| / h)` with the compact kernel `W(q) = (1 − q²)³` for q < 1,
//! neighbours found through a hashed grid of cells of side h.

use glam::{IVec3, Vec3};
use hashbrown::HashMap;

use super::{density_distance, Aabb, Target};

/// The kernel, 1 at the particle and 0 from distance h on, smooth at both ends.
#[inline]
pub fn kernel(q: f32) -> f32 {
    if q >= 1.0 {
        0.0
    } else {
        let s = 1.0 - q * q;
        s * s * s
    }
}

/// The iso value that puts the surface of a lone particle at `radius` with support `h`.
pub fn iso_for_radius(radius: f32, h: f32) -> f32 {
    kernel(radius / h)
}

pub struct Density {
    positions: Vec<Vec3>,
    cells: HashMap<IVec3, Vec<u32>>,
    h: f32,
    iso: f32,
    bounds: Aabb,
}

impl Density {
    /// `h`: the kernel's support (world units); `iso`: the density of the surface.
    pub fn new(positions: Vec<Vec3>, h: f32, iso: f32) -> Self {
        let mut cells: HashMap<IVec3, Vec<u32>> = HashMap::new();
        let mut bounds = Aabb {
            min: Vec3::INFINITY,
            max: Vec3::NEG_INFINITY,
        };
        for (i, &p) in positions.iter().enumerate() {
            cells
                .entry((p / h).floor().as_ivec3())
                .or_default()
                .push(i as u32);
            bounds.min = bounds.min.min(p);
            bounds.max = bounds.max.max(p);
        }
        Density {
            positions,
            cells,
            h,
            iso,
            bounds: bounds.padded(h),
        }
    }

    /// G at `p`.
    pub fn density(&self, p: Vec3) -> f32 {
        let cell = (p / self.h).floor().as_ivec3();
        let mut g = 0.0;
        for n in 0..27 {
            let d = IVec3::new(n / 9 - 1, (n / 3) % 3 - 1, n % 3 - 1);
            if let Some(list) = self.cells.get(&(cell + d)) {
                for &i in list {
                    g += kernel(p.distance(self.positions[i as usize]) / self.h);
                }
            }
        }
        g
    }
}

impl Target for Density {
    /// First-order distance to the iso-density surface, (iso − G)/|∇G|, capped at h where
    /// the density fades.
    fn distance(&self, p: Vec3) -> f32 {
        let d = density_distance(|q| self.density(q), self.iso, p, 0.05 * self.h);
        d.clamp(-self.h, self.h)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
}
