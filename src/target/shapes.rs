//! Analytic targets: sphere, torus, box, skeleton blobs (Figs. 6 and 7), union.

use super::{density_distance, Target};

use crate::grid::Aabb;
use glam::Vec3;

#[derive(Debug, Clone, Copy)]
pub struct Sphere {
    /// World units.
    pub center: Vec3,
    /// World units.
    pub radius: f32,
}

impl Target for Sphere {
    fn distance(&self, p: Vec3) -> f32 {
        (p - self.center).length() - self.radius
    }
    fn bounds(&self) -> Aabb {
        Aabb {
            min: self.center - Vec3::splat(self.radius),
            max: self.center + Vec3::splat(self.radius),
        }
    }
}

/// A torus around the z axis through `center`.
#[derive(Debug, Clone, Copy)]
pub struct Torus {
    /// World units.
    pub center: Vec3,
    /// Distance from the axis to the centre of the tube.
    pub major: f32,
    /// Radius of the tube.
    pub minor: f32,
}

impl Target for Torus {
    fn distance(&self, p: Vec3) -> f32 {
        let q = p - self.center;
        let ring = (q.x * q.x + q.y * q.y).sqrt() - self.major;
        (ring * ring + q.z * q.z).sqrt() - self.minor
    }
    fn bounds(&self) -> Aabb {
        let r = self.major + self.minor;
        Aabb {
            min: self.center - Vec3::new(r, r, self.minor),
            max: self.center + Vec3::new(r, r, self.minor),
        }
    }
}

#[derive(Debug, Clone, Copy)]
pub struct BoxShape {
    /// World units.
    pub center: Vec3,
    /// Half its extent along each axis.
    pub half_size: Vec3,
}

impl Target for BoxShape {
    fn distance(&self, p: Vec3) -> f32 {
        let q = (p - self.center).abs() - self.half_size;
        q.max(Vec3::ZERO).length() + q.x.max(q.y).max(q.z).min(0.0)
    }
    fn bounds(&self) -> Aabb {
        Aabb {
            min: self.center - self.half_size,
            max: self.center + self.half_size,
        }
    }
}

/// A skeleton element of a blob: its field depends on the distance to a point or segment.
#[derive(Debug, Clone, Copy)]
pub enum Skeleton {
    Point { at: Vec3, radius: f32 },
    Segment { a: Vec3, b: Vec3, radius: f32 },
}

impl Skeleton {
    fn distance(&self, p: Vec3) -> f32 {
        match *self {
            Skeleton::Point { at, .. } => (p - at).length(),
            Skeleton::Segment { a, b, .. } => {
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                (p - (a + t * ab)).length()
            }
        }
    }

    fn radius(&self) -> f32 {
        match *self {
            Skeleton::Point { radius, .. } | Skeleton::Segment { radius, .. } => radius,
        }
    }

    /// Wyvill's compact kernel (1 − (d/R)²)³: smooth, zero beyond R.
    fn field(&self, p: Vec3) -> f32 {
        let t = self.distance(p) / self.radius();
        if t >= 1.0 {
            0.0
        } else {
            let s = 1.0 - t * t;
            s * s * s
        }
    }

    fn bounds(&self) -> Aabb {
        let r = Vec3::splat(self.radius());
        match *self {
            Skeleton::Point { at, .. } => Aabb {
                min: at - r,
                max: at + r,
            },
            Skeleton::Segment { a, b, .. } => Aabb {
                min: a.min(b) - r,
                max: a.max(b) + r,
            },
        }
    }
}

/// An implicit surface G = Σ kernels = iso around point and segment skeletons.
#[derive(Debug, Clone)]
pub struct Blobs {
    /// The points and segments the kernels surround.
    pub skeletons: Vec<Skeleton>,
    /// The field's value on the surface.
    pub iso: f32,
}

impl Blobs {
    pub fn density(&self, p: Vec3) -> f32 {
        self.skeletons.iter().map(|s| s.field(p)).sum()
    }

    /// Fig. 7's source: six point skeletons on a hexagon, blended into one body.
    pub fn fig7_points() -> Blobs {
        let skeletons = (0..6)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 6.0;
                Skeleton::Point {
                    at: Vec3::new(0.3 * a.cos(), 0.3 * a.sin(), 0.0),
                    radius: 0.5,
                }
            })
            .collect();
        Blobs {
            skeletons,
            iso: 0.5,
        }
    }

    /// Fig. 6's source: a chain of segments twisted into one turn of a helix.
    pub fn fig6_twisted_segment() -> Blobs {
        let n = 8;
        let point = |i: usize| {
            let t = i as f32 / n as f32;
            let a = t * std::f32::consts::TAU;
            Vec3::new(0.3 * a.cos(), 0.3 * a.sin(), 1.2 * t - 0.6)
        };
        let skeletons = (0..n)
            .map(|i| Skeleton::Segment {
                a: point(i),
                b: point(i + 1),
                radius: 0.3,
            })
            .collect();
        Blobs {
            skeletons,
            iso: 0.4,
        }
    }
}

impl Target for Blobs {
    fn distance(&self, p: Vec3) -> f32 {
        let far = self.bounds();
        if p.cmplt(far.min).any() || p.cmpgt(far.max).any() {
            // No field out here: distance to the box is a safe lower bound.
            let q = (far.min - p).max(p - far.max).max(Vec3::ZERO);
            return q.length().max(1e-3);
        }
        density_distance(|q| self.density(q), self.iso, p, 1e-3)
    }
    fn bounds(&self) -> Aabb {
        let mut b = self.skeletons[0].bounds();
        for s in &self.skeletons[1..] {
            b = b.union(s.bounds());
        }
        b
    }
}

/// The union of targets: inside any of them.
pub struct Union(pub Vec<Box<dyn Target>>);

impl Union {
    /// Fig. 7's target: a pair of spheres.
    pub fn fig7_spheres() -> Union {
        Union(vec![
            Box::new(Sphere {
                center: Vec3::new(-0.5, 0.0, 0.0),
                radius: 0.3,
            }),
            Box::new(Sphere {
                center: Vec3::new(0.5, 0.0, 0.0),
                radius: 0.3,
            }),
        ])
    }
}

impl Target for Union {
    fn distance(&self, p: Vec3) -> f32 {
        self.0
            .iter()
            .map(|t| t.distance(p))
            .fold(f32::INFINITY, f32::min)
    }
    fn bounds(&self) -> Aabb {
        let mut b = self.0[0].bounds();
        for t in &self.0[1..] {
            b = b.union(t.bounds());
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_are_signed() {
        let torus = Torus {
            center: Vec3::ZERO,
            major: 0.6,
            minor: 0.25,
        };
        assert!((torus.distance(Vec3::new(0.6, 0.0, 0.0)) + 0.25).abs() < 1e-6);
        assert!((torus.distance(Vec3::ZERO) - 0.35).abs() < 1e-6);
        let b = BoxShape {
            center: Vec3::ZERO,
            half_size: Vec3::splat(0.5),
        };
        assert!((b.distance(Vec3::new(1.0, 0.0, 0.0)) - 0.5).abs() < 1e-6);
        assert!((b.distance(Vec3::ZERO) + 0.5).abs() < 1e-6);
    }

    #[test]
    fn blob_distance_is_first_order_accurate() {
        // One point blob: the iso-surface is a sphere of known radius.
        let blob = Blobs {
            skeletons: vec![Skeleton::Point {
                at: Vec3::ZERO,
                radius: 1.0,
            }],
            iso: 0.125, // (1 - t²)³ = 1/8 at t² = 1/2
        };
        let r = 0.5f32.sqrt();
        for d in [-0.02f32, 0.0, 0.02] {
            let got = blob.distance(Vec3::new(r + d, 0.0, 0.0));
            assert!((got - d).abs() < 0.003, "{d}: {got}");
        }
        assert!(Blobs::fig7_points().distance(Vec3::ZERO) < 0.0);
        assert!(Union::fig7_spheres().distance(Vec3::ZERO) > 0.0);
    }
}
