//! Indexed triangle meshes: measures (area, enclosed volume, Euler characteristic,
//! components), topology checks, OBJ / binary PLY writers and an OBJ reader.

use std::io::Write;
use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

mod check;
mod nearest;

pub use check::MeshCheck;
pub(crate) use nearest::point_triangle_distance;
pub use nearest::{hausdorff, mean_distance, TriangleIndex};

#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// World-space positions.
    pub positions: Vec<Vec3>,
    /// Unit outward normals, one per position.
    pub normals: Vec<Vec3>,
    /// Counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// Why a mesh could not be written or read.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct MeshError {
    pub path: std::path::PathBuf,
    pub message: String,
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
        let mut parent: Vec<u32> = (0..self.positions.len() as u32).collect();
        fn root(parent: &mut [u32], mut i: u32) -> u32 {
            while parent[i as usize] != i {
                let p = parent[parent[i as usize] as usize];
                parent[i as usize] = p;
                i = p;
            }
            i
        }
        for t in &self.triangles {
            let a = root(&mut parent, t[0]);
            for &v in &t[1..] {
                let b = root(&mut parent, v);
                parent[b as usize] = a;
            }
        }
        let mut used = vec![false; self.positions.len()];
        for t in &self.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        (0..self.positions.len() as u32)
            .filter(|&i| used[i as usize] && root(&mut parent, i) == i)
            .count()
    }

    /// Wavefront OBJ with normals, through a temporary file renamed into place. The text
    /// is formatted in parallel chunks, then written in order.
    pub fn write_obj(&self, path: &Path) -> Result<(), MeshError> {
        const CHUNK: usize = 1 << 16;
        // ryu and itoa: shortest round-trip text, several times faster than `Display`
        // (the OBJ was a tenth of a particle frame's time).
        let vertices = obj_vectors("v", &self.positions, CHUNK);
        let normals = obj_vectors("vn", &self.normals, CHUNK);
        let faces = self.triangles.par_chunks(CHUNK).map(|chunk| {
            let mut s = String::with_capacity(chunk.len() * 40);
            let mut buffer = itoa::Buffer::new();
            for t in chunk {
                s.push('f');
                for i in t.map(|i| i + 1) {
                    let i = buffer.format(i);
                    s.push(' ');
                    s.push_str(i);
                    s.push_str("//");
                    s.push_str(i);
                }
                s.push('\n');
            }
            s
        });
        let text: Vec<String> = vertices.chain(normals).chain(faces).collect();
        self.write_with(path, |w| {
            writeln!(w, "# activeskin {}", env!("CARGO_PKG_VERSION"))?;
            for part in &text {
                w.write_all(part.as_bytes())?;
            }
            Ok(())
        })
    }

    /// Binary little-endian PLY with normals, its body laid out in parallel.
    pub fn write_ply(&self, path: &Path) -> Result<(), MeshError> {
        self.write_with(path, |w| {
            write!(
                w,
                "ply\nformat binary_little_endian 1.0\ncomment activeskin {}\n\
                 element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
                 property float nx\nproperty float ny\nproperty float nz\n\
                 element face {}\nproperty list uchar int vertex_indices\nend_header\n",
                env!("CARGO_PKG_VERSION"),
                self.positions.len(),
                self.triangles.len()
            )?;
            write_records(w, &self.positions, 24, |i, p, out| {
                let n = self.normals[i];
                for (k, v) in [p.x, p.y, p.z, n.x, n.y, n.z].into_iter().enumerate() {
                    out[4 * k..4 * k + 4].copy_from_slice(&v.to_le_bytes());
                }
            })?;
            write_records(w, &self.triangles, 13, |_, t, out| {
                out[0] = 3;
                for (k, &i) in t.iter().enumerate() {
                    out[1 + 4 * k..5 + 4 * k].copy_from_slice(&(i as i32).to_le_bytes());
                }
            })
        })
    }

    /// A Wavefront OBJ's vertices and faces (other records skipped; polygons fanned into
    /// triangles), as other tools write them; no normals.
    pub fn read_obj(path: &Path) -> Result<Mesh, MeshError> {
        let error = |message: String| MeshError {
            path: path.to_path_buf(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| error(e.to_string()))?;
        let mut mesh = Mesh::default();
        for (number, line) in text.lines().enumerate() {
            let bad = || error(format!("line {}: cannot read '{line}'", number + 1));
            let mut words = line.split_whitespace();
            match words.next() {
                Some("v") => {
                    let v: Vec<f32> = words
                        .take(3)
                        .map(|w| w.parse().map_err(|_| bad()))
                        .collect::<Result<_, _>>()?;
                    if v.len() < 3 {
                        return Err(bad());
                    }
                    mesh.positions.push(Vec3::new(v[0], v[1], v[2]));
                }
                Some("f") => {
                    let face: Vec<u32> = words
                        .map(|w| {
                            let i: u32 = w.split('/').next()?.parse().ok()?;
                            (1..=mesh.positions.len() as u32)
                                .contains(&i)
                                .then(|| i - 1)
                        })
                        .collect::<Option<_>>()
                        .ok_or_else(bad)?;
                    if face.len() < 3 {
                        return Err(bad());
                    }
                    for k in 1..face.len() - 1 {
                        mesh.triangles.push([face[0], face[k], face[k + 1]]);
                    }
                }
                _ => {}
            }
        }
        Ok(mesh)
    }

    /// OBJ or PLY by the file's extension.
    pub fn write(&self, path: &Path) -> Result<(), MeshError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
        {
            Some(e) if e == "obj" => self.write_obj(path),
            Some(e) if e == "ply" => self.write_ply(path),
            _ => Err(MeshError {
                path: path.into(),
                message: "mesh files must end in .obj or .ply".into(),
            }),
        }
    }

    fn write_with(
        &self,
        path: &Path,
        body: impl FnOnce(&mut (dyn Write + Send)) -> std::io::Result<()>,
    ) -> Result<(), MeshError> {
        crate::io::write_atomically(path, |tmp| {
            let file = crate::io::EagerWriteback::create(tmp).map_err(|e| e.to_string())?;
            let mut w = std::io::BufWriter::new(file);
            body(&mut w)
                .and_then(|()| w.flush())
                .map_err(|e| e.to_string())?;
            w.get_ref().sync().map_err(|e| e.to_string())
        })
        .map_err(|message| MeshError {
            path: path.into(),
            message,
        })
    }
}

/// OBJ records `tag x y z`, one per item, `chunk` items to a string, in parallel.
fn obj_vectors<'a>(
    tag: &'static str,
    items: &'a [Vec3],
    chunk: usize,
) -> impl IndexedParallelIterator<Item = String> + 'a {
    items.par_chunks(chunk).map(move |chunk| {
        let mut s = String::with_capacity(chunk.len() * 40);
        let mut buffer = ryu::Buffer::new();
        for p in chunk {
            s.push_str(tag);
            for v in [p.x, p.y, p.z] {
                s.push(' ');
                s.push_str(buffer.format(v));
            }
            s.push('\n');
        }
        s
    })
}

/// Writes `items` as fixed-size binary records of `size` bytes, each laid out by `record`
/// (index, item, its bytes), a chunk at a time in parallel.
fn write_records<T: Sync>(
    w: &mut (dyn Write + Send),
    items: &[T],
    size: usize,
    record: impl Fn(usize, &T, &mut [u8]) + Sync,
) -> std::io::Result<()> {
    const CHUNK: usize = 1 << 16;
    let encode = |c: usize, chunk: &[T], buffer: &mut Vec<u8>| {
        buffer.resize(chunk.len() * size, 0);
        buffer
            .par_chunks_mut(size)
            .zip(chunk)
            .enumerate()
            .for_each(|(i, (out, item))| record(c * CHUNK + i, item, out));
    };
    // One chunk is written while the next is laid out.
    let mut chunks = items.chunks(CHUNK).enumerate();
    let (mut ready, mut next) = (Vec::new(), Vec::new());
    let Some((c, chunk)) = chunks.next() else {
        return Ok(());
    };
    encode(c, chunk, &mut ready);
    for (c, chunk) in chunks {
        let (written, ()) = rayon::join(|| w.write_all(&ready), || encode(c, chunk, &mut next));
        written?;
        std::mem::swap(&mut ready, &mut next);
    }
    w.write_all(&ready)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_round_trips_and_bad_records_are_errors() {
        let dir = std::env::temp_dir().join(format!("activeskin-obj-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.25, 0.5, 1.0)],
            normals: vec![Vec3::Z; 4],
            triangles: vec![[0, 1, 2], [0, 3, 1]],
        };
        let path = dir.join("m.obj");
        mesh.write_obj(&path).unwrap();
        let back = Mesh::read_obj(&path).unwrap();
        assert_eq!(back.positions, mesh.positions);
        assert_eq!(back.triangles, mesh.triangles);
        // A quad is fanned; an index past the vertices is an error naming the line.
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        assert_eq!(
            Mesh::read_obj(&path).unwrap().triangles,
            vec![[0, 1, 2], [0, 2, 3]]
        );
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nf 1 2 5\n").unwrap();
        let e = Mesh::read_obj(&path).unwrap_err().to_string();
        assert!(e.contains("line 3"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

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
