//! Evening a marching-cubes mesh's triangles without moving its surface: marching cubes
//! puts each vertex where the surface crosses a grid edge, so its triangles are slivers
//! and fans whose normals turn from one to the next by a degree or more even on an exact
//! sphere, which a renderer's shading shows as facets. Each step moves every vertex
//! along the surface towards the mean of its neighbours (the tangential part of the
//! umbrella Laplacian only, so that nothing shrinks) and back onto the implicit surface
//! by a Newton step on its value.

use glam::Vec3;
use rayon::prelude::*;

use super::Mesh;

/// Each step's share of the way to the neighbours' mean, along the surface: below 1 so
/// that a vertex never overshoots a neighbour.
const SHARE: f32 = 0.5;

/// An implicit surface a mesh was made from, read near each vertex's first place.
pub trait Surface: Sync {
    /// Scratch one thread reads the surface with (a cache of what is around).
    type Probe: Send;
    fn probe(&self) -> Self::Probe;
    /// The surface's value (zero on it) and gradient at `p`, near `home`; `None` where
    /// it is not known.
    fn value_and_gradient(
        &self,
        probe: &mut Self::Probe,
        home: Vec3,
        p: Vec3,
    ) -> Option<(f32, Vec3)>;
    /// The unit normal a renderer should shade with at `p`, near `home`.
    fn normal(&self, probe: &mut Self::Probe, home: Vec3, p: Vec3) -> Option<Vec3>;
}

/// Evens `mesh`'s triangles over `steps` steps, keeping its vertices on `surface`. A
/// vertex stays where it is where the surface is unknown or flat, or where its move
/// would take it further than `reach` from where it was (the surface there is not the
/// one the mesh was made from). The normals are then the surface's at the vertices' new
/// places; the connectivity is untouched.
pub fn relax_on_surface(mesh: &mut Mesh, (steps, reach): (usize, f32), surface: &impl Surface) {
    if steps == 0 || mesh.triangles.is_empty() {
        return;
    }
    let neighbours = Neighbours::of(mesh);
    let home = mesh.positions.clone();
    let mut next = mesh.positions.clone();
    // The tangent plane: the normals the mesh came with, then the surface's gradient.
    let mut tangent = mesh.normals.clone();
    let mut before = tangent.clone();
    for _ in 0..steps {
        before.copy_from_slice(&tangent);
        let positions = &mesh.positions;
        next.par_iter_mut()
            .zip(tangent.par_iter_mut())
            .enumerate()
            .for_each_init(
                || surface.probe(),
                |probe, (i, (out, n))| {
                    let p = positions[i];
                    let around = neighbours.of_vertex(i);
                    if around.is_empty() {
                        return;
                    }
                    let mean = around.iter().map(|&j| positions[j as usize]).sum::<Vec3>()
                        / around.len() as f32;
                    let pull = mean - p;
                    let moved = p + SHARE * (pull - *n * n.dot(pull));
                    let Some((value, gradient)) = surface.value_and_gradient(probe, home[i], moved)
                    else {
                        return;
                    };
                    let slope = gradient.length_squared();
                    if slope > 1e-12 {
                        // One Newton step back onto the surface.
                        let q = moved - gradient * (value / slope);
                        if q.distance_squared(home[i]) <= reach * reach {
                            *out = q;
                            *n = gradient / slope.sqrt();
                        }
                    }
                },
            );
        undo_folds(
            &mesh.triangles,
            (&mesh.positions, &before),
            (&mut next, &mut tangent),
        );
        mesh.positions.copy_from_slice(&next);
    }
    let positions = &mesh.positions;
    mesh.normals.par_iter_mut().enumerate().for_each_init(
        || surface.probe(),
        |probe, (i, n)| {
            if let Some(normal) = surface.normal(probe, home[i], positions[i]) {
                *n = normal;
            }
        },
    );
}

/// Puts back where they were the corners of each triangle a step turned over (facing
/// against its corners' normals where it did not before), until none is: moving along a
/// thin neck or a sharp rim, a vertex can pass its neighbour. The triangles are checked
/// in parallel against the state a round starts from, the few turned over then undone
/// together (the same whatever the threads).
fn undo_folds(
    triangles: &[[u32; 3]],
    (was, was_normal): (&[Vec3], &[Vec3]),
    (now, now_normal): (&mut [Vec3], &mut [Vec3]),
) {
    let facing = |positions: &[Vec3], normals: &[Vec3], t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n: Vec3 = t.iter().map(|&i| normals[i as usize]).sum();
        (b - a).cross(c - a).dot(n) > 0.0
    };
    loop {
        let folded: Vec<&[u32; 3]> = {
            let (now, now_normal) = (&*now, &*now_normal);
            triangles
                .par_iter()
                .filter(|t| !facing(now, now_normal, t) && facing(was, was_normal, t))
                .collect()
        };
        let mut undone = false;
        for t in folded {
            for &i in t {
                let i = i as usize;
                undone |= now[i] != was[i];
                (now[i], now_normal[i]) = (was[i], was_normal[i]);
            }
        }
        if !undone {
            return;
        }
    }
}

/// Each vertex's neighbours along the mesh's edges, compressed: those of vertex `i` at
/// `list[start[i]..start[i + 1]]`. Each triangle gives each of its corners the next
/// corner, so on a closed oriented mesh (each edge once each way) every neighbour is
/// listed once, with no sorting.
struct Neighbours {
    start: Vec<u32>,
    list: Vec<u32>,
}

impl Neighbours {
    fn of(mesh: &Mesh) -> Self {
        let mut start = vec![0u32; mesh.positions.len() + 1];
        for &i in mesh.triangles.iter().flatten() {
            start[i as usize + 1] += 1;
        }
        for i in 0..mesh.positions.len() {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut list = vec![0u32; 3 * mesh.triangles.len()];
        for t in &mesh.triangles {
            for k in 0..3 {
                let slot = &mut fill[t[k] as usize];
                list[*slot as usize] = t[(k + 1) % 3];
                *slot += 1;
            }
        }
        Neighbours { start, list }
    }

    fn of_vertex(&self, i: usize) -> &[u32] {
        &self.list[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_that_turns_a_triangle_over_is_undone_and_others_are_kept() {
        // A square of two triangles facing +z, and a third beside it.
        let was = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
        ];
        let triangles = [[0, 1, 2], [0, 2, 3], [1, 4, 5]];
        let normals = [Vec3::Z; 6];
        let mut now = was;
        // Vertex 2 pushed past the diagonal turns [0, 2, 3] over; vertex 4 moved a
        // little turns nothing.
        now[2] = Vec3::new(-0.5, 1.5, 0.0);
        now[4] = Vec3::new(2.1, -0.1, 0.0);
        let mut now_normals = normals;
        undo_folds(&triangles, (&was, &normals), (&mut now, &mut now_normals));
        assert_eq!(now[2], was[2]);
        assert_eq!(now[4], Vec3::new(2.1, -0.1, 0.0));
        for t in &triangles {
            let [a, b, c] = t.map(|i| now[i as usize]);
            assert!((b - a).cross(c - a).z > 0.0);
        }
    }
}
