//! What a level set's distances are measured in. A signed distance has |∇φ| = 1 per world
//! unit; caches from other tools store voxels (Mantaflow's `phi`: |∇φ| = 1/Δx) or other
//! units. Measured where it matters — across the zero crossing — and rescaled to world.

use super::{GridData, LEAF_VOXELS};

/// |∇φ| per world unit across the zero crossing: the median over the leaf voxels with a
/// sign change to a face neighbour (central differences inside each leaf); `None` without
/// a crossing to measure on.
pub fn gradient_per_world_unit(data: &GridData) -> Option<f64> {
    let dx = data.transform.voxel_size();
    let mut norms: Vec<f32> = Vec::new();
    for leaf in 0..data.leaf_count() {
        let v = &data.leaf_values[leaf * LEAF_VOXELS..(leaf + 1) * LEAF_VOXELS];
        let at = |x: usize, y: usize, z: usize| v[x * 64 + y * 8 + z];
        for x in 1..7 {
            for y in 1..7 {
                for z in 1..7 {
                    let f = at(x, y, z);
                    let crossed = [at(x + 1, y, z), at(x, y + 1, z), at(x, y, z + 1)]
                        .iter()
                        .any(|&g| (g < 0.0) != (f < 0.0));
                    if crossed {
                        let gx = at(x + 1, y, z) - at(x - 1, y, z);
                        let gy = at(x, y + 1, z) - at(x, y - 1, z);
                        let gz = at(x, y, z + 1) - at(x, y, z - 1);
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
    let (_, median, _) = norms.select_nth_unstable_by(middle, f32::total_cmp);
    Some(f64::from(*median) / dx)
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
    }
}
