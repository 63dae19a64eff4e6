//! The velocity's units, measured from the data: between two frames the surface moves by
//! what the velocity says, so `φ_n − φ_{n+1} ≈ k·Δt·u·∇φ_n/|∇φ_n|` near the surface, and
//! the least-squares k over those points is the factor that turns the cache's velocity
//! into world units per second (Houdini writes scene units per second, Mantaflow its own
//! grid units, other tools voxels per frame).

use glam::Vec3;

use crate::flow::{Flow, Timing};
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

/// How far the surface moves between frames along a normal, at most, in voxels: a
/// surface point whose counterpart lies farther says nothing.
const REACH_VOXELS: f32 = 6.0;

/// Residuals beyond this many robust standard deviations (1.4826 × the median absolute
/// residual) are left out of the second fit: surfaces that merged, split or met a wall
/// between the frames.
const OUTLIER_SIGMAS: f64 = 3.0;

/// Fits k on `points` (near the surface of `before`) between `before` and `after`, `dt`
/// seconds apart, with the velocity `flow` (in the cache's units) over that interval.
///
/// Each point is taken to the surface of `before` along its normal (`before`'s gradient
/// by central differences of step `h`); there the surface's motion is how far along that
/// normal the surface of `after` lies (the nearest zero of `after` on the line, within
/// [`REACH_VOXELS`] of `h`·2). Solver level sets are distances only near their surface
/// (Mantaflow's `phi` jumps to a constant a few voxels out, and is only roughly one
/// before that), so the motion is measured between surfaces, not read off `after`'s
/// values. Points where a normal is not a distance's, or the velocity vanishes, are left
/// out; so are outliers ([`OUTLIER_SIGMAS`]), after a first fit.
pub fn fit(
    before: &dyn Target,
    after: &dyn Target,
    flow: &dyn Flow,
    points: &[Vec3],
    dt: f32,
    h: f32,
) -> ScaleFit {
    let dx = 2.0 * h;
    let mut pairs: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    for &p in points {
        let Some(normal) = unit_gradient(before, p, h) else {
            continue;
        };
        let on_surface = p - normal * before.distance(p);
        let Some(along) = surface_along(after, on_surface, normal, h, REACH_VOXELS * dx) else {
            continue;
        };
        // Measured across the mean of both surfaces' normals: along the earlier normal
        // the line meets a surface tilted by θ (bumps that changed) 1/cos θ farther than it
        // moved, while a curved surface's tangent plane there is cos θ nearer; the half
        // angle leaves errors of order θ²/8 either way.
        let Some(later) = unit_gradient(after, on_surface + normal * along, h) else {
            continue;
        };
        let moved = along * normal.dot((normal + later).normalize_or(normal));
        let predicted = f64::from(dt * flow.velocity(on_surface).dot(normal));
        if predicted != 0.0 && predicted.is_finite() {
            pairs.push((f64::from(moved), predicted));
        }
    }
    let first = least_squares(&pairs);
    let mut residuals: Vec<f64> = pairs
        .iter()
        .map(|&(a, b)| (a - first.0 * b).abs())
        .collect();
    residuals.sort_by(f64::total_cmp);
    let Some(&median) = residuals.get(residuals.len() / 2) else {
        return ScaleFit {
            scale: 0.0,
            r2: 0.0,
            samples: 0,
        };
    };
    let bound = OUTLIER_SIGMAS * 1.4826 * median;
    pairs.retain(|&(a, b)| (a - first.0 * b).abs() <= bound);
    let (scale, r2) = least_squares(&pairs);
    ScaleFit {
        scale,
        r2,
        samples: pairs.len(),
    }
}

/// The normal of `target` at `p` by central differences of step `h`; `None` where its
/// gradient is not a distance's (a medial axis, the band's edge).
fn unit_gradient(target: &dyn Target, p: Vec3, h: f32) -> Option<Vec3> {
    let grad = crate::target::gradient(target, p, h);
    let length = grad.length();
    (0.5..=1.5).contains(&length).then(|| grad / length)
}

/// The least-squares k of `a ≈ k·b` over `pairs`, and its coefficient of determination.
fn least_squares(pairs: &[(f64, f64)]) -> (f64, f64) {
    let (sab, sbb) = pairs
        .iter()
        .fold((0.0, 0.0), |(ab, bb), &(a, b)| (ab + a * b, bb + b * b));
    if pairs.is_empty() || sbb == 0.0 {
        return (0.0, 0.0);
    }
    let k = sab / sbb;
    let mean = pairs.iter().map(|p| p.0).sum::<f64>() / pairs.len() as f64;
    let (residual, total) = pairs.iter().fold((0.0, 0.0), |(r, t), &(a, b)| {
        (r + (a - k * b).powi(2), t + (a - mean).powi(2))
    });
    (
        k,
        if total > 0.0 {
            1.0 - residual / total
        } else {
            0.0
        },
    )
}

/// The signed distance s, |s| ≤ `reach`, of the zero of `target` nearest to `x` on the
/// line `x + s·n`: found in steps of `h` outward from `x` both ways, then by the secant.
fn surface_along(target: &dyn Target, x: Vec3, n: Vec3, h: f32, reach: f32) -> Option<f32> {
    let f = |s: f32| target.distance(x + n * s);
    let f0 = f(0.0);
    if f0 == 0.0 {
        return Some(0.0);
    }
    let mut last = [(0.0, f0); 2];
    let steps = (reach / h).ceil() as i32;
    for i in 1..=steps {
        for (side, sign) in [1.0f32, -1.0].into_iter().enumerate() {
            let s = sign * i as f32 * h;
            let v = f(s);
            let (s0, v0) = last[side];
            if (v < 0.0) != (v0 < 0.0) {
                return Some(s0 + (s - s0) * v0 / (v0 - v));
            }
            last[side] = (s, v);
        }
    }
    None
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

/// The timing under which the velocity explains the motion, from the fits of the same
/// frame pairs under each `(timing, fits)`: the one with the most good fits, then the one
/// whose scales agree best (a unit conversion is the same on every pair; the wrong timing
/// makes it drift as the liquid accelerates), then [`Timing::Start`]. Returns it with its
/// median scale, `None` when no fit is good.
pub fn choose_timing(candidates: &[(Timing, Vec<ScaleFit>)]) -> (Timing, Option<f64>) {
    let spread = |fits: &[ScaleFit]| {
        let good = fits.iter().filter(|f| f.is_good()).map(|f| f.scale);
        let (lo, hi) = good.fold((f64::MAX, f64::MIN), |(lo, hi), k| (lo.min(k), hi.max(k)));
        if hi > lo {
            hi / lo - 1.0
        } else {
            0.0
        }
    };
    let count = |fits: &[ScaleFit]| fits.iter().filter(|f| f.is_good()).count();
    let best = candidates.iter().min_by(|(ta, a), (tb, b)| {
        count(b)
            .cmp(&count(a))
            .then(spread(a).total_cmp(&spread(b)))
            .then((*ta != Timing::Start).cmp(&(*tb != Timing::Start)))
    });
    match best {
        Some((timing, fits)) => (*timing, median_scale(fits)),
        None => (Timing::Start, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flow::Rigid;
    use crate::grid::Aabb;
    use crate::target::Sphere;

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

    /// A level set that is a distance only within `reach` of its surface and a constant
    /// `far` beyond, as a solver's (Mantaflow's `phi`).
    struct NearOnly<T>(T, f32, f32);

    impl<T: Target> Target for NearOnly<T> {
        fn distance(&self, p: Vec3) -> f32 {
            let d = self.0.distance(p);
            if d.abs() < self.1 {
                d
            } else {
                self.2.copysign(d)
            }
        }
        fn bounds(&self) -> Aabb {
            self.0.bounds()
        }
    }

    #[test]
    fn a_level_set_that_is_a_distance_only_near_its_surface_gives_the_units() {
        let dx = 1.0 / 32.0;
        let dt = 1.0 / 24.0;
        let speed = 4.0 * dx / dt; // farther a frame than the level set is a distance
        let a = Sphere {
            center: Vec3::ZERO,
            radius: 0.3,
        };
        let b = Sphere {
            center: Vec3::new(0.6, 0.8, 0.0) * speed * dt,
            ..a
        };
        let (na, nb) = (
            NearOnly(a, 3.0 * dx, 5.5 * dx),
            NearOnly(b, 3.0 * dx, 5.5 * dx),
        );
        let flow = Rigid {
            center: Vec3::ZERO,
            linear: Vec3::new(0.6, 0.8, 0.0) * speed / dx, // voxels per second
            angular: Vec3::ZERO,
        };
        let f = fit(&na, &nb, &flow, &sphere_points(&a, 400), dt, 0.5 * dx);
        assert!(
            f.is_good() && (f.scale / f64::from(dx) - 1.0).abs() < 0.02,
            "{f:?}"
        );
    }

    #[test]
    fn the_timing_whose_scale_holds_on_every_pair_is_chosen() {
        let fit_of = |scale| ScaleFit {
            scale,
            r2: 0.99,
            samples: 1000,
        };
        let steady = vec![fit_of(0.078), fit_of(0.079), fit_of(0.078)];
        let drifting = vec![fit_of(0.052), fit_of(0.063), fit_of(0.136)];
        for order in [
            [
                (Timing::Start, steady.clone()),
                (Timing::Mid, drifting.clone()),
            ],
            [
                (Timing::Mid, steady.clone()),
                (Timing::Start, drifting.clone()),
            ],
        ] {
            let (timing, scale) = choose_timing(&order);
            assert_eq!(timing, order[0].0);
            assert_eq!(scale, Some(0.078));
        }
        // More good fits win; a tie with nothing to tell them apart is `Start`.
        let poor = ScaleFit {
            r2: 0.1,
            ..fit_of(0.078)
        };
        let (timing, _) = choose_timing(&[
            (Timing::Start, vec![fit_of(0.07), poor]),
            (Timing::Mid, vec![fit_of(0.07), fit_of(0.09)]),
        ]);
        assert_eq!(timing, Timing::Mid);
        let one = vec![fit_of(0.07)];
        let (timing, _) = choose_timing(&[(Timing::Mid, one.clone()), (Timing::Start, one)]);
        assert_eq!(timing, Timing::Start);
        assert_eq!(
            choose_timing(&[(Timing::Mid, vec![poor])]),
            (Timing::Mid, None)
        );
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
