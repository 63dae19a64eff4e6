//! A mesh cut to a box (`--region`): what lies outside is dropped, triangles across a side
//! are cut along it, so the surface ends open on the box's sides (a river or an ocean tank
//! meshed only where the camera sees it). The cuts are shared by the triangles on both
//! sides of an edge, so the mesh inside stays manifold, its boundary on the box.

use glam::Vec3;
use hashbrown::HashMap;

use super::Mesh;
use crate::grid::Aabb;

/// Values carried at each vertex through a cut: `components` floats a vertex, flat
/// (a velocity is 3, a scalar attribute 1). Cut vertices get the values interpolated
/// along their edge.
pub struct VertexChannel<'a> {
    /// `components` × the vertex count.
    pub values: &'a [f32],
    /// Floats a vertex.
    pub components: usize,
}

/// `mesh` cut to `region`, and each channel's values at the new mesh's vertices.
/// Vertices within `tolerance` of a side are moved onto it first (no sliver triangles
/// along the cut; a tiny fraction of a voxel is plenty).
pub fn clip_to_box(
    mesh: &Mesh,
    region: Aabb,
    channels: &[VertexChannel],
    tolerance: f32,
) -> (Mesh, Vec<Vec<f32>>) {
    let mut cut = Cutter::new(mesh, channels);
    let inside = |p: Vec3| p.cmpge(region.min).all() && p.cmple(region.max).all();
    let mut polygons: Vec<Vec<u32>> = Vec::new();
    let mut kept: Vec<[u32; 3]> = Vec::with_capacity(mesh.triangles.len());
    for t in &mesh.triangles {
        let corners = t.map(|i| mesh.positions[i as usize]);
        if corners.iter().all(|&p| inside(p)) {
            kept.push(*t);
        } else if !(0..6).any(|side| corners.iter().all(|&p| distance(p, region, side) < 0.0)) {
            polygons.push(t.to_vec());
        }
    }
    // Side by side, each polygon cut by one side before the next: an edge two triangles
    // share is the same pair of vertices in both, so it is cut at one shared vertex.
    for side in 0..6 {
        cut.snap(&polygons, region, side, tolerance);
        for polygon in &mut polygons {
            *polygon = cut.polygon(polygon, region, side);
        }
        polygons.retain(|p| p.len() >= 3);
    }
    for polygon in &polygons {
        // Convex (a triangle cut by planes): a fan.
        for i in 1..polygon.len() - 1 {
            kept.push([polygon[0], polygon[i], polygon[i + 1]]);
        }
    }
    cut.into_mesh(kept)
}

/// Signed distance of `p` inside the box's `side` (0–2 the low x, y, z sides, 3–5 the
/// high): positive inside.
fn distance(p: Vec3, region: Aabb, side: usize) -> f32 {
    let axis = side % 3;
    match side < 3 {
        true => p[axis] - region.min[axis],
        false => region.max[axis] - p[axis],
    }
}

/// The growing vertex list of a cut mesh, its values, and the vertices cut on each edge.
struct Cutter {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    /// Every channel's floats a vertex, interleaved.
    values: Vec<f32>,
    stride: usize,
    components: Vec<usize>,
    /// The vertex cut on an edge (lower index first) by the current side.
    edges: HashMap<(u32, u32), u32>,
}

impl Cutter {
    fn new(mesh: &Mesh, channels: &[VertexChannel]) -> Self {
        let components: Vec<usize> = channels.iter().map(|c| c.components).collect();
        let stride = components.iter().sum();
        let n = mesh.positions.len();
        let mut values = Vec::with_capacity(n * stride);
        for v in 0..n {
            for c in channels {
                values.extend_from_slice(&c.values[v * c.components..(v + 1) * c.components]);
            }
        }
        Cutter {
            positions: mesh.positions.clone(),
            normals: mesh.normals.clone(),
            values,
            stride,
            components,
            edges: HashMap::new(),
        }
    }

    /// Moves the polygons' vertices within `tolerance` of `side` onto it.
    fn snap(&mut self, polygons: &[Vec<u32>], region: Aabb, side: usize, tolerance: f32) {
        self.edges.clear();
        let axis = side % 3;
        let plane = if side < 3 {
            region.min[axis]
        } else {
            region.max[axis]
        };
        for &v in polygons.iter().flatten() {
            let p = &mut self.positions[v as usize];
            if (p[axis] - plane).abs() < tolerance {
                p[axis] = plane;
            }
        }
    }

    /// `polygon` (convex, counter-clockwise) cut to the inside of `side`: Sutherland and
    /// Hodgman, vertices on the side kept, a new vertex only where an edge runs from
    /// strictly inside to strictly outside.
    fn polygon(&mut self, polygon: &[u32], region: Aabb, side: usize) -> Vec<u32> {
        let d: Vec<f32> = polygon
            .iter()
            .map(|&v| distance(self.positions[v as usize], region, side))
            .collect();
        if d.iter().all(|&d| d >= 0.0) {
            return polygon.to_vec();
        }
        let mut out = Vec::with_capacity(polygon.len() + 1);
        for i in 0..polygon.len() {
            let j = (i + 1) % polygon.len();
            if d[i] >= 0.0 {
                out.push(polygon[i]);
            }
            if (d[i] > 0.0 && d[j] < 0.0) || (d[i] < 0.0 && d[j] > 0.0) {
                out.push(self.cut(polygon[i], polygon[j], region, side));
            }
        }
        out
    }

    /// The vertex where edge `a`–`b` crosses `side`, made once for both its triangles
    /// (computed from the lower index, so the same bits either way).
    fn cut(&mut self, a: u32, b: u32, region: Aabb, side: usize) -> u32 {
        let (a, b) = (a.min(b), a.max(b));
        if let Some(&v) = self.edges.get(&(a, b)) {
            return v;
        }
        let (pa, pb) = (self.positions[a as usize], self.positions[b as usize]);
        let (da, db) = (distance(pa, region, side), distance(pb, region, side));
        let t = da / (da - db);
        let mut p = pa.lerp(pb, t);
        // On this side exactly, and within the sides cut before (a point interpolated
        // between two on a side can round a bit off it).
        for done in 0..=side {
            let axis = done % 3;
            p[axis] = match done < 3 {
                true if done == side => region.min[axis],
                false if done == side => region.max[axis],
                true => p[axis].max(region.min[axis]),
                false => p[axis].min(region.max[axis]),
            };
        }
        let v = self.positions.len() as u32;
        self.positions.push(p);
        if !self.normals.is_empty() {
            let (na, nb) = (self.normals[a as usize], self.normals[b as usize]);
            self.normals.push(na.lerp(nb, t).normalize_or(na));
        }
        for k in 0..self.stride {
            let (va, vb) = (
                self.values[a as usize * self.stride + k],
                self.values[b as usize * self.stride + k],
            );
            self.values.push(va + (vb - va) * t);
        }
        self.edges.insert((a, b), v);
        v
    }

    /// The mesh of `triangles` with only the vertices they use (in their first use's
    /// order of the original list), and each channel's values.
    fn into_mesh(self, triangles: Vec<[u32; 3]>) -> (Mesh, Vec<Vec<f32>>) {
        let mut used = vec![false; self.positions.len()];
        for &v in triangles.iter().flatten() {
            used[v as usize] = true;
        }
        let mut index = vec![u32::MAX; self.positions.len()];
        let mut mesh = Mesh::default();
        let mut channels: Vec<Vec<f32>> = vec![Vec::new(); self.components.len()];
        for (v, _) in used.iter().enumerate().filter(|(_, &u)| u) {
            index[v] = mesh.positions.len() as u32;
            mesh.positions.push(self.positions[v]);
            if !self.normals.is_empty() {
                mesh.normals.push(self.normals[v]);
            }
            let mut at = v * self.stride;
            for (channel, &n) in channels.iter_mut().zip(&self.components) {
                channel.extend_from_slice(&self.values[at..at + n]);
                at += n;
            }
        }
        mesh.triangles = triangles
            .into_iter()
            .map(|t| t.map(|v| index[v as usize]))
            .collect();
        (mesh, channels)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed box mesh of 2 × 2 × 2 cells a side, split into triangles, outward.
    fn sphere(n: u32) -> Mesh {
        // A UV sphere, radius 1, outward, closed.
        let mut mesh = Mesh::default();
        mesh.positions.push(Vec3::Z);
        for i in 1..n {
            let theta = std::f32::consts::PI * i as f32 / n as f32;
            for j in 0..2 * n {
                let phi = std::f32::consts::PI * j as f32 / n as f32;
                mesh.positions.push(Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ));
            }
        }
        mesh.positions.push(-Vec3::Z);
        let ring = |i: u32, j: u32| 1 + (i - 1) * 2 * n + j % (2 * n);
        let last = mesh.positions.len() as u32 - 1;
        for j in 0..2 * n {
            mesh.triangles.push([0, ring(1, j), ring(1, j + 1)]);
            for i in 1..n - 1 {
                let (a, b, c, d) = (
                    ring(i, j),
                    ring(i + 1, j),
                    ring(i + 1, j + 1),
                    ring(i, j + 1),
                );
                mesh.triangles.push([a, b, c]);
                mesh.triangles.push([a, c, d]);
            }
            mesh.triangles
                .push([ring(n - 1, j), last, ring(n - 1, j + 1)]);
        }
        mesh.normals = mesh.positions.clone();
        mesh
    }

    #[test]
    fn a_sphere_cut_to_a_box_is_open_on_its_sides_and_manifold() {
        let mesh = sphere(24);
        assert!(mesh.check().is_clean(), "{}", mesh.check());
        let heights: Vec<f32> = mesh.positions.iter().map(|p| p.z).collect();
        let region = Aabb {
            min: Vec3::new(-0.5, -2.0, -0.3),
            max: Vec3::new(2.0, 0.6, 2.0),
        };
        let (cut, values) = clip_to_box(
            &mesh,
            region,
            &[VertexChannel {
                values: &heights,
                components: 1,
            }],
            1e-5,
        );
        let check = cut.check();
        // Open along the cut, manifold with its boundary, nothing degenerate.
        assert!(check.open_edges > 0);
        assert!(check.manifold_with_boundary(), "{check}");
        assert_eq!((check.coincident, check.degenerate), (0, 0), "{check}");
        let boundary = cut.boundary_vertices();
        assert!(!boundary.is_empty());
        for &v in &boundary {
            let p = cut.positions[v as usize];
            let on_side = (0..6).any(|side| distance(p, region, side) == 0.0);
            assert!(on_side, "a boundary vertex off the box's sides: {p}");
        }
        for (p, &z) in cut.positions.iter().zip(&values[0]) {
            assert!(
                region.min.cmple(*p).all() && p.cmple(region.max).all(),
                "{p} outside"
            );
            // Interpolated along the edges: the height at the vertex, within the chord's sag.
            assert!(
                (z - p.z).abs() < 1e-4,
                "{z} carried to a vertex at height {}",
                p.z
            );
        }
        for n in &cut.normals {
            assert!((n.length() - 1.0).abs() < 1e-5);
        }
        // The area inside the box: the cap and the band's parts, against the uncut mesh's
        // triangles wholly inside, which it exceeds.
        let whole: f64 = mesh.area();
        assert!(cut.area() < whole && cut.area() > 0.1 * whole);
        // A box around everything leaves the mesh as it is.
        let all = Aabb {
            min: Vec3::splat(-2.0),
            max: Vec3::splat(2.0),
        };
        let (same, _) = clip_to_box(&mesh, all, &[], 1e-5);
        assert_eq!(same.triangles, mesh.triangles);
        assert_eq!(same.positions, mesh.positions);
        // A box beside it leaves nothing.
        let beside = Aabb {
            min: Vec3::splat(3.0),
            max: Vec3::splat(4.0),
        };
        assert!(clip_to_box(&mesh, beside, &[], 1e-5).0.triangles.is_empty());
    }
}
