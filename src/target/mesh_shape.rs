//! A closed triangle mesh as a signed distance, without OpenVDB: a collider given as an
//! OBJ (a tank's walls, an obstacle from a DCC). The distance is exact within `reach` of
//! the surface (the nearest triangle, from a hashed grid of cells) and ±`reach` beyond;
//! the sign is the parity of the surface's crossings along a ray in +x, so it holds on
//! every node however far from the surface.

use glam::{DVec2, IVec2, IVec3, Vec3, Vec3Swizzles};
use hashbrown::HashMap;
use rayon::prelude::*;

use super::Target;
use crate::grid::Aabb;
use crate::mesh::nearest::point_triangle_distance;

/// A closed mesh's signed distance (negative inside), clamped to ±`reach`.
pub struct MeshShape {
    corners: Vec<[Vec3; 3]>,
    /// Cell side: `reach`, so a triangle within reach of a point is filed in one of the
    /// 27 cells around it.
    cell: f32,
    /// The triangles passing through each cell.
    cells: HashMap<IVec3, Vec<u32>>,
    /// The triangles whose shadow on the (y, z) plane covers each column of cells.
    columns: HashMap<IVec2, Vec<u32>>,
    /// Ray origins are nudged off the (y, z) lattice by this much, so that a ray never
    /// runs along an edge shared by two triangles (counted twice) or none.
    nudge: DVec2,
    bounds: Aabb,
}

/// A mesh with edges not shared by exactly two triangles: it has no inside.
#[derive(Debug, thiserror::Error)]
#[error("not a closed mesh: {open} of its edges are not shared by exactly two triangles")]
pub struct OpenMesh {
    /// The edges on one triangle or more than two.
    pub open: usize,
}

impl MeshShape {
    /// `triangles` over `positions` (a closed mesh, either orientation), its distance
    /// exact within `reach` (world units, positive).
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]], reach: f32) -> Result<Self, OpenMesh> {
        let open = open_edges(triangles);
        if open > 0 || triangles.is_empty() {
            return Err(OpenMesh { open });
        }
        let corners: Vec<[Vec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|v| positions[v as usize]))
            .collect();
        let cell = reach;
        let key = |p: Vec3| (p / cell).floor().as_ivec3();
        let half_diagonal = 0.5 * 3f32.sqrt() * cell;
        // Each triangle in the cells it passes through (their centres within a half
        // diagonal of it), found over its bounding box.
        let filed: Vec<(IVec3, u32)> = corners
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, &[a, b, c])| {
                let (lo, hi) = (key(a.min(b).min(c)), key(a.max(b).max(c)));
                (lo.x..=hi.x).flat_map(move |x| {
                    (lo.y..=hi.y).flat_map(move |y| {
                        (lo.z..=hi.z).filter_map(move |z| {
                            let k = IVec3::new(x, y, z);
                            let centre = (k.as_vec3() + 0.5) * cell;
                            (point_triangle_distance(centre, a, b, c) <= half_diagonal)
                                .then_some((k, i as u32))
                        })
                    })
                })
            })
            .collect();
        let mut cells: HashMap<IVec3, Vec<u32>> = HashMap::new();
        for (k, i) in filed {
            cells.entry(k).or_default().push(i);
        }
        let mut columns: HashMap<IVec2, Vec<u32>> = HashMap::new();
        for (i, &[a, b, c]) in corners.iter().enumerate() {
            let (lo, hi) = (key(a.min(b).min(c)), key(a.max(b).max(c)));
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    columns.entry(IVec2::new(y, z)).or_default().push(i as u32);
                }
            }
        }
        let (min, max) = positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        Ok(MeshShape {
            corners,
            cell,
            cells,
            columns,
            nudge: DVec2::new(1.234_567e-6, 2.345_679e-6) * f64::from(cell),
            bounds: Aabb { min, max },
        })
    }

    /// The distance from `p` to the surface, up to `reach`.
    fn unsigned(&self, p: Vec3) -> f32 {
        let at = (p / self.cell).floor().as_ivec3();
        let mut nearest = self.cell;
        // A large triangle is filed in many of the 27 cells: each measured once (those
        // seen kept while few, as near a wall of a tank).
        let mut seen = [u32::MAX; 32];
        let mut count = 0;
        for x in -1..=1 {
            for y in -1..=1 {
                for z in -1..=1 {
                    let Some(filed) = self.cells.get(&(at + IVec3::new(x, y, z))) else {
                        continue;
                    };
                    for &i in filed {
                        if seen[..count].contains(&i) {
                            continue;
                        }
                        if count < seen.len() {
                            seen[count] = i;
                            count += 1;
                        }
                        let [a, b, c] = self.corners[i as usize];
                        nearest = nearest.min(point_triangle_distance(p, a, b, c));
                    }
                }
            }
        }
        nearest
    }

    /// Whether `p` is inside: the ray from it in +x crosses the surface an odd number of
    /// times (in f64, from a nudged origin).
    fn inside(&self, p: Vec3) -> bool {
        let column = IVec2::new(
            (p.y / self.cell).floor() as i32,
            (p.z / self.cell).floor() as i32,
        );
        let Some(filed) = self.columns.get(&column) else {
            return false;
        };
        let o = DVec2::new(f64::from(p.y), f64::from(p.z)) + self.nudge;
        let mut crossings = 0;
        for &i in filed {
            let [a, b, c] = self.corners[i as usize].map(|v| v.as_dvec3());
            let (ya, yb, yc) = (a.yz() - o, b.yz() - o, c.yz() - o);
            // The origin inside the triangle's shadow: the three edges turn the same way.
            let (u, v, w) = (ya.perp_dot(yb), yb.perp_dot(yc), yc.perp_dot(ya));
            let area = u + v + w;
            if area == 0.0 || !((u > 0.0 && v > 0.0 && w > 0.0) || (u < 0.0 && v < 0.0 && w < 0.0))
            {
                continue;
            }
            // Where the ray meets the triangle's plane, by the barycentric weights.
            let x = (a.x * v + b.x * w + c.x * u) / area;
            if x > f64::from(p.x) {
                crossings += 1;
            }
        }
        crossings % 2 == 1
    }
}

/// The edges of `triangles` not shared by exactly two of them.
fn open_edges(triangles: &[[u32; 3]]) -> usize {
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    uses.values().filter(|&&n| n != 2).count()
}

impl Target for MeshShape {
    fn distance(&self, p: Vec3) -> f32 {
        let d = self.unsigned(p);
        match self.inside(p) {
            true => -d,
            false => d,
        }
    }
    fn inside(&self, p: Vec3) -> bool {
        MeshShape::inside(self, p)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    /// The cells its triangles pass through.
    fn surface_parts(&self) -> Vec<Aabb> {
        let mut cells: Vec<IVec3> = self.cells.keys().copied().collect();
        cells.sort_unstable_by_key(|k| k.to_array());
        cells
            .into_iter()
            .map(|k| Aabb {
                min: k.as_vec3() * self.cell,
                max: (k + 1).as_vec3() * self.cell,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box's twelve triangles, outward.
    fn cube(lo: Vec3, hi: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let corners = (0..8)
            .map(|c| Vec3::select(glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0), hi, lo))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles = quads
            .iter()
            .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
            .collect();
        (corners, triangles)
    }

    #[test]
    fn a_box_is_its_signed_distance_within_reach() {
        let (lo, hi) = (Vec3::new(-0.5, -0.25, 0.0), Vec3::new(0.5, 0.0, 1.0));
        let (positions, triangles) = cube(lo, hi);
        let reach = 0.1;
        let shape = MeshShape::new(&positions, &triangles, reach).unwrap();
        let exact = crate::target::BoxShape {
            center: 0.5 * (lo + hi),
            half_size: 0.5 * (hi - lo),
        };
        // On a lattice that lands on the box's faces, edges and corners (the floor's top
        // at y = 0), as a skin's nodes do.
        for i in -30..=30 {
            for j in -20..=10 {
                for k in -5..=55 {
                    let p = Vec3::new(i as f32, j as f32, k as f32) * 0.02;
                    let want = exact.distance(p).clamp(-reach, reach);
                    let got = shape.distance(p);
                    assert!((got - want).abs() < 1e-5, "{p}: {got} against {want}");
                }
            }
        }
    }

    #[test]
    fn an_open_mesh_is_refused() {
        let (positions, mut triangles) = cube(Vec3::ZERO, Vec3::ONE);
        triangles.pop();
        let open = MeshShape::new(&positions, &triangles, 0.1).err().unwrap();
        assert_eq!(open.open, 3);
    }
}
