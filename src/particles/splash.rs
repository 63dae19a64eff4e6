//! A drop falling on a floor and splashing: a small, deterministic particle animation for
//! the sample data and the demo (not a fluid solver). Each sub-step applies gravity,
//! pushes apart particles closer than their spacing (a position-based pressure, one
//! Jacobi pass over a hashed cell grid), and bounces them off the floor with a sideways
//! kick that throws a crown outward.

use glam::{IVec3, Vec3};
use hashbrown::HashMap;

/// Particle spacing and radius, world units.
pub const SPACING: f32 = 0.04;
/// Height of the floor.
pub const FLOOR: f32 = 1.0;
const DROP_RADIUS: f32 = 0.2;
const GRAVITY: f32 = 3.0;
const SUBSTEPS: usize = 8;

pub struct Splash {
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    /// Seconds simulated.
    time: f32,
}

impl Default for Splash {
    fn default() -> Self {
        Self::new()
    }
}

impl Splash {
    /// A ball of particles on a lattice (about 500), its bottom 0.4 above the floor,
    /// falling at 1 unit/s, around x = z = 1.5.
    pub fn new() -> Self {
        let n = (DROP_RADIUS / SPACING).ceil() as i32;
        let centre = Vec3::new(1.5, FLOOR + 0.3 + DROP_RADIUS, 1.5);
        let positions: Vec<Vec3> = (-n..=n)
            .flat_map(|x| (-n..=n).flat_map(move |y| (-n..=n).map(move |z| IVec3::new(x, y, z))))
            .map(|c| c.as_vec3() * SPACING)
            .filter(|p| p.length() <= DROP_RADIUS)
            .map(|p| centre + p)
            .collect();
        let velocities = vec![Vec3::new(0.0, -0.5, 0.0); positions.len()];
        Splash {
            positions,
            velocities,
            time: 0.0,
        }
    }

    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    pub fn time(&self) -> f32 {
        self.time
    }

    /// Advances by `duration` seconds.
    pub fn advance(&mut self, duration: f32) {
        let dt = duration / SUBSTEPS as f32;
        for _ in 0..SUBSTEPS {
            self.substep(dt);
        }
        self.time += duration;
    }

    fn substep(&mut self, dt: f32) {
        let before = self.positions.clone();
        for (p, v) in self.positions.iter_mut().zip(&mut self.velocities) {
            v.y -= GRAVITY * dt;
            *p += *v * dt;
        }
        self.separate();
        for (p, v) in self.positions.iter_mut().zip(&mut self.velocities) {
            let low = FLOOR + 0.5 * SPACING;
            if p.y < low {
                // Bounce a little, and turn part of the impact outward from the drop's
                // axis: the crown.
                let impact = -v.y.min(0.0);
                let out = Vec3::new(p.x - 1.5, 0.0, p.z - 1.5).normalize_or_zero();
                p.y = low;
                v.y = 0.25 * impact;
                *v += out * (0.6 * impact);
                v.x *= 0.95;
                v.z *= 0.95;
            }
        }
        // Velocities follow what the pressure pass did to the positions.
        for ((p, v), b) in self.positions.iter().zip(&mut self.velocities).zip(&before) {
            *v = 0.5 * (*v + (*p - *b) / dt);
        }
    }

    /// One Jacobi pass moving apart the pairs closer than `SPACING`, half the overlap
    /// each.
    fn separate(&mut self) {
        let key = |p: Vec3| (p / SPACING).floor().as_ivec3();
        let mut cells: HashMap<IVec3, Vec<u32>> = HashMap::new();
        for (i, &p) in self.positions.iter().enumerate() {
            cells.entry(key(p)).or_default().push(i as u32);
        }
        let moved: Vec<Vec3> = self
            .positions
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                let c = key(p);
                let mut push = Vec3::ZERO;
                for d in 0..27 {
                    let n = c + IVec3::new(d / 9 - 1, (d / 3) % 3 - 1, d % 3 - 1);
                    for &j in cells.get(&n).map_or(&[][..], Vec::as_slice) {
                        let q = self.positions[j as usize];
                        let gap = p.distance(q);
                        if j as usize != i && gap < SPACING && gap > 1e-6 {
                            push += (p - q) / gap * (0.5 * (SPACING - gap));
                        }
                    }
                }
                p + push
            })
            .collect();
        self.positions = moved;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_drop_falls_lands_and_spreads() {
        let mut splash = Splash::new();
        let n = splash.positions().len();
        assert!((400..700).contains(&n), "{n} particles");
        let spread = |s: &Splash| {
            s.positions()
                .iter()
                .map(|p| Vec3::new(p.x - 1.5, 0.0, p.z - 1.5).length())
                .fold(0.0f32, f32::max)
        };
        let lowest = |s: &Splash| s.positions().iter().map(|p| p.y).fold(f32::MAX, f32::min);
        let before = spread(&splash);
        for _ in 0..30 {
            splash.advance(1.0 / 24.0);
            assert!(splash.positions().iter().all(|p| p.is_finite()));
            assert!(lowest(&splash) >= FLOOR, "through the floor");
        }
        // It has landed and spread to several times its width.
        assert!(lowest(&splash) < FLOOR + SPACING);
        assert!(
            spread(&splash) > 2.5 * before,
            "{} vs {before}",
            spread(&splash)
        );
    }
}
