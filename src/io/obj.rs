//! Wavefront OBJ: meshes written with normals (formatted in parallel chunks, written in
//! order) and read as other tools write them.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use super::mesh_write::{write_with, MeshError, MeshFault};
use crate::mesh::Mesh;

/// Wavefront OBJ with normals, through a temporary file renamed into place. The text
/// is formatted in parallel chunks, then written in order.
pub fn write(mesh: &Mesh, path: &Path) -> Result<(), MeshError> {
    const CHUNK: usize = 1 << 16;
    // ryu and itoa: shortest round-trip text, several times faster than `Display`
    // (the OBJ was a tenth of a particle frame's time).
    let vertices = obj_vectors("v", &mesh.positions, CHUNK);
    let normals = obj_vectors("vn", &mesh.normals, CHUNK);
    let faces = mesh.triangles.par_chunks(CHUNK).map(|chunk| {
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
    write_with(path, |w| {
        writeln!(w, "# activeskin {}", env!("CARGO_PKG_VERSION"))?;
        for part in &text {
            w.write_all(part.as_bytes())?;
        }
        Ok(())
    })
}

/// A Wavefront OBJ's vertices and faces (other records skipped; polygons fanned into
/// triangles), as other tools write them; no normals.
pub fn read(path: &Path) -> Result<Mesh, MeshError> {
    let text = std::fs::read_to_string(path).map_err(|e| MeshError::new(path, e))?;
    let mut mesh = Mesh::default();
    for (number, line) in text.lines().enumerate() {
        let bad = || {
            let record = MeshFault::Record {
                line: number + 1,
                text: line.to_string(),
            };
            MeshError::new(path, record)
        };
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
        write(&mesh, &path).unwrap();
        let back = read(&path).unwrap();
        assert_eq!(back.positions, mesh.positions);
        assert_eq!(back.triangles, mesh.triangles);
        // A quad is fanned; an index past the vertices is an error naming the line.
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        assert_eq!(read(&path).unwrap().triangles, vec![[0, 1, 2], [0, 2, 3]]);
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nf 1 2 5\n").unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.contains("line 3"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
