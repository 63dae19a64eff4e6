//! The 256 marching-cubes cases, built once from one face rule and triangulated so that no
//! two cubes can emit the same triangle.
//!
//! Cube corners and edges (corner c sits at (c & 1, c >> 1 & 1, c >> 2 & 1)):
//!
//! ```text
//!         6-----11-------7            edges by axis
//!        /|             /|            x:  0 (0-1)  1 (2-3)  2 (4-5)  3 (6-7)
//!       6 |            7 |            y:  4 (0-2)  5 (1-3)  6 (4-6)  7 (5-7)
//!      /  10          /  11           z:  8 (0-4)  9 (1-5) 10 (2-6) 11 (3-7)
//!     4------2-------5   |
//!     |   |          |   |      z
//!     |   2------1---|---3      |  y
//!     8  /           9  /       | /
//!     | 4            | 5        |/
//!     |/             |/         +---- x
//!     0------0-------1
//! ```
//!
//! **Loops.** Walking a face counter-clockwise seen from outside the cube, a crossing from
//! an inside corner (φ < 0) to an outside one is an *exit*, the reverse an *entry*; every
//! entry is joined to the next exit. That one rule separates inside corners on ambiguous
//! faces the same way from both cubes sharing the face, so the surface is closed; and each
//! crossing is an entry on one of its faces and an exit on the other, so the segments chain
//! into loops wound with the normal pointing outward (toward φ > 0).
//!
//! **Triangles.** A loop of n crossings needs n − 3 diagonals. A diagonal between two
//! crossings on one face would lie in that face, where the neighbouring cube may draw the
//! same one: the two triangles then coincide with opposite windings (a fin) and their edges
//! belong to four triangles. So every diagonal here joins crossings on no common face,
//! which keeps each triangle strictly inside its cube except for its loop segments.

use std::sync::OnceLock;

/// Corners of each edge, ordered along its axis.
pub const EDGE_CORNERS: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// Faces as corner cycles, counter-clockwise seen from outside: -x +x -y +y -z +z.
const FACES: [[usize; 4]; 6] = [
    [0, 4, 6, 2],
    [1, 3, 7, 5],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 2, 3, 1],
    [4, 5, 7, 6],
];

/// Position of corner c relative to the cube's lower corner.
pub const fn corner_offset(c: usize) -> glam::IVec3 {
    glam::IVec3::new((c & 1) as i32, ((c >> 1) & 1) as i32, ((c >> 2) & 1) as i32)
}

/// Axis of an edge.
pub const fn edge_axis(e: usize) -> usize {
    e / 4
}

const fn edge_between(a: usize, b: usize) -> usize {
    let mut e = 0;
    while e < 12 {
        let (p, q) = EDGE_CORNERS[e];
        if (p == a && q == b) || (p == b && q == a) {
            return e;
        }
        e += 1;
    }
    panic!("corners are not adjacent");
}

/// Edge index of each face side (corner i to corner i+1 of `FACES`).
const FACE_EDGES: [[usize; 4]; 6] = {
    let mut t = [[0; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            t[f][i] = edge_between(FACES[f][i], FACES[f][(i + 1) % 4]);
            i += 1;
        }
        f += 1;
    }
    t
};

/// Bit f set when edge e lies on face f.
const EDGE_FACES: [u8; 12] = {
    let mut t = [0u8; 12];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            t[FACE_EDGES[f][i]] |= 1 << f;
            i += 1;
        }
        f += 1;
    }
    t
};

/// Whether two edges lie on a common face of the cube.
const fn share_face(a: usize, b: usize) -> bool {
    EDGE_FACES[a] & EDGE_FACES[b] != 0
}

/// Most triangles a case has (the face rule gives at most 12 crossings, in at least one
/// loop of at least 3).
pub const MAX_TRIANGLES: usize = 10;

/// The triangles of one sign case, as edge triples, counter-clockwise seen from outside.
#[derive(Clone, Copy)]
pub struct Case {
    /// How many of `triangles` are used.
    pub len: u8,
    /// Each triangle's three crossed edges.
    pub triangles: [[u8; 3]; MAX_TRIANGLES],
}

impl Case {
    pub fn triangles(&self) -> &[[u8; 3]] {
        &self.triangles[..self.len as usize]
    }
}

/// The case of each sign pattern: bit c of the index set when corner c is inside.
pub fn table() -> &'static [Case; 256] {
    static TABLE: OnceLock<[Case; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|signs| build_case(signs as u8)))
}

/// The loops of a sign case as cycles of crossed edges (the face rule above).
pub fn loops(signs: u8) -> Vec<Vec<u8>> {
    let is_in = |c: usize| signs >> c & 1 == 1;
    // next[e] = the edge that follows crossed edge e along its loop.
    let mut next = [u8::MAX; 12];
    for (face, edges) in FACES.iter().zip(FACE_EDGES.iter()) {
        let mut events = [(0u8, false); 4];
        let mut n = 0;
        for i in 0..4 {
            let (a, b) = (face[i], face[(i + 1) % 4]);
            if is_in(a) != is_in(b) {
                events[n] = (edges[i] as u8, is_in(b));
                n += 1;
            }
        }
        for i in 0..n {
            let (edge, entry) = events[i];
            if entry {
                next[edge as usize] = events[(i + 1) % n].0;
            }
        }
    }
    let mut done = [false; 12];
    let mut out = Vec::new();
    for start in 0..12 {
        if next[start] == u8::MAX || done[start] {
            continue;
        }
        let mut lp = Vec::new();
        let mut e = start;
        while !done[e] {
            done[e] = true;
            lp.push(e as u8);
            e = next[e] as usize;
        }
        out.push(lp);
    }
    out
}

fn build_case(signs: u8) -> Case {
    let mut case = Case {
        len: 0,
        triangles: [[0; 3]; MAX_TRIANGLES],
    };
    for lp in loops(signs) {
        let triangles = triangulate(&lp).unwrap_or_else(|| {
            panic!("case {signs:#010b}: loop {lp:?} has no face-free triangulation")
        });
        for t in triangles {
            case.triangles[case.len as usize] = t;
            case.len += 1;
        }
    }
    case
}

/// A triangulation of the polygon `p` (edges in loop order) whose diagonals join edges on
/// no common face, preferring fans from early vertices; `None` if there is none.
fn triangulate(p: &[u8]) -> Option<Vec<[u8; 3]>> {
    let n = p.len();
    if n < 3 {
        return None;
    }
    if n == 3 {
        return Some(vec![[p[0], p[1], p[2]]]);
    }
    let ok = |a: u8, b: u8| !share_face(a as usize, b as usize);
    // The side p0–p1 belongs to one triangle (p0, p1, pk); the rest splits in two.
    for k in 2..n {
        if (k != 2 && !ok(p[1], p[k])) || (k != n - 1 && !ok(p[k], p[0])) {
            continue;
        }
        let left: Vec<u8> = p[1..=k].to_vec();
        let right: Vec<u8> = p[k..].iter().chain(&p[..1]).copied().collect();
        let left = if left.len() >= 3 {
            triangulate(&left)
        } else {
            Some(Vec::new())
        };
        let right = if right.len() >= 3 {
            triangulate(&right)
        } else {
            Some(Vec::new())
        };
        if let (Some(mut left), Some(right)) = (left, right) {
            left.push([p[0], p[1], p[k]]);
            left.extend(right);
            return Some(left);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Edges of a triangle, as unordered pairs.
    fn sides(t: [u8; 3]) -> [(u8, u8); 3] {
        [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])].map(|(a, b)| (a.min(b), a.max(b)))
    }

    #[test]
    fn every_case_is_a_set_of_closed_outward_loops_with_no_triangle_in_a_face() {
        for signs in 0..=255u8 {
            let case = &table()[signs as usize];
            let crossed: Vec<u8> = (0..12u8)
                .filter(|&e| {
                    let (a, b) = EDGE_CORNERS[e as usize];
                    (signs >> a & 1) != (signs >> b & 1)
                })
                .collect();
            // Each crossed edge is used; each loop is a disc: n − 2 triangles.
            let loops = loops(signs);
            let in_loops: usize = loops.iter().map(Vec::len).sum();
            assert_eq!(in_loops, crossed.len(), "{signs:#010b}");
            let expected: usize = loops.iter().map(|l| l.len() - 2).sum();
            assert_eq!(case.triangles().len(), expected, "{signs:#010b}");
            for t in case.triangles() {
                // No triangle lies in a face: its three edges share no face.
                let common = EDGE_FACES[t[0] as usize]
                    & EDGE_FACES[t[1] as usize]
                    & EDGE_FACES[t[2] as usize];
                assert_eq!(common, 0, "{signs:#010b}: {t:?} lies in a face");
                // A side joining two crossings of one face is a loop segment.
                for (a, b) in sides(*t) {
                    if share_face(a as usize, b as usize) {
                        let segment = loops.iter().any(|l| {
                            (0..l.len()).any(|i| {
                                let (p, q) = (l[i], l[(i + 1) % l.len()]);
                                (p.min(q), p.max(q)) == (a, b)
                            })
                        });
                        assert!(segment, "{signs:#010b}: {t:?} has a diagonal in a face");
                    }
                }
            }
            // Inside the cube, each diagonal has two triangles and each segment one.
            let mut count = std::collections::HashMap::new();
            for t in case.triangles() {
                for s in sides(*t) {
                    *count.entry(s).or_insert(0) += 1;
                }
            }
            for (s, n) in count {
                let on_face = share_face(s.0 as usize, s.1 as usize);
                assert_eq!(n, if on_face { 1 } else { 2 }, "{signs:#010b}: side {s:?}");
            }
        }
    }

    #[test]
    fn triangles_face_away_from_the_inside_corners() {
        let corner = |c: usize| [c & 1, c >> 1 & 1, c >> 2 & 1].map(|v| v as f32);
        let midpoint = |e: u8| {
            let (a, b) = EDGE_CORNERS[e as usize];
            let (a, b) = (corner(a), corner(b));
            [0, 1, 2].map(|i| 0.5 * (a[i] + b[i]))
        };
        let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        for signs in 1..=254u8 {
            for t in table()[signs as usize].triangles() {
                let [p, q, r] = t.map(midpoint);
                let (u, v) = (sub(q, p), sub(r, p));
                let normal = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                // Along each crossed edge, from its inside corner to its outside one.
                let outward: f32 = t
                    .iter()
                    .map(|&e| {
                        let (a, b) = EDGE_CORNERS[e as usize];
                        let (i, o) = if signs >> a & 1 == 1 { (a, b) } else { (b, a) };
                        dot(normal, sub(corner(o), corner(i)))
                    })
                    .sum();
                assert!(outward > 0.0, "{signs:#010b}: {t:?} faces inward");
            }
        }
    }
}
