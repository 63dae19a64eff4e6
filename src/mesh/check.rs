//! Whether a mesh is a clean surface, as booleans, subdivision and remeshers need it: every
//! edge in exactly two triangles traversed in opposite directions, one fan of triangles
//! around each vertex, no two triangles on the same three points, no triangle of zero
//! area, and wound outward (positive enclosed volume).

use glam::DVec3;
use rayon::prelude::*;

use super::Mesh;

/// What [`Mesh::check`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MeshCheck {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// Undirected edges not in exactly two triangles of opposite directions.
    pub open_edges: usize,
    /// Of the open edges, those in one triangle only: a boundary (a mesh cut to a
    /// region ends there).
    pub boundary_edges: usize,
    /// Vertices whose triangles form more than one fan, open or closed (a mesh with a
    /// boundary; 0 when an edge is in more than two triangles or two of one direction).
    pub boundary_pinched: usize,
    /// Vertices whose triangles form more than one fan (or an open one).
    pub pinched_vertices: usize,
    /// Triangles on the same three points as another (by index or by position).
    pub coincident: usize,
    /// Triangles of zero area (two corners at one point, or three on a line).
    pub degenerate: usize,
    /// Enclosed volume ≤ 0 for a non-empty mesh: wound inside out.
    pub inward: bool,
}

impl MeshCheck {
    /// Closed: each edge in two triangles, in opposite directions.
    pub fn closed(&self) -> bool {
        self.open_edges == 0
    }

    /// Closed with one fan around each vertex.
    pub fn manifold(&self) -> bool {
        self.closed() && self.pinched_vertices == 0
    }

    /// Manifold but for a boundary: each edge in two triangles of opposite directions or
    /// in one, one fan (closed, or open at the boundary) around each vertex.
    pub fn manifold_with_boundary(&self) -> bool {
        self.open_edges == self.boundary_edges && self.boundary_pinched == 0
    }

    /// [`MeshCheck::is_clean`] but for a boundary (a mesh cut to a region): manifold with
    /// it, nothing coincident or degenerate (an open mesh has no inside to wind).
    pub fn is_clean_with_boundary(&self) -> bool {
        self.manifold_with_boundary() && self.coincident == 0 && self.degenerate == 0
    }

    /// Everything a downstream tool relies on.
    pub fn is_clean(&self) -> bool {
        self.manifold() && self.coincident == 0 && self.degenerate == 0 && !self.inward
    }
}

impl std::fmt::Display for MeshCheck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_clean() {
            return write!(f, "clean ({} triangles)", self.triangles);
        }
        let mut problems = Vec::new();
        for (n, what) in [
            (
                self.open_edges,
                "edges not in exactly two opposite triangles",
            ),
            (self.pinched_vertices, "vertices with more than one fan"),
            (self.coincident, "coincident triangles"),
            (self.degenerate, "zero-area triangles"),
        ] {
            if n > 0 {
                problems.push(format!("{n} {what}"));
            }
        }
        if self.inward {
            problems.push("wound inward".into());
        }
        write!(f, "{} ({} triangles)", problems.join(", "), self.triangles)
    }
}

impl Mesh {
    /// Checks the mesh; see [`MeshCheck`]. Sorted lists rather than hash sets: a few
    /// parallel sorts over millions of triangles.
    pub fn check(&self) -> MeshCheck {
        // An edge is closed when its triangles are exactly one pair running it opposite ways.
        let edges = self.sorted_edges();
        let runs = || edges.chunk_by(|a, b| a.0 == b.0);
        let open = runs()
            .filter(|run| !(run.len() == 2 && run[0].1 != run[1].1))
            .count();
        let boundary = runs().filter(|run| run.len() == 1).count();

        // Coincident: the same three indices, or the same three points, as a triangle
        // before it.
        let mut marked = vec![false; self.triangles.len()];
        let mut by_index: Vec<([u32; 3], u32)> = self
            .triangles
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let mut sorted = *t;
                sorted.sort_unstable();
                (sorted, i as u32)
            })
            .collect();
        by_index.par_sort_unstable();
        mark_repeats(&by_index, &mut marked);
        let mut by_position: Vec<([[u32; 3]; 3], u32)> = self
            .triangles
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let mut points = t.map(|v| self.positions[v as usize].to_array().map(f32::to_bits));
                points.sort_unstable();
                (points, i as u32)
            })
            .collect();
        by_position.par_sort_unstable();
        mark_repeats(&by_position, &mut marked);
        let coincident = marked.iter().filter(|&&m| m).count();
        let degenerate = self
            .triangles
            .par_iter()
            .filter(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize].as_dvec3());
                (b - a).cross(c - a) == DVec3::ZERO
            })
            .count();

        MeshCheck {
            triangles: self.triangles.len(),
            open_edges: open,
            pinched_vertices: if open == 0 {
                // Closed: one fan each, and none open.
                self.fans()
                    .filter(|&(fans, open)| fans != 1 || open)
                    .count()
            } else {
                0
            },
            boundary_edges: boundary,
            boundary_pinched: if open == boundary {
                self.fans().filter(|&(fans, _)| fans > 1).count()
            } else {
                0
            },
            coincident,
            degenerate,
            inward: !self.triangles.is_empty() && self.volume() <= 0.0,
        }
    }

    /// Every triangle's edges as (min·2³² + max, runs min → max), sorted.
    pub(super) fn sorted_edges(&self) -> Vec<(u64, bool)> {
        let mut edges: Vec<(u64, bool)> = self
            .triangles
            .par_iter()
            .flat_map_iter(|t| {
                (0..3).map(move |i| {
                    let (a, b) = (t[i], t[(i + 1) % 3]);
                    ((u64::from(a.min(b)) << 32) | u64::from(a.max(b)), a < b)
                })
            })
            .collect();
        edges.par_sort_unstable();
        edges
    }

    /// The vertices on a boundary: on an edge of one triangle only.
    pub fn boundary_vertices(&self) -> Vec<u32> {
        let mut ends: Vec<u32> = self
            .sorted_edges()
            .chunk_by(|a, b| a.0 == b.0)
            .filter(|run| run.len() == 1)
            .flat_map(|run| [(run[0].0 >> 32) as u32, run[0].0 as u32])
            .collect();
        ends.sort_unstable();
        ends.dedup();
        ends
    }

    /// Around each used vertex of a mesh whose edges are in at most two triangles of
    /// opposite directions: how many fans its triangles form, and whether one is open.
    fn fans(&self) -> impl Iterator<Item = (usize, bool)> {
        // Around t[i], triangle t leads from neighbour t[i+1] to t[i+2]: a fan is a chain
        // of these, open where a neighbour leads nowhere.
        let mut around: Vec<(u32, u32, u32)> = Vec::with_capacity(self.triangles.len() * 3);
        for t in &self.triangles {
            for i in 0..3 {
                around.push((t[i], t[(i + 1) % 3], t[(i + 2) % 3]));
            }
        }
        around.sort_unstable();
        let mut counts = Vec::new();
        for fan in around.chunk_by(|a, b| a.0 == b.0) {
            // Chains start at a neighbour no triangle leads to (open fans), then the
            // cycles left (closed ones).
            let leads_to: Vec<u32> = {
                let mut to: Vec<u32> = fan.iter().map(|&(_, _, b)| b).collect();
                to.sort_unstable();
                to
            };
            let mut seen = vec![false; fan.len()];
            let (mut fans, mut open) = (0, false);
            let starts = fan
                .iter()
                .enumerate()
                .filter(|(_, &(_, a, _))| leads_to.binary_search(&a).is_err())
                .map(|(i, _)| (i, true))
                .chain((0..fan.len()).map(|i| (i, false)));
            for (start, is_open) in starts {
                if seen[start] {
                    continue;
                }
                fans += 1;
                open |= is_open;
                let mut at = fan[start].1;
                while let Ok(i) = fan.binary_search_by_key(&at, |&(_, a, _)| a) {
                    if seen[i] {
                        break;
                    }
                    seen[i] = true;
                    at = fan[i].2;
                }
            }
            counts.push((fans, open));
        }
        counts.into_iter()
    }
}

/// Marks every entry of a sorted list but the first of each run of equal keys.
fn mark_repeats<K: PartialEq>(sorted: &[(K, u32)], marked: &mut [bool]) {
    for run in sorted.chunk_by(|a, b| a.0 == b.0) {
        for (_, i) in &run[1..] {
            marked[*i as usize] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn tetrahedron() -> Mesh {
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            normals: vec![Vec3::ZERO; 4],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        }
    }

    #[test]
    fn a_tetrahedron_is_clean_and_each_defect_is_named() {
        let clean = tetrahedron();
        assert!(clean.check().is_clean(), "{}", clean.check());

        let mut inward = tetrahedron();
        inward.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        assert!(inward.check().inward && inward.check().manifold());

        // A fin: one triangle twice, once each way round.
        let mut fin = tetrahedron();
        fin.triangles.extend([[0, 1, 3], [0, 3, 1]]);
        let check = fin.check();
        assert_eq!(check.coincident, 2);
        assert!(!check.closed(), "{check}");

        let mut open = tetrahedron();
        open.triangles.pop();
        assert_eq!(open.check().open_edges, 3);

        let mut flat = tetrahedron();
        flat.positions[3] = Vec3::new(0.5, 0.5, 0.0);
        assert!(flat.check().degenerate > 0);

        // Two tetrahedra sharing one vertex: closed, not manifold there.
        let mut pinched = tetrahedron();
        pinched.positions.extend([
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(0.0, 0.0, -1.0),
        ]);
        pinched
            .triangles
            .extend([[0, 4, 5], [0, 6, 4], [0, 5, 6], [4, 6, 5]]);
        let check = pinched.check();
        assert!(check.closed() && check.pinched_vertices == 1, "{check}");

        // Open meshes: a tetrahedron without a face is manifold with its boundary (three
        // edges, each vertex one fan); two such sharing a vertex are not, nor is a fin.
        assert!(open.check().manifold_with_boundary() && !open.check().manifold());
        assert_eq!(open.boundary_vertices(), vec![1, 2, 3]);
        assert_eq!(open.check().boundary_edges, 3);
        let mut two = pinched.clone();
        two.triangles.retain(|t| *t != [1, 2, 3] && *t != [4, 6, 5]);
        let check = two.check();
        assert_eq!(
            (check.boundary_edges, check.boundary_pinched),
            (6, 1),
            "{check}"
        );
        assert!(!check.manifold_with_boundary());
        assert!(!fin.check().manifold_with_boundary());
        assert!(clean.check().manifold_with_boundary());
    }
}
