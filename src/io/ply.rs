//! PLY (Stanford polygon files): particle frames read (ASCII, binary little and big
//! endian; `x y z`, velocities, radii and ids by name), particles and meshes written.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use super::file::WriteError;
use super::mesh_write::{write_records, write_with, MeshError, VertexValues};
use super::scalar::Scalar;
use crate::mesh::Mesh;
use crate::particles::{Attribute, Particles};

/// A PLY element: name, count, properties (name, type).
type Element = (String, usize, Vec<(String, String)>);

/// How a PLY file stores its rows.
#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// A scalar type, by PLY's name for it (both spellings).
fn scalar_type(name: &str) -> Option<Scalar> {
    Some(match name {
        "char" | "int8" => Scalar::I8,
        "uchar" | "uint8" => Scalar::U8,
        "short" | "int16" => Scalar::I16,
        "ushort" | "uint16" => Scalar::U16,
        "int" | "int32" => Scalar::I32,
        "uint" | "uint32" => Scalar::U32,
        "float" | "float32" => Scalar::F32,
        "double" | "float64" => Scalar::F64,
        _ => return None,
    })
}

/// A PLY particle file that cannot be read: what is wrong, where (a line, an element).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct PlyError(pub String);

impl From<String> for PlyError {
    fn from(message: String) -> Self {
        PlyError(message)
    }
}

impl From<&str> for PlyError {
    fn from(message: &str) -> Self {
        PlyError(message.to_string())
    }
}

pub(crate) fn read_ply(bytes: &[u8]) -> Result<Particles, PlyError> {
    parse_ply(bytes)
}

fn parse_ply(bytes: &[u8]) -> Result<Particles, PlyError> {
    let (format, elements, body) = parse_header(bytes)?;
    let (index, (_, count, properties)) = elements
        .iter()
        .enumerate()
        .find(|(_, e)| e.0 == "vertex")
        .ok_or("PLY file has no vertex element")?;
    if elements[..index].iter().any(|e| e.1 > 0) {
        return Err("PLY elements before the vertices are not supported".into());
    }
    if properties.iter().any(|p| p.1 == "list") {
        return Err("vertex element has a list property".into());
    }
    let columns = Columns::of(properties)?;
    let data = &bytes[body.min(bytes.len())..];
    let rows = match format {
        Encoding::Ascii => read_ascii(data, *count, properties.len(), &columns)?,
        Encoding::Little | Encoding::Big => {
            read_binary(data, *count, properties, &columns, format == Encoding::Big)?
        }
    };
    Ok(Particles {
        positions: rows.positions,
        radii: rows.radii,
        velocities: rows.velocities,
        ids: rows.ids,
        attributes: columns
            .extra
            .iter()
            .zip(rows.extras)
            .map(|(&k, values)| Attribute {
                name: properties[k].0.clone(),
                components: 1,
                values,
            })
            .collect(),
    })
}

/// The header of a PLY file: its encoding, its elements in order, and where its body
/// starts (past the end of the `end_header` line).
fn parse_header(bytes: &[u8]) -> Result<(Encoding, Vec<Element>, usize), PlyError> {
    const END: &[u8] = b"end_header";
    let end = bytes
        .windows(END.len())
        .position(|w| w == END)
        .ok_or("not a PLY file: no end_header")?;
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| "PLY header is not text")?;
    let mut body = end + END.len();
    // The header ends with "\n" (or "\r\n").
    while body < bytes.len() && bytes[body] != b'\n' {
        body += 1;
    }
    body += 1;
    let mut lines = header.lines();
    if lines.next().map(str::trim) != Some("ply") {
        return Err("not a PLY file: it does not start with 'ply'".into());
    }
    let mut format = None;
    // Elements in order; a list property is refused in the vertex element.
    let mut elements: Vec<Element> = Vec::new();
    for line in lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["format", f, _] => {
                format = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    other => return Err(format!("unknown PLY format '{other}'").into()),
                })
            }
            ["element", name, count] => {
                let count = count
                    .parse()
                    .map_err(|_| format!("element {name}: count '{count}' is not a number"))?;
                elements.push((name.to_string(), count, Vec::new()));
            }
            ["property", "list", ..] => {
                let element = elements.last_mut().ok_or("property before any element")?;
                element.2.push(("list".into(), "list".into()));
            }
            ["property", ty, name] => {
                let element = elements.last_mut().ok_or("property before any element")?;
                if scalar_type(ty).is_none() {
                    return Err(format!("property {name}: unknown type '{ty}'").into());
                }
                // Which of two would be meant cannot be known.
                if element.2.iter().any(|(n, _)| n == name) {
                    return Err(
                        format!("property {name} appears twice in element {}", element.0).into(),
                    );
                }
                element.2.push((name.to_string(), ty.to_string()));
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            _ => return Err(format!("unreadable PLY header line '{line}'").into()),
        }
    }
    let format = format.ok_or("PLY header has no format line")?;
    Ok((format, elements, body))
}

/// Where the vertex element holds what a particle has, by the names solvers give them.
struct Columns {
    x: usize,
    y: usize,
    z: usize,
    radius: Option<usize>,
    id: Option<usize>,
    velocity: Option<(usize, usize, usize)>,
    /// Every other property: an attribute under its own name.
    extra: Vec<usize>,
}

impl Columns {
    fn of(properties: &[(String, String)]) -> Result<Self, PlyError> {
        let column = |names: &[&str]| {
            properties
                .iter()
                .position(|p| names.contains(&p.0.as_str()))
        };
        let (x, y, z) = match (column(&["x"]), column(&["y"]), column(&["z"])) {
            (Some(x), Some(y), Some(z)) => (x, y, z),
            _ => return Err("vertex element lacks x, y or z".into()),
        };
        let radius = column(&["radius", "pscale", "r"]);
        let id = column(&["id", "pid"]);
        let velocity = match (
            column(&["vx", "velocity_x"]),
            column(&["vy", "velocity_y"]),
            column(&["vz", "velocity_z"]),
        ) {
            (Some(a), Some(b), Some(c)) => Some((a, b, c)),
            _ => None,
        };
        let known: Vec<usize> = [Some(x), Some(y), Some(z), radius, id]
            .into_iter()
            .flatten()
            .chain(velocity.into_iter().flat_map(|(a, b, c)| [a, b, c]))
            .collect();
        let extra = (0..properties.len())
            .filter(|k| !known.contains(k))
            .collect();
        Ok(Columns {
            x,
            y,
            z,
            radius,
            id,
            velocity,
            extra,
        })
    }
}

/// The vertices' values, column by column.
struct Rows {
    positions: Vec<Vec3>,
    radii: Option<Vec<f32>>,
    velocities: Option<Vec<Vec3>>,
    ids: Option<Vec<i64>>,
    extras: Vec<Vec<f32>>,
}

/// `count` ASCII rows of `width` numbers from `data`.
fn read_ascii(data: &[u8], count: usize, width: usize, c: &Columns) -> Result<Rows, PlyError> {
    // The header's count is only a claim (found by cargo fuzz: 4.6 trillion vertices asked
    // for a 200-byte file): reserve no more rows than the bytes could hold.
    let capacity = count.min(data.len());
    let mut rows = Rows {
        positions: Vec::with_capacity(capacity),
        radii: c.radius.map(|_| Vec::with_capacity(capacity)),
        velocities: c.velocity.map(|_| Vec::with_capacity(capacity)),
        ids: c.id.map(|_| Vec::with_capacity(capacity)),
        extras: c
            .extra
            .iter()
            .map(|_| Vec::with_capacity(capacity))
            .collect(),
    };
    let text = std::str::from_utf8(data).map_err(|_| "PLY body is not text")?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    for i in 0..count {
        let line = lines
            .next()
            .ok_or(format!("{count} vertices announced, {i} found"))?;
        let row: Result<Vec<f64>, _> = line.split_whitespace().map(str::parse).collect();
        let row = row.map_err(|_| format!("vertex {i}: not numbers"))?;
        if row.len() < width {
            return Err(format!("vertex {i}: {} values, {width} expected", row.len()).into());
        }
        rows.positions
            .push(Vec3::new(row[c.x] as f32, row[c.y] as f32, row[c.z] as f32));
        if let (Some(r), Some(radii)) = (c.radius, rows.radii.as_mut()) {
            radii.push(row[r] as f32);
        }
        if let (Some((a, b, d)), Some(v)) = (c.velocity, rows.velocities.as_mut()) {
            v.push(Vec3::new(row[a] as f32, row[b] as f32, row[d] as f32));
        }
        if let (Some(k), Some(ids)) = (c.id, rows.ids.as_mut()) {
            ids.push(row[k] as i64);
        }
        for (&k, values) in c.extra.iter().zip(rows.extras.iter_mut()) {
            values.push(row[k] as f32);
        }
    }
    Ok(rows)
}

/// `count` binary rows of `properties` from `data` (big-endian when `big`): fixed-size
/// records, each column read on all threads at its offset.
fn read_binary(
    data: &[u8],
    count: usize,
    properties: &[(String, String)],
    c: &Columns,
    big: bool,
) -> Result<Rows, PlyError> {
    // Every vertex property's type is known (checked in the header; no lists).
    let kinds: Vec<Scalar> = properties
        .iter()
        .map(|p| scalar_type(&p.1).expect("checked in the header"))
        .collect();
    let sizes: Vec<usize> = kinds.iter().map(|k| k.size()).collect();
    let stride: usize = sizes.iter().sum();
    if stride
        .checked_mul(count)
        .map_or(true, |needed| data.len() < needed)
    {
        return Err(format!(
            "{count} vertices announced, {} bytes hold {}",
            data.len(),
            data.len() / stride.max(1)
        )
        .into());
    }
    if count > 0 && stride == 0 {
        return Err("vertex element has no properties".into());
    }
    let offsets: Vec<usize> = sizes
        .iter()
        .scan(0, |at, &s| {
            *at += s;
            Some(*at - s)
        })
        .collect();
    let body = &data[..stride * count];
    let records = || body.par_chunks_exact(stride.max(1));
    let field = |record: &[u8], k: usize| kinds[k].read(&record[offsets[k]..], big);
    let column = |k: usize| records().map(|r| field(r, k) as f32).collect();
    let vector = |(a, b, d): (usize, usize, usize)| {
        records()
            .map(|r| Vec3::new(field(r, a) as f32, field(r, b) as f32, field(r, d) as f32))
            .collect()
    };
    Ok(Rows {
        positions: vector((c.x, c.y, c.z)),
        radii: c.radius.map(column),
        velocities: c.velocity.map(vector),
        ids: c
            .id
            .map(|k| records().map(|r| field(r, k) as i64).collect()),
        extras: c.extra.iter().map(|&k| column(k)).collect(),
    })
}

/// Writes positions as a binary little-endian PLY (`x y z` floats), atomically.
pub fn write_ply(path: &Path, positions: &[Vec3]) -> Result<(), WriteError> {
    let particles = Particles {
        positions: positions.to_vec(),
        ..Particles::default()
    };
    write_particles(path, &particles)
}

/// Writes a particle frame as a binary little-endian PLY, atomically: `x y z`, then what
/// the frame has of `vx vy vz`, `radius` (floats), `id` (`int` when every id fits in
/// 32 bits, else `double`, exact to 2⁵³) and its attributes (floats; a vector's as
/// `NAME_x NAME_y NAME_z`) — what [`read_ply`] reads back: a converter from any format
/// read.
pub fn write_particles(path: &Path, particles: &Particles) -> Result<(), WriteError> {
    let n = particles.positions.len();
    let wide_ids = particles
        .ids
        .as_ref()
        .is_some_and(|ids| ids.iter().any(|&i| i32::try_from(i).is_err()));
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment activeskin\nelement vertex {n}\n\
         property float x\nproperty float y\nproperty float z\n"
    );
    if particles.velocities.is_some() {
        header += "property float vx\nproperty float vy\nproperty float vz\n";
    }
    if particles.radii.is_some() {
        header += "property float radius\n";
    }
    if particles.ids.is_some() {
        header += if wide_ids {
            "property double id\n"
        } else {
            "property int id\n"
        };
    }
    let taken = ["x", "y", "z", "vx", "vy", "vz", "radius", "id"];
    for name in attribute_names(&particles.attributes, &taken) {
        header += &format!("property float {name}\n");
    }
    header += "end_header\n";
    let mut bytes = header.into_bytes();
    for i in 0..n {
        let mut put = |c: f32| bytes.extend_from_slice(&c.to_le_bytes());
        particles.positions[i]
            .to_array()
            .into_iter()
            .for_each(&mut put);
        if let Some(v) = &particles.velocities {
            v[i].to_array().into_iter().for_each(&mut put);
        }
        if let Some(r) = &particles.radii {
            put(r[i]);
        }
        if let Some(ids) = &particles.ids {
            if wide_ids {
                bytes.extend_from_slice(&(ids[i] as f64).to_le_bytes());
            } else {
                bytes.extend_from_slice(&(ids[i] as i32).to_le_bytes());
            }
        }
        for a in &particles.attributes {
            for &x in &a.values[i * a.components..(i + 1) * a.components] {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    super::file::write_atomically(path, |tmp| std::fs::write(tmp, &bytes)).map_err(|source| {
        WriteError {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// PLY has scalar properties only, named by one token: a scalar attribute under its own
/// name, a vector's components as `NAME_x NAME_y NAME_z`; white space in a name becomes
/// `_` (`T [K]` → `T_[K]`), and a name taken already (by `taken`, or an earlier one)
/// gets `_` appended until it is free.
fn attribute_names<'a>(
    attributes: impl IntoIterator<Item = &'a Attribute>,
    taken: &[&str],
) -> Vec<String> {
    let mut used: Vec<String> = taken.iter().map(|t| t.to_string()).collect();
    let mut out = Vec::new();
    for a in attributes {
        let base = match a.name.split_whitespace().collect::<Vec<_>>().join("_") {
            b if b.is_empty() => "attribute".to_string(),
            b => b,
        };
        let components: Vec<String> = match a.components {
            1 => vec![base],
            _ => ["x", "y", "z"].map(|c| format!("{base}_{c}")).to_vec(),
        };
        for mut name in components {
            while used.contains(&name) {
                name.push('_');
            }
            used.push(name.clone());
            out.push(name);
        }
    }
    out
}

/// Binary little-endian PLY with normals and, when given, velocities (`vx vy vz`) and
/// attributes, its body laid out in parallel.
pub fn write_mesh(mesh: &Mesh, values: VertexValues, path: &Path) -> Result<(), MeshError> {
    let n = mesh.positions.len();
    let velocities = values.velocities.filter(|v| v.len() == n);
    let attributes: Vec<&Attribute> = values
        .attributes
        .iter()
        .filter(|a| a.values.len() == n * a.components)
        .collect();
    let mut names: Vec<String> = ["x", "y", "z", "nx", "ny", "nz"].map(String::from).to_vec();
    if velocities.is_some() {
        names.extend(["vx", "vy", "vz"].map(String::from));
    }
    let taken: Vec<&str> = names.iter().map(String::as_str).collect();
    let extra = attribute_names(attributes.iter().copied(), &taken);
    names.extend(extra);
    let floats = names.len();
    let properties: String = names
        .iter()
        .map(|name| format!("property float {name}\n"))
        .collect();
    write_with(path, |w| {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment activeskin {}\n\
             element vertex {n}\n{properties}\
             element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            env!("CARGO_PKG_VERSION"),
            mesh.triangles.len()
        )?;
        write_records(w, &mesh.positions, 4 * floats, |i, p, out| {
            let nrm = mesh.normals[i];
            let record = [p.x, p.y, p.z, nrm.x, nrm.y, nrm.z]
                .into_iter()
                .chain(velocities.into_iter().flat_map(|v| v[i].to_array()))
                .chain(attributes.iter().flat_map(|a| {
                    a.values[i * a.components..(i + 1) * a.components]
                        .iter()
                        .copied()
                }));
            for (k, x) in record.enumerate() {
                out[4 * k..4 * k + 4].copy_from_slice(&x.to_le_bytes());
            }
        })?;
        write_records(w, &mesh.triangles, 13, |_, t, out| {
            out[0] = 3;
            for (k, &i) in t.iter().enumerate() {
                out[1 + 4 * k..5 + 4 * k].copy_from_slice(&(i as i32).to_le_bytes());
            }
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One token each, none taken twice: a space, a clash with a property written before
    /// (a particle attribute called `nx` beside the mesh's normals), a vector.
    #[test]
    fn attribute_names_are_single_free_tokens() {
        let attribute = |name: &str, components| Attribute {
            name: name.into(),
            components,
            values: Vec::new(),
        };
        let attributes = [
            attribute("T [K]", 1),
            attribute("nx", 1),
            attribute("w", 3),
            attribute("w_x", 1),
            attribute("", 1),
        ];
        assert_eq!(
            attribute_names(&attributes, &["x", "y", "z", "nx"]),
            ["T_[K]", "nx_", "w_x", "w_y", "w_z", "w_x_", "attribute"]
        );
    }
}
