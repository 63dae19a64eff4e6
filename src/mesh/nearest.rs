//! Nearest-triangle queries through a hashed grid of cells: distances from points to a
//! mesh, for the Hausdorff comparison.

use std::ops::Range;

use glam::{IVec3, Vec3};
use hashbrown::HashMap;
use rayon::prelude::*;

use super::Mesh;

/// The triangles of a mesh, each filed under the cell holding its bounding box's lower
/// corner; each cell's triangles are stored together, corners inline, for
/// cache-friendly queries. A query widens its range downward by the largest bounding
/// box, in cells (one for a marching-cubes mesh on a grid of the same spacing).
pub struct TriangleIndex {
    cell: f32,
    cells: HashMap<IVec3, Range<u32>>,
    corners: Vec<[Vec3; 3]>,
    extent: IVec3,
}

impl TriangleIndex {
    /// Indexes `mesh` with cubic cells of side `cell` (world units).
    pub fn new(mesh: &Mesh, cell: f32) -> Self {
        let key = |p: Vec3| (p / cell).floor().as_ivec3();
        let boxes: Vec<(IVec3, IVec3)> = mesh
            .triangles
            .par_iter()
            .map(|t| {
                let [p, q, r] = t.map(|v| mesh.positions[v as usize]);
                (key(p.min(q).min(r)), key(p.max(q).max(r)))
            })
            .collect();
        let extent = boxes
            .par_iter()
            .map(|(lo, hi)| *hi - *lo)
            .reduce(|| IVec3::ZERO, IVec3::max);
        let mut filed: Vec<(IVec3, u32)> = boxes
            .par_iter()
            .enumerate()
            .map(|(i, (lo, _))| (*lo, i as u32))
            .collect();
        filed.par_sort_unstable_by_key(|(c, i)| (c.to_array(), *i));
        let corners = filed
            .par_iter()
            .map(|&(_, i)| mesh.triangles[i as usize].map(|v| mesh.positions[v as usize]))
            .collect();
        let mut cells = HashMap::new();
        let mut start = 0;
        for (end, pair) in filed.iter().enumerate() {
            if filed.get(end + 1).map_or(true, |next| next.0 != pair.0) {
                cells.insert(pair.0, start as u32..end as u32 + 1);
                start = end + 1;
            }
        }
        TriangleIndex {
            cell,
            cells,
            corners,
            extent,
        }
    }

    fn key(&self, p: Vec3) -> IVec3 {
        (p / self.cell).floor().as_ivec3()
    }

    /// Distance from `p` to the nearest triangle within `reach` cells of `p`'s cell;
    /// infinite when there is none. Exact whenever the nearest point of the mesh is
    /// within `reach` cells.
    pub fn distance(&self, p: Vec3, reach: i32) -> f32 {
        let c = self.key(p);
        self.nearest_in(
            c - IVec3::splat(reach) - self.extent,
            c + IVec3::splat(reach),
            p,
        )
    }

    fn nearest_in(&self, lo: IVec3, hi: IVec3, p: Vec3) -> f32 {
        let mut best = f32::INFINITY;
        for x in lo.x..=hi.x {
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    let Some(range) = self.cells.get(&IVec3::new(x, y, z)) else {
                        continue;
                    };
                    for &[a, b, c] in &self.corners[range.start as usize..range.end as usize] {
                        best = best.min(point_triangle_distance(p, a, b, c));
                    }
                }
            }
        }
        best
    }
}

/// Distance from `p` to triangle `abc` (Ericson, Real-Time Collision Detection, 5.1.5).
pub(crate) fn point_triangle_distance(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return p.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return p.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return p.distance(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    p.distance(a + ab * (vb * denom) + ac * (vc * denom))
}

/// Symmetric Hausdorff distance between two meshes (world units), searched through a
/// hashed grid of triangles with cells of `cell`: distances beyond two cells are reported
/// as found among the triangles within two cells, or as infinite.
pub fn hausdorff(a: &Mesh, b: &Mesh, cell: f32) -> f64 {
    let max = |d: Vec<f64>| d.into_iter().fold(0.0, f64::max);
    max(distances(a, b, cell)).max(max(distances(b, a, cell)))
}

/// Mean distance from the vertices of `from` to the surface of `to` (world units),
/// searched as in [`hausdorff`].
pub fn mean_distance(from: &Mesh, to: &Mesh, cell: f32) -> f64 {
    let d = distances(from, to, cell);
    d.iter().sum::<f64>() / d.len().max(1) as f64
}

/// Distance from each vertex of `from` to the triangles of `to`.
fn distances(from: &Mesh, to: &Mesh, cell: f32) -> Vec<f64> {
    let index = TriangleIndex::new(to, cell);
    from.positions
        .par_iter()
        .map(|&p| f64::from(index.distance(p, 2)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{point_triangle_distance, TriangleIndex};
    use crate::mesh::Mesh;
    use glam::Vec3;

    #[test]
    fn index_finds_what_brute_force_finds_within_the_radius() {
        let mut state = 11u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut mesh = Mesh::default();
        for t in 0..400u32 {
            // Triangles up to 1.5 cells across, scattered over 10 cells.
            let base = Vec3::new(next(), next(), next()) * 10.0;
            for _ in 0..3 {
                mesh.positions
                    .push(base + Vec3::new(next(), next(), next()) * 1.5);
            }
            mesh.triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        let index = TriangleIndex::new(&mesh, 1.0);
        for _ in 0..2000 {
            let p = Vec3::new(next(), next(), next()) * 10.0;
            let exact = mesh
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                    point_triangle_distance(p, a, b, c)
                })
                .fold(f32::INFINITY, f32::min);
            if exact <= 1.0 {
                assert_eq!(index.distance(p, 1), exact, "{p}");
            }
        }
    }

    #[test]
    fn point_triangle_distance_in_each_region() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let d = |p: Vec3| point_triangle_distance(p, a, b, c);
        assert!((d(Vec3::new(0.2, 0.2, 0.5)) - 0.5).abs() < 1e-6); // face
        assert!((d(Vec3::new(-1.0, -1.0, 0.0)) - 2f32.sqrt()).abs() < 1e-6); // vertex a
        assert!((d(Vec3::new(0.5, -2.0, 0.0)) - 2.0).abs() < 1e-6); // edge ab
        assert!((d(Vec3::new(1.0, 1.0, 0.0)) - 0.5f32.sqrt()).abs() < 1e-6); // edge bc
        assert!((d(Vec3::new(3.0, 0.0, 0.0)) - 2.0).abs() < 1e-6); // vertex b
    }
}
