//! The velocity's units, measured from the data: between two frames the surface moves by
//! what the velocity says, so `φ_n − φ_{n+1} ≈ k·Δt·u·∇φ_n/|∇φ_n|` near the surface, and
//! the least-squares k over those points is the factor that turns the cache's velocity
//! into world units per second (Houdini writes scene units per second, Mantaflow its own
//! grid units, other tools voxels per frame).

use glam::Vec3;

use super::Flow;
use crate::target::Target;

/// The fit of one frame pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleFit {
    /// The factor k: world distance moved per (velocity unit × second).
    pub scale: f64,
    /// Coefficient of determination of the fit through the origin.
    pub r2: f64,
    /// Points used.
    pub samples: usize,
}

impl ScaleFit {
    /// Good enough to trust: the velocity explains most of the surface's motion.
    pub fn is_good(&self) -> bool {
        self.scale > 0.0 && self.r2 >= MIN_R2 && self.samples >= MIN_SAMPLES
    }
}

/// Below this share of the surface's motion explained, the velocity is not used.
pub const MIN_R2: f64 = 0.5;
/// Fewer points than this say nothing.
pub const MIN_SAMPLES: usize = 50;

/// Fits k on `points` (near the surface of `before`) between `before` and `after`, `dt`
/// seconds apart, with the velocity `flow` (in the cache's units) over that interval.
/// The normal is `before`'s gradient by central differences of step `h`; points where it
/// is flat, or where the velocity vanishes, are left out.
pub fn fit(
    before: &dyn Target,
    after: &dyn Target,
    flow: &dyn Flow,
    points: &[Vec3],
    dt: f32,
    h: f32,
) -> ScaleFit {
    let mut pairs: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    for &p in points {
        let grad = Vec3::new(
            before.distance(p + Vec3::X * h) - before.distance(p - Vec3::X * h),
            before.distance(p + Vec3::Y * h) - before.distance(p - Vec3::Y * h),
            before.distance(p + Vec3::Z * h) - before.distance(p - Vec3::Z * h),
        ) / (2.0 * h);
        let length = grad.length();
        if !(0.5..=1.5).contains(&length) {
            continue; // not a distance here (a medial axis, the band's edge)
        }
        let moved = f64::from(before.distance(p) - after.distance(p));
        let predicted = f64::from(dt * flow.velocity(p).dot(grad / length));
        if predicted != 0.0 && moved.is_finite() && predicted.is_finite() {
            pairs.push((moved, predicted));
        }
    }
    let (sab, sbb) = pairs
        .iter()
        .fold((0.0, 0.0), |(ab, bb), &(a, b)| (ab + a * b, bb + b * b));
    if pairs.is_empty() || sbb == 0.0 {
        return ScaleFit {
            scale: 0.0,
            r2: 0.0,
            samples: pairs.len(),
        };
    }
    let k = sab / sbb;
    let mean = pairs.iter().map(|p| p.0).sum::<f64>() / pairs.len() as f64;
    let (residual, total) = pairs.iter().fold((0.0, 0.0), |(r, t), &(a, b)| {
        (r + (a - k * b).powi(2), t + (a - mean).powi(2))
    });
    ScaleFit {
        scale: k,
        r2: if total > 0.0 {
            1.0 - residual / total
        } else {
            0.0
        },
        samples: pairs.len(),
    }
}

/// The median scale of the good fits, if any.
pub fn median_scale(fits: &[ScaleFit]) -> Option<f64> {
    let mut good: Vec<f64> = fits
        .iter()
        .filter(|f| f.is_good())
        .map(|f| f.scale)
        .collect();
    if good.is_empty() {
        return None;
    }
    good.sort_by(f64::total_cmp);
    Some(good[good.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flow::Rigid;
    use crate::target::{Aabb, Sphere};

    /// A sphere with bumps of `amplitude` that change between frames.
    struct Bumpy(Sphere, f32, f32);

    impl Target for Bumpy {
        fn distance(&self, p: Vec3) -> f32 {
            let n = (p - self.0.center).normalize_or_zero();
            let bumps = (5.0 * n.x + self.2).sin() * (4.0 * n.y + 2.0 * self.2).cos();
            self.0.distance(p) - self.1 * bumps
        }
        fn bounds(&self) -> Aabb {
            self.0.bounds()
        }
    }

    fn sphere_points(s: &Sphere, n: usize) -> Vec<Vec3> {
        // A Fibonacci sphere, just off the surface.
        (0..n)
            .map(|i| {
                let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                let r = (1.0 - y * y).sqrt();
                let phi = i as f32 * 2.399_963;
                s.center + Vec3::new(r * phi.cos(), y, r * phi.sin()) * (s.radius + 0.01)
            })
            .collect()
    }

    #[test]
    fn the_units_of_a_moving_sphere_come_back() {
        let dx = 1.0 / 32.0;
        let dt = 1.0 / 24.0;
        let speed = 3.0 * dx / dt; // 3 voxels a frame
        let a = Sphere {
            center: Vec3::ZERO,
            radius: 0.3,
        };
        let b = Sphere {
            center: Vec3::X * speed * dt,
            ..a
        };
        let points = sphere_points(&a, 400);
        // The cache's velocity in world units/s, voxels/s, voxels/frame and cm/s.
        for (units, per_world) in [
            ("world/s", 1.0),
            ("voxels/s", 1.0 / dx),
            ("voxels/frame", dt / dx),
            ("cm/s", 100.0),
        ] {
            let flow = Rigid {
                center: Vec3::ZERO,
                linear: Vec3::X * speed * per_world,
                angular: Vec3::ZERO,
            };
            let f = fit(&a, &b, &flow, &points, dt, 0.5 * dx);
            let expected = 1.0 / f64::from(per_world);
            assert!(f.is_good(), "{units}: {f:?}");
            assert!(
                (f.scale / expected - 1.0).abs() < 0.05,
                "{units}: {f:?} vs {expected}"
            );
            // Surface noise of a voxel, changing between frames, biases it by under 10 %.
            let (na, nb) = (Bumpy(a, dx, 0.0), Bumpy(b, dx, 1.3));
            let noisy = fit(&na, &nb, &flow, &points, dt, 0.5 * dx);
            assert!(
                (noisy.scale / expected - 1.0).abs() < 0.10,
                "{units} noisy: {noisy:?} vs {expected}"
            );
        }
        // A velocity that does not explain the motion (across it): a poor fit, not used.
        let unrelated = Rigid {
            center: Vec3::ZERO,
            linear: Vec3::Y * speed,
            angular: Vec3::ZERO,
        };
        let f = fit(&a, &b, &unrelated, &points, dt, 0.5 * dx);
        assert!(!f.is_good() && f.samples > 300, "{f:?}");
        assert_eq!(median_scale(&[f]), None);
    }
}
