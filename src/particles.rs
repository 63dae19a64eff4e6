//! Particle frames (paper §6.1): positions and, when the simulator wrote them, radii,
//! velocities and ids. Read from files by [`crate::io::particles`].

use glam::Vec3;

pub mod motion;
pub mod splash;

/// One frame of particles.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Particles {
    /// World units.
    pub positions: Vec<Vec3>,
    /// Per-particle radius, when the file has one.
    pub radii: Option<Vec<f32>>,
    /// Per-particle velocity (PLY `vx vy vz` or `velocity_x velocity_y velocity_z`), in
    /// the file's units, when it has one.
    pub velocities: Option<Vec<Vec3>>,
    /// Per-particle identifier (PLY `id`, as SPlisHSPlasH and partio write it), when the
    /// file has one: the same particle keeps it from frame to frame.
    pub ids: Option<Vec<i64>>,
    /// Every other per-particle quantity the file holds (temperature, age, density, a
    /// foam flag, vorticity), under its own name, for `particles --attribute`.
    pub attributes: Vec<Attribute>,
}

/// A per-particle quantity a simulator wrote, carried onto the surface by name.
#[derive(Debug, Clone, PartialEq)]
pub struct Attribute {
    /// Its name in the file (and on the mesh written).
    pub name: String,
    /// 1 for a scalar, 3 for a vector, as the file holds it.
    pub components: usize,
    /// `components` values a particle, in the particles' order.
    pub values: Vec<f32>,
}

/// A particle no frame can hold, as [`Particles::check`] finds it: the field and the
/// particle's index.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum InvalidParticle {
    #[error("particle {0} has a NaN or infinite coordinate")]
    Position(usize),
    #[error("particle {0} has a velocity that is not finite")]
    Velocity(usize),
    #[error("particle {0} has a radius that is not a positive number")]
    Radius(usize),
}

impl InvalidParticle {
    /// The field it is in: `positions`, `velocities` or `radii`.
    pub fn field(&self) -> &'static str {
        match self {
            InvalidParticle::Position(_) => "positions",
            InvalidParticle::Velocity(_) => "velocities",
            InvalidParticle::Radius(_) => "radii",
        }
    }
}

impl Particles {
    /// Every position and velocity finite, every radius finite and positive: what a
    /// frame must hold, whether read from a file or handed over (the command and the
    /// Python API refuse alike).
    pub fn check(&self) -> Result<(), InvalidParticle> {
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(InvalidParticle::Position(i));
        }
        if let Some(v) = &self.velocities {
            if let Some(i) = v.iter().position(|v| !v.is_finite()) {
                return Err(InvalidParticle::Velocity(i));
            }
        }
        if let Some(radii) = &self.radii {
            if let Some(i) = radii.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
                return Err(InvalidParticle::Radius(i));
            }
        }
        Ok(())
    }

    /// Whether every particle lies within `reach` of the origin on each axis.
    pub fn within(&self, reach: f32) -> bool {
        self.positions
            .iter()
            .all(|p| p.abs().max_element() <= reach)
    }

    /// Leaves out the particles with a coordinate beyond `reach` of the origin, with their
    /// radii, velocities and ids; returns how many.
    pub fn keep_within(&mut self, reach: f32) -> usize {
        if self.within(reach) {
            return 0;
        }
        let inside = |p: &Vec3| p.abs().max_element() <= reach;
        let keep: Vec<bool> = self.positions.iter().map(inside).collect();
        fn filter<T>(values: &mut Vec<T>, keep: &[bool]) {
            let mut k = keep.iter();
            values.retain(|_| *k.next().unwrap_or(&true));
        }
        let before = self.positions.len();
        filter(&mut self.positions, &keep);
        if let Some(r) = &mut self.radii {
            filter(r, &keep);
        }
        if let Some(v) = &mut self.velocities {
            filter(v, &keep);
        }
        if let Some(ids) = &mut self.ids {
            filter(ids, &keep);
        }
        for a in &mut self.attributes {
            let mut kept = Vec::with_capacity(a.values.len());
            for (row, &k) in a.values.chunks_exact(a.components).zip(&keep) {
                if k {
                    kept.extend_from_slice(row);
                }
            }
            a.values = kept;
        }
        before - self.positions.len()
    }
}
