//! Indexed triangle meshes: measures (area, enclosed volume, Euler characteristic,
//! components) and topology checks; written and read by [`crate::io::mesh`].

use glam::Vec3;
use rayon::prelude::*;

mod check;
mod clip;
pub(crate) mod nearest;
mod relax;

pub use check::MeshCheck;
pub use clip::{clip_to_box, VertexChannel};
pub(crate) use nearest::point_triangle_distance;
pub use nearest::{hausdorff, mean_distance, TriangleIndex};
pub use relax::{relax_on_surface, Surface};

#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// World-space positions.
    pub positions: Vec<Vec3>,
    /// Unit outward normals, one per position.
    pub normals: Vec<Vec3>,
    /// Counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn clear(&mut self) {
        self.positions.clear();
        self.normals.clear();
        self.triangles.clear();
    }

    fn corners(&self, t: &[u32; 3]) -> [Vec3; 3] {
        t.map(|i| self.positions[i as usize])
    }

    /// Surface area.
    pub fn area(&self) -> f64 {
        self.area_and_volume().0
    }

    /// Signed enclosed volume (positive for an outward-wound closed mesh).
    pub fn volume(&self) -> f64 {
        self.area_and_volume().1
    }

    /// Area and signed volume in one parallel pass. Sums run over fixed chunks in a fixed
    /// order, so the result does not depend on thread scheduling (a resumed run must
    /// repeat an uninterrupted one bit for bit).
    pub fn area_and_volume(&self) -> (f64, f64) {
        let centre = self.positions.first().copied().unwrap_or(Vec3::ZERO);
        let partial: Vec<(f64, f64)> = self
            .triangles
            .par_chunks(4096)
            .map(|chunk| {
                chunk.iter().fold((0.0, 0.0), |(area, volume), t| {
                    let [a, b, c] = self.corners(t).map(|p| p - centre);
                    let area = area + f64::from(0.5 * (b - a).cross(c - a).length());
                    let [a, b, c] = [a, b, c].map(|p| p.as_dvec3());
                    (area, volume + a.dot(b.cross(c)) / 6.0)
                })
            })
            .collect();
        partial
            .iter()
            .fold((0.0, 0.0), |(a, v), &(pa, pv)| (a + pa, v + pv))
    }

    /// The flux of `velocity` out through the surface, ∮ v·n dA (volume per unit time),
    /// each triangle's velocity read at its centroid; in fixed chunks, as
    /// [`Mesh::area_and_volume`], for the same bits on every run.
    pub fn flux(&self, velocity: impl Fn(Vec3) -> Vec3 + Sync) -> f64 {
        let partial: Vec<f64> = self
            .triangles
            .par_chunks(4096)
            .map(|chunk| {
                chunk.iter().fold(0.0, |flux, t| {
                    let [a, b, c] = self.corners(t);
                    let area_normal = 0.5 * (b - a).cross(c - a);
                    flux + f64::from(velocity((a + b + c) / 3.0).dot(area_normal))
                })
            })
            .collect();
        partial.iter().sum()
    }

    /// The worst triangle's shape, min over triangles of 4√3·area / Σ edge²: 1 for an
    /// equilateral triangle, near 0 for a sliver (1 with no triangles).
    pub fn worst_triangle_quality(&self) -> f32 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = self.corners(t);
                let squares =
                    (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
                2.0 * 3f32.sqrt() * (b - a).cross(c - a).length() / squares
            })
            .fold(1.0, f32::min)
    }

    /// χ = V − E + F over the vertices the triangles use.
    pub fn euler_characteristic(&self) -> i64 {
        let mut used = vec![false; self.positions.len()];
        for t in &self.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let v = used.iter().filter(|&&u| u).count() as i64;
        v - self.edge_count() as i64 + self.triangles.len() as i64
    }

    /// Undirected edges the triangles use, each once: bucketed by their lower vertex (a
    /// counting sort, linear), then the few in each bucket deduplicated.
    fn edge_count(&self) -> usize {
        let edges = || {
            self.triangles.iter().flat_map(|t| {
                (0..3).map(move |i| (t[i].min(t[(i + 1) % 3]), t[i].max(t[(i + 1) % 3])))
            })
        };
        let mut start = vec![0u32; self.positions.len() + 1];
        for (low, _) in edges() {
            start[low as usize + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut next = start.clone();
        let mut high = vec![0u32; 3 * self.triangles.len()];
        for (low, h) in edges() {
            high[next[low as usize] as usize] = h;
            next[low as usize] += 1;
        }
        start
            .windows(2)
            .map(|w| {
                let bucket = &mut high[w[0] as usize..w[1] as usize];
                bucket.sort_unstable();
                bucket.chunk_by(|a, b| a == b).count()
            })
            .sum()
    }

    /// Connected components (through shared vertices).
    pub fn components(&self) -> usize {
        let labels = piece_labels(self);
        let mut used = vec![false; self.positions.len()];
        for t in &self.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        (0..self.positions.len())
            .filter(|&i| used[i] && labels[i] == i as u32)
            .count()
    }
}

/// Each vertex's piece: the index of one vertex of its connected component (through
/// shared vertices), the same for every vertex of the piece.
pub fn piece_labels(mesh: &Mesh) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            let p = parent[parent[i as usize] as usize];
            parent[i as usize] = p;
            i = p;
        }
        i
    }
    for t in &mesh.triangles {
        let a = root(&mut parent, t[0]);
        for &v in &t[1..] {
            let b = root(&mut parent, v);
            parent[b as usize] = a;
        }
    }
    (0..parent.len() as u32)
        .map(|i| root(&mut parent, i))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// χ counts each undirected edge once, however many triangles share it and in
    /// whichever direction.
    #[test]
    fn euler_characteristic_counts_each_edge_once() {
        let mut rng = crate::test_rng(3);
        let mut next = move |n: u32| rng(u64::from(n)) as u32;
        for _ in 0..20 {
            let vertices = 40;
            let triangles: Vec<[u32; 3]> = (0..60)
                .map(|_| [next(vertices), next(vertices), next(vertices)])
                .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
                .collect();
            let mesh = Mesh {
                positions: vec![Vec3::ZERO; vertices as usize],
                normals: vec![Vec3::Z; vertices as usize],
                triangles,
            };
            let edges: std::collections::HashSet<(u32, u32)> = mesh
                .triangles
                .iter()
                .flat_map(|t| {
                    (0..3).map(move |i| (t[i].min(t[(i + 1) % 3]), t[i].max(t[(i + 1) % 3])))
                })
                .collect();
            let used: std::collections::HashSet<u32> =
                mesh.triangles.iter().flatten().copied().collect();
            let chi = used.len() as i64 - edges.len() as i64 + mesh.triangles.len() as i64;
            assert_eq!(mesh.euler_characteristic(), chi);
        }
    }
}
