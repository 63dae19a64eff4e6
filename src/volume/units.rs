//! What a level set's distances are measured in. A signed distance has |∇φ| = 1 per world
//! unit; caches from other tools store voxels (Mantaflow's `phi`: |∇φ| = 1/Δx) or other
//! units. Measured where it matters — across the zero crossing — and rescaled to world.

use super::{GridData, LEAF_VOXELS};

/// |∇φ| per world unit across the zero crossing: the median over the leaf voxels with a
/// sign change to a face neighbour (central differences inside each leaf); `None` without
/// a crossing to measure on.
pub fn gradient_per_world_unit(data: &GridData) -> Option<f64> {
    let dx = data.transform.voxel_size();
    // In f64: values of 1e30 (a cache in absurd units) square past f32's range.
    let mut norms: Vec<f64> = Vec::new();
    for leaf in 0..data.leaf_count() {
        let v = &data.leaf_values[leaf * LEAF_VOXELS..(leaf + 1) * LEAF_VOXELS];
        let at = |x: usize, y: usize, z: usize| v[x * 64 + y * 8 + z];
        for x in 1..7 {
            for y in 1..7 {
                for z in 1..7 {
                    let f = f64::from(at(x, y, z));
                    let crossed = [at(x + 1, y, z), at(x, y + 1, z), at(x, y, z + 1)]
                        .iter()
                        .any(|&g| (g < 0.0) != (f < 0.0));
                    if crossed {
                        let d = |a: f32, b: f32| f64::from(a) - f64::from(b);
                        let gx = d(at(x + 1, y, z), at(x - 1, y, z));
                        let gy = d(at(x, y + 1, z), at(x, y - 1, z));
                        let gz = d(at(x, y, z + 1), at(x, y, z - 1));
                        norms.push(0.5 * (gx * gx + gy * gy + gz * gz).sqrt());
                    }
                }
            }
        }
    }
    if norms.is_empty() {
        return None;
    }
    let middle = norms.len() / 2;
    let (_, median, _) = norms.select_nth_unstable_by(middle, f64::total_cmp);
    Some(*median / dx).filter(|k| k.is_finite() && *k > 0.0)
}

/// Multiplies every distance of `data` (values, tiles, background) by `scale`.
pub fn rescale(data: &mut GridData, scale: f32) {
    data.leaf_values.iter_mut().for_each(|v| *v *= scale);
    data.tiles.iter_mut().for_each(|t| t.value *= scale);
    data.background *= scale;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::target::{sample, Sphere, Target};
    use glam::Vec3;

    #[test]
    fn world_and_voxel_units_are_told_apart() {
        let dx = 1.0 / 32.0;
        let sphere = Sphere {
            center: Vec3::splat(0.5),
            radius: 0.3,
        };
        let mut grid = sample::level_set(&sphere as &dyn Target, dx, 3.0);
        let world = gradient_per_world_unit(&grid).unwrap();
        assert!((world - 1.0).abs() < 0.02, "{world}");
        rescale(&mut grid, 1.0 / dx);
        let voxels = gradient_per_world_unit(&grid).unwrap();
        assert!((voxels * f64::from(dx) - 1.0).abs() < 0.02, "{voxels}");
        // Absurd units are measured too (their squares overflowed f32: infinite, then a
        // rescale by 0 that emptied the skin), and rescaled back to distances.
        rescale(&mut grid, 1e30 * dx);
        let absurd = gradient_per_world_unit(&grid).unwrap();
        assert!((absurd / 1e30 - 1.0).abs() < 0.02, "{absurd}");
        rescale(&mut grid, (1.0 / absurd) as f32);
        let back = gradient_per_world_unit(&grid).unwrap();
        assert!((back - 1.0).abs() < 0.02, "{back}");
    }
}
