//! Finite-difference stencils on the potential (paper §4.4, eq. 4), in index units.

use crate::grid::{Halo, HALO_DIM};
use glam::{IVec3, Vec3};

/// The 3×3×3 neighbourhood of a node, read in place from its block's halo (copying its
/// 27 values per node was 6 % of a step).
#[derive(Clone, Copy)]
pub(crate) struct Stencil<'a> {
    values: &'a [f32; HALO_DIM * HALO_DIM * HALO_DIM],
    /// Halo index of the centre node.
    centre: usize,
}

impl<'a> Stencil<'a> {
    /// The stencil of local node (x, y, z), each in 0..8.
    #[inline]
    pub(crate) fn from_halo(halo: &'a Halo, x: i32, y: i32, z: i32) -> Self {
        debug_assert!((0..8).contains(&x) && (0..8).contains(&y) && (0..8).contains(&z));
        Stencil {
            values: &halo.values,
            centre: Halo::index(x, y, z),
        }
    }

    /// The value at offset (dx, dy, dz), each in -1..=1, from the centre.
    #[inline]
    pub(crate) fn at(&self, dx: i32, dy: i32, dz: i32) -> f32 {
        let step = (dx * HALO_DIM as i32 + dy) * HALO_DIM as i32 + dz;
        // SAFETY: the centre is a block node (0..8 on each axis, `from_halo`), so every
        // offset of -1..=1 stays within the halo's -1..=8.
        unsafe {
            *self
                .values
                .get_unchecked((self.centre as isize + step as isize) as usize)
        }
    }

    #[inline]
    pub(crate) fn center(&self) -> f32 {
        self.at(0, 0, 0)
    }

    /// Central-difference gradient.
    #[inline]
    pub(crate) fn gradient(&self) -> Vec3 {
        Vec3::new(
            0.5 * (self.at(1, 0, 0) - self.at(-1, 0, 0)),
            0.5 * (self.at(0, 1, 0) - self.at(0, -1, 0)),
            0.5 * (self.at(0, 0, 1) - self.at(0, 0, -1)),
        )
    }
}

/// The upwind (Godunov) |∇φ| of a node for an outward and for an inward front (φ
/// decreasing where it grows), from its values at offsets (dx, dy, dz). Unlike central
/// differences, it sees an isolated node, so a vanishing bubble keeps shrinking instead of
/// freezing.
#[inline(always)]
fn upwind_norms(at: impl Fn(i32, i32, i32) -> f32) -> (f32, f32) {
    let c = at(0, 0, 0);
    let (mut outward, mut inward) = (0.0, 0.0);
    for (lo, hi) in [
        (at(-1, 0, 0), at(1, 0, 0)),
        (at(0, -1, 0), at(0, 1, 0)),
        (at(0, 0, -1), at(0, 0, 1)),
    ] {
        let (minus, plus) = (c - lo, hi - c);
        let d = minus.max(0.0).max(-plus.min(0.0));
        outward += d * d;
        let d = (-minus.min(0.0)).max(plus.max(0.0));
        inward += d * d;
    }
    (outward.sqrt(), inward.sqrt())
}

/// Mean curvature κ = div(∇φ/|∇φ|) (sum of principal curvatures, positive on a sphere
/// with φ negative inside), per index unit: eq. 4 with the paper's slip corrected (the y²
/// term multiplies φxx + φzz), from a node's values at offsets (dx, dy, dz); 0 where |∇φ|
/// vanishes. Branch-free, so that a row of nodes computes it together.
#[inline(always)]
fn mean_curvature(at: impl Fn(i32, i32, i32) -> f32) -> f32 {
    let c = at(0, 0, 0);
    let fx = 0.5 * (at(1, 0, 0) - at(-1, 0, 0));
    let fy = 0.5 * (at(0, 1, 0) - at(0, -1, 0));
    let fz = 0.5 * (at(0, 0, 1) - at(0, 0, -1));
    let fxx = at(1, 0, 0) - 2.0 * c + at(-1, 0, 0);
    let fyy = at(0, 1, 0) - 2.0 * c + at(0, -1, 0);
    let fzz = at(0, 0, 1) - 2.0 * c + at(0, 0, -1);
    let fxy = 0.25 * (at(1, 1, 0) - at(1, -1, 0) - at(-1, 1, 0) + at(-1, -1, 0));
    let fyz = 0.25 * (at(0, 1, 1) - at(0, 1, -1) - at(0, -1, 1) + at(0, -1, -1));
    let fxz = 0.25 * (at(1, 0, 1) - at(1, 0, -1) - at(-1, 0, 1) + at(-1, 0, -1));
    let g2 = fx * fx + fy * fy + fz * fz;
    let numerator = fx * fx * (fyy + fzz) + fy * fy * (fxx + fzz) + fz * fz * (fxx + fyy)
        - 2.0 * (fx * fy * fxy + fy * fz * fyz + fx * fz * fxz);
    let kappa = numerator / (g2 * g2.sqrt());
    if g2 < 1e-12 {
        0.0
    } else {
        kappa
    }
}

/// The speed's stencil terms (eq. 4's curvature, the upwind |∇φ|) of the eight nodes of
/// one row along z of a block, computed together: the arithmetic vectorises across the row.
pub(crate) struct RowTerms {
    /// Mean curvature per index unit, 0 where |∇φ| vanishes.
    pub curvature: [f32; 8],
    /// Upwind |∇φ| for an outward front.
    pub outward: [f32; 8],
    /// Upwind |∇φ| for an inward front.
    pub inward: [f32; 8],
}

impl RowTerms {
    /// The terms of local nodes (x, y, 0..8), x and y in 0..8.
    pub(crate) fn of(halo: &Halo, x: i32, y: i32) -> Self {
        debug_assert!((0..8).contains(&x) && (0..8).contains(&y));
        // The 3×3 rows around this one, each with a value before and after: rows[dx][dy]
        // holds z = -1..=8.
        let mut rows = [[[0.0f32; 10]; 3]; 3];
        for (i, plane) in rows.iter_mut().enumerate() {
            for (j, row) in plane.iter_mut().enumerate() {
                let start = Halo::index(x + i as i32 - 1, y + j as i32 - 1, -1);
                row.copy_from_slice(&halo.values[start..start + 10]);
            }
        }
        let mut terms = RowTerms {
            curvature: [0.0; 8],
            outward: [0.0; 8],
            inward: [0.0; 8],
        };
        for z in 0..8 {
            let at = |dx: i32, dy: i32, dz: i32| {
                rows[(dx + 1) as usize][(dy + 1) as usize][(z as i32 + 1 + dz) as usize]
            };
            terms.curvature[z] = mean_curvature(at);
            (terms.outward[z], terms.inward[z]) = upwind_norms(at);
        }
        terms
    }
}

/// Catmull-Rom weights of the four nodes around a point at fraction `t` past the second.
#[inline]
pub(crate) fn cubic_weights(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// ⌊u⌋ for |u| < 2³¹, by truncation: `f32::floor` is a libm call on x86-64's baseline
/// (no SSE4.1 rounding), 2 % of a particle run's time in the trilinear and tricubic
/// reads. NaN gives 0, as `floor().as_ivec3()` does.
#[inline]
pub(crate) fn floor_ivec3(u: Vec3) -> IVec3 {
    let i = u.as_ivec3();
    i - IVec3::select(u.cmplt(i.as_vec3()), IVec3::ONE, IVec3::ZERO)
}

/// Catmull-Rom interpolation of `at` (node units → value) at `u`, limited to the values
/// of the cell holding `u` (a cubic may overshoot them; the limiter never creates a new
/// extremum, as the advection's). Fourth order where the values are smooth: trilinear
/// reads would shrink every convex part by about κΔx²/8 (the carry's remap each frame,
/// a level-set target's surface).
#[inline]
pub(crate) fn limited_tricubic(mut at: impl FnMut(IVec3) -> f32, u: Vec3) -> f32 {
    let base = floor_ivec3(u);
    let t = u - base.as_vec3();
    // A cell of one value (most of the tube's outer nodes, at ±1) limits the cubic to it:
    // its 56 other taps need not be read.
    let first = at(base);
    if (1..8).all(|k| at(base + IVec3::new(k >> 2, (k >> 1) & 1, k & 1)) == first) {
        return first;
    }
    let (wx, wy, wz) = (cubic_weights(t.x), cubic_weights(t.y), cubic_weights(t.z));
    let mut value = 0.0;
    let (mut low, mut high) = (f32::INFINITY, f32::NEG_INFINITY);
    for (i, wx) in wx.iter().enumerate() {
        let mut plane = 0.0;
        for (j, wy) in wy.iter().enumerate() {
            let mut row = 0.0;
            for (k, wz) in wz.iter().enumerate() {
                let step = IVec3::new(i as i32 - 1, j as i32 - 1, k as i32 - 1);
                let v = at(base + step);
                if step.cmpge(IVec3::ZERO).all() && step.cmple(IVec3::ONE).all() {
                    low = low.min(v);
                    high = high.max(v);
                }
                row += wz * v;
            }
            plane += wy * row;
        }
        value += wx * plane;
    }
    value.clamp(low, high)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A halo holding `f` around `p` (index units), with `p` at local node (1, 1, 1).
    fn sampled(f: impl Fn(f32, f32, f32) -> f32, p: Vec3) -> Box<Halo> {
        let mut halo = Box::<Halo>::default();
        for x in -1..=8 {
            for y in -1..=8 {
                for z in -1..=8 {
                    let q = p + Vec3::new(x as f32, y as f32, z as f32) - Vec3::ONE;
                    halo.values[Halo::index(x, y, z)] = f(q.x, q.y, q.z);
                }
            }
        }
        halo
    }

    #[test]
    fn sphere_curvature_is_two_over_r() {
        let r = 20.0;
        let sdf = |x: f32, y: f32, z: f32| (x * x + y * y + z * z).sqrt() - r;
        // Off-axis, where the slip of eq. 4 would show.
        let p = Vec3::new(11.0, 13.0, 10.0).normalize() * r;
        let k = RowTerms::of(&sampled(sdf, p), 1, 1).curvature[1];
        assert!((k - 2.0 / r).abs() < 0.002, "{k}");
    }

    #[test]
    fn cylinder_curvature_is_one_over_r() {
        let r = 15.0;
        let sdf = |x: f32, _y: f32, z: f32| (x * x + z * z).sqrt() - r;
        let p = Vec3::new(r * 0.6, 3.0, r * 0.8);
        let k = RowTerms::of(&sampled(sdf, p), 1, 1).curvature[1];
        assert!((k - 1.0 / r).abs() < 0.002, "{k}");
    }
}
