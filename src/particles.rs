//! Particle frames (paper §6.1): positions and optional radii read from PLY (ASCII or
//! binary little/big endian), legacy VTK (ASCII or binary), VTK XML (`.vtu`, `.vtp`,
//! `.pvtu`), partio BGEO, OpenVDB point data grids (`P`, `pscale`; through the bridge) or
//! plain text (XYZ or CSV: `x y z [radius]` per line).

use std::path::{Path, PathBuf};

use glam::Vec3;

pub mod flicker;
pub mod motion;
pub mod splash;

/// A particle frame that cannot be read.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct ParticleError {
    pub path: PathBuf,
    pub message: String,
}

/// One frame of particles.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Particles {
    pub positions: Vec<Vec3>,
    /// Per-particle radius, when the file has one.
    pub radii: Option<Vec<f32>>,
    /// Per-particle velocity (PLY `vx vy vz` or `velocity_x velocity_y velocity_z`), in
    /// the file's units, when it has one.
    pub velocities: Option<Vec<Vec3>>,
    /// Per-particle identifier (PLY `id`, as SPlisHSPlasH and partio write it), when the
    /// file has one: the same particle keeps it from frame to frame.
    pub ids: Option<Vec<i64>>,
}

/// A particle file format read from bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Ply,
    /// `x y z [radius]` per line, spaces or commas, optional header.
    Text,
    /// Legacy VTK, ASCII or binary ([`crate::io::vtk`]).
    Vtk,
    /// VTK XML points, `.vtu` or `.vtp` ([`crate::io::vtu`]).
    Vtu,
    /// Classic BGEO as partio writes it, gzipped or not ([`crate::io::bgeo`]).
    Bgeo,
    /// splashsurf's JSON: `[[x, y, z], …]`.
    Json,
}

/// Reads a frame by extension: `.ply`, `.vtk`, `.vtu` / `.vtp` (and `.pvtu` / `.pvtp`,
/// every piece file they list), `.bgeo` (`.bgeo.gz`), `.vdb` (the first point data grid),
/// `.json` (splashsurf's), or `.xyz` / `.csv` / `.txt`.
pub fn read(path: &Path) -> Result<Particles, ParticleError> {
    let error = |message: String| ParticleError {
        path: path.to_path_buf(),
        message,
    };
    if let Some(why) = crate::io::not_a_file(path) {
        return Err(error(why));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if ext.as_deref() == Some("vdb") {
        #[cfg(feature = "vdb")]
        {
            // The VDB reader names the file in its own errors.
            let particles = read_vdb(path).map_err(|e| error(e.reason()))?;
            return check(particles).map_err(error);
        }
        #[cfg(not(feature = "vdb"))]
        return Err(error(
            "VDB point files need activeskin built with the `vdb` feature".into(),
        ));
    }
    if matches!(ext.as_deref(), Some("pvtu" | "pvtp")) {
        return read_pieces(path).map_err(error);
    }
    let format = match ext.as_deref() {
        Some("ply") => Format::Ply,
        Some("vtu" | "vtp") => Format::Vtu,
        Some("xyz" | "csv" | "txt") => Format::Text,
        Some("vtk") => Format::Vtk,
        Some("bgeo" | "geo") => Format::Bgeo,
        Some("json") => Format::Json,
        Some("gz")
            if path
                .to_string_lossy()
                .to_ascii_lowercase()
                .ends_with(".bgeo.gz") =>
        {
            Format::Bgeo
        }
        _ => {
            return Err(error(
                "particle files must end in .ply, .vtk, .vtu, .vtp, .pvtu, .bgeo, .vdb, .json, .xyz, .csv or .txt"
                    .into(),
            ))
        }
    };
    let bytes = std::fs::read(path).map_err(|e| error(e.to_string()))?;
    parse(&bytes, format).map_err(error)
}

/// Parses a frame's bytes: positions finite, radii (when given) positive.
pub fn parse(bytes: &[u8], format: Format) -> Result<Particles, String> {
    check(match format {
        Format::Ply => read_ply(bytes)?,
        Format::Text => read_text(bytes)?,
        Format::Vtk => read_vtk(bytes)?,
        Format::Vtu => read_vtu(bytes)?,
        Format::Bgeo => read_bgeo(bytes)?,
        Format::Json => read_json(bytes)?,
    })
}

/// splashsurf's JSON particle file: an array of `[x, y, z]` arrays.
fn read_json(bytes: &[u8]) -> Result<Particles, String> {
    let points: Vec<[f32; 3]> = serde_json::from_slice(bytes)
        .map_err(|e| format!("not a JSON array of [x, y, z] points: {e}"))?;
    Ok(Particles {
        positions: points.into_iter().map(Vec3::from_array).collect(),
        ..Particles::default()
    })
}

/// A gzipped frame inflates to at most this many times its size (float data compresses
/// 1.2–6×): a bomb reads as truncated instead of filling the memory.
const INFLATE_LIMIT: u64 = 256;

/// A partio BGEO's points, with the attributes simulators name velocity (`v`, partio's
/// and Houdini's; SPlisHSPlasH `velocity`), identity (`id`) and radius (`pscale`).
fn read_bgeo(bytes: &[u8]) -> Result<Particles, String> {
    let limit = (bytes.len() as u64)
        .saturating_mul(INFLATE_LIMIT)
        .max(1 << 20);
    let points = crate::io::bgeo::parse(bytes, limit).map_err(|e| error_chain(&e))?;
    let n = points.positions.len();
    let column =
        |names: &[&str], components: usize| column(&points.attributes, n, names, components);
    let ids: Option<Vec<i64>> = column(&["id"], 1).map(|v| v.iter().map(|&i| i as i64).collect());
    // pysplishsplash 2.19's partio export writes each particle's id into the bits of its x
    // (y, z and the attributes are right): x cannot be had back.
    if let Some(ids) = &ids {
        let x_is_id = points
            .positions
            .iter()
            .zip(ids)
            .all(|(p, &id)| i64::from(p[0].to_bits()) == id);
        if n > 1 && x_is_id {
            return Err("every x holds the particle's id, not a coordinate (SPlisHSPlasH's partio export writes so); export VTK (enableVTKExport) instead".into());
        }
    }
    Ok(Particles {
        positions: points
            .positions
            .iter()
            .map(|p| Vec3::from_array(*p))
            .collect(),
        radii: column(&["pscale", "radius"], 1).map(|v| v.iter().map(|&r| r as f32).collect()),
        velocities: column(&["v", "velocity", "vel"], 3).map(vectors),
        ids,
    })
}

/// The values of the array called one of `names` with `components` components, when it has
/// a row for each of the `n` points.
fn column<'a>(
    arrays: &'a [crate::io::PointArray],
    n: usize,
    names: &[&str],
    components: usize,
) -> Option<&'a [f64]> {
    crate::io::find_array(arrays, names, components)
        .filter(|a| a.values.len() == n * components)
        .map(|a| a.values.as_slice())
}

/// Rows of three as vectors.
fn vectors(values: &[f64]) -> Vec<Vec3> {
    values
        .chunks_exact(3)
        .map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
        .collect()
}

/// A legacy VTK file's points, with the point data simulators name velocity
/// (SPlisHSPlasH `velocity`, DualSPHysics `Vel`), identity (`id`, `Idp`) and radius.
fn read_vtk(bytes: &[u8]) -> Result<Particles, String> {
    let points = crate::io::vtk::parse(bytes).map_err(|e| e.to_string())?;
    Ok(from_arrays(&points.positions, &points.arrays))
}

/// A VTK XML file's points (every piece), with the point data named as in legacy VTK.
fn read_vtu(bytes: &[u8]) -> Result<Particles, String> {
    let limit = (bytes.len() as u64)
        .saturating_mul(INFLATE_LIMIT)
        .max(1 << 20);
    let points = crate::io::vtu::parse(bytes, limit).map_err(|e| error_chain(&e))?;
    Ok(from_arrays(&points.positions, &points.arrays))
}

/// A parallel `.pvtu`/`.pvtp`: the points of every piece file it lists, in order, with
/// the attributes every piece has.
fn read_pieces(path: &Path) -> Result<Particles, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let sources = crate::io::vtu::piece_sources(&bytes).map_err(|e| error_chain(&e))?;
    if sources.is_empty() {
        return Err("lists no <Piece Source=...> files".into());
    }
    let folder = path.parent().unwrap_or(Path::new(""));
    let mut all = Particles::default();
    for (k, source) in sources.iter().enumerate() {
        let piece = folder.join(source);
        let part = std::fs::read(&piece)
            .map_err(|e| e.to_string())
            .and_then(|b| read_vtu(&b))
            .and_then(check)
            .map_err(|e| format!("piece {}: {e}", piece.display()))?;
        if k == 0 {
            all = part;
            continue;
        }
        fn join<T: Clone>(a: &mut Option<Vec<T>>, b: Option<Vec<T>>) {
            match (a.as_mut(), b) {
                (Some(a), Some(b)) => a.extend(b),
                _ => *a = None,
            }
        }
        all.positions.extend(part.positions);
        join(&mut all.radii, part.radii);
        join(&mut all.velocities, part.velocities);
        join(&mut all.ids, part.ids);
    }
    Ok(all)
}

/// An error with its causes, `error: cause: cause`.
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        text = format!("{text}: {cause}");
        source = cause.source();
    }
    text
}

/// Particles from positions and the point-data arrays simulators name velocity
/// (SPlisHSPlasH `velocity`, DualSPHysics `Vel`), identity (`id`, `Idp`) and radius.
fn from_arrays(positions: &[[f64; 3]], arrays: &[crate::io::PointArray]) -> Particles {
    let n = positions.len();
    let column = |names: &[&str], components: usize| column(arrays, n, names, components);
    Particles {
        positions: positions
            .iter()
            .map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32))
            .collect(),
        radii: column(&["radius", "pscale"], 1).map(|v| v.iter().map(|&r| r as f32).collect()),
        velocities: column(&["velocity", "velocities", "vel", "v"], 3).map(vectors),
        ids: column(&["id", "idp", "ids"], 1).map(|v| v.iter().map(|&i| i as i64).collect()),
    }
}

impl Particles {
    /// Whether every particle lies within `reach` of the origin on each axis.
    pub fn within(&self, reach: f32) -> bool {
        self.positions
            .iter()
            .all(|p| p.abs().max_element() <= reach)
    }

    /// Leaves out the particles with a coordinate beyond `reach` of the origin, with their
    /// radii, velocities and ids; returns how many.
    pub fn keep_within(&mut self, reach: f32) -> usize {
        if self.within(reach) {
            return 0;
        }
        let inside = |p: &Vec3| p.abs().max_element() <= reach;
        let keep: Vec<bool> = self.positions.iter().map(inside).collect();
        fn filter<T>(values: &mut Vec<T>, keep: &[bool]) {
            let mut k = keep.iter();
            values.retain(|_| *k.next().unwrap_or(&true));
        }
        let before = self.positions.len();
        filter(&mut self.positions, &keep);
        if let Some(r) = &mut self.radii {
            filter(r, &keep);
        }
        if let Some(v) = &mut self.velocities {
            filter(v, &keep);
        }
        if let Some(ids) = &mut self.ids {
            filter(ids, &keep);
        }
        before - self.positions.len()
    }
}

fn check(particles: Particles) -> Result<Particles, String> {
    if let Some(i) = particles.positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("particle {i} has a NaN or infinite coordinate"));
    }
    if let Some(v) = &particles.velocities {
        if let Some(i) = v.iter().position(|v| !v.is_finite()) {
            return Err(format!("particle {i} has a velocity that is not finite"));
        }
    }
    if let Some(radii) = &particles.radii {
        if let Some(i) = radii.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
            return Err(format!(
                "particle {i} has a radius that is not a positive number"
            ));
        }
    }
    Ok(particles)
}

/// Writes positions as a binary little-endian PLY (`x y z` floats), atomically.
pub fn write_ply(path: &Path, positions: &[Vec3]) -> Result<(), ParticleError> {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\ncomment activeskin\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\nend_header\n",
        positions.len()
    )
    .into_bytes();
    for c in positions.iter().flat_map(|p| p.to_array()) {
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    crate::io::write_atomically(path, |tmp| {
        std::fs::write(tmp, &bytes).map_err(|e| e.to_string())
    })
    .map_err(|message| ParticleError {
        path: path.to_path_buf(),
        message,
    })
}

#[cfg(feature = "vdb")]
fn read_vdb(path: &Path) -> Result<Particles, crate::vdb::VdbError> {
    let points = crate::vdb::read_points(path, None)?;
    Ok(Particles {
        positions: points
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect(),
        radii: points.has_radius.then_some(points.radii),
        velocities: points.has_velocity.then(|| {
            points
                .velocities
                .chunks_exact(3)
                .map(|v| Vec3::new(v[0], v[1], v[2]))
                .collect()
        }),
        ids: None,
    })
}

/// Text particles: `x y z [radius]` per line (spaces, commas or semicolons), or a CSV
/// whose header names its columns in any order — `x y z`, ParaView's `Points:0`,
/// DualSPHysics' `Pos.x [m]`, `position_x`, …; radius (`radius`, `pscale`), velocity
/// (`vx`, `velocity:0`, `Vel.x`, `v_x`, …) and id (`id`, `Idp`) read by name, other
/// columns ignored.
fn read_text(bytes: &[u8]) -> Result<Particles, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "not a text file".to_string())?;
    // Commas, semicolons or tabs when the line has any (names may hold spaces:
    // `Pos.x [m]`), else spaces.
    let split = |line: &str| -> Vec<String> {
        let fields: Vec<&str> = if line.contains([',', ';', '\t']) {
            line.split([',', ';', '\t']).collect()
        } else {
            line.split_whitespace().collect()
        };
        fields
            .into_iter()
            .map(|f| f.trim().to_string())
            .filter(|f| !f.is_empty())
            .collect()
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(n, l)| (n + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let mut first = lines.next();
    // A header: its first line is not all numbers.
    let columns = match first {
        Some((_, line)) if split(line).iter().any(|f| f.parse::<f64>().is_err()) => {
            let names = split(line);
            first = None;
            Some(
                Columns::from_header(&names)
                    .ok_or_else(|| format!("the header names no x, y and z columns: '{line}'"))?,
            )
        }
        _ => None,
    };
    let mut out = Particles::default();
    let (mut radii, mut velocities, mut ids) = (Vec::new(), Vec::new(), Vec::new());
    for (n, line) in first.into_iter().chain(lines) {
        let fields = split(line);
        let numbers: Vec<f64> = fields
            .iter()
            .map(|f| f.trim_matches('"').parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("line {n}: not numbers: '{line}'"))?;
        let at = |k: usize| numbers[k] as f32;
        match &columns {
            Some(c) => {
                if numbers.len() < c.width {
                    return Err(format!(
                        "line {n}: {} numbers, the header names {} columns",
                        numbers.len(),
                        c.width
                    ));
                }
                out.positions.push(Vec3::new(at(c.x[0]), at(c.x[1]), at(c.x[2])));
                if let Some(k) = c.radius {
                    radii.push(at(k));
                }
                if let Some(v) = c.velocity {
                    velocities.push(Vec3::new(at(v[0]), at(v[1]), at(v[2])));
                }
                if let Some(k) = c.id {
                    ids.push(numbers[k] as i64);
                }
            }
            None => match numbers.len() {
                3 => out.positions.push(Vec3::new(at(0), at(1), at(2))),
                4 => {
                    out.positions.push(Vec3::new(at(0), at(1), at(2)));
                    radii.push(at(3));
                }
                k => {
                    return Err(format!(
                        "line {n}: {k} numbers, expected x y z [radius] (or a header naming the columns)"
                    ))
                }
            },
        }
    }
    if !radii.is_empty() && radii.len() != out.positions.len() {
        return Err("some lines have a radius and others not".into());
    }
    out.radii = (!radii.is_empty()).then_some(radii);
    out.velocities = (!velocities.is_empty()).then_some(velocities);
    out.ids = (!ids.is_empty()).then_some(ids);
    Ok(out)
}

/// Where a CSV header puts the columns read.
#[derive(Debug, PartialEq)]
struct Columns {
    x: [usize; 3],
    radius: Option<usize>,
    velocity: Option<[usize; 3]>,
    id: Option<usize>,
    /// Columns a row must have: one past the last read.
    width: usize,
}

impl Columns {
    fn from_header(names: &[String]) -> Option<Columns> {
        // Each name as (base, component): `Points:0` → ("points", 0), `Pos.x [m]` →
        // ("pos", 0), `vx` → ("v", 0), `x` → ("", 0), `radius` → ("radius", none).
        let parsed: Vec<(String, Option<usize>)> = names.iter().map(|n| name_parts(n)).collect();
        let find = |bases: &[&str], component: Option<usize>| {
            parsed
                .iter()
                .position(|(b, c)| *c == component && bases.contains(&b.as_str()))
        };
        let vector = |bases: &[&str]| -> Option<[usize; 3]> {
            Some([
                find(bases, Some(0))?,
                find(bases, Some(1))?,
                find(bases, Some(2))?,
            ])
        };
        let x = vector(&["", "p", "pos", "position", "points", "point", "coords"])?;
        let radius = find(&["radius", "pscale", "r"], None);
        let velocity = vector(&["v", "vel", "velocity", "velocities"]);
        let id = find(&["id", "idp", "pid", "ids"], None);
        let width = x
            .iter()
            .chain(velocity.iter().flatten())
            .chain(radius.iter())
            .chain(id.iter())
            .max()
            .map_or(0, |&k| k + 1);
        Some(Columns {
            x,
            radius,
            velocity,
            id,
            width,
        })
    }
}

/// A column name's base and component, lowercased, quotes and units (`[m]`, `(m/s)`)
/// dropped.
fn name_parts(name: &str) -> (String, Option<usize>) {
    let mut n = name.trim().trim_matches('"').to_ascii_lowercase();
    if let Some(cut) = n.find(['[', '(']).filter(|&k| k > 0) {
        // `p[0]` keeps its index; `Pos.x [m]` loses its unit.
        let inner = n[cut + 1..].trim_end_matches([']', ')']);
        if let Ok(k) = inner.parse::<usize>() {
            return (n[..cut].trim().to_string(), (k < 3).then_some(k));
        }
        n.truncate(cut);
    }
    let n = n.trim();
    let axis = |c: &str| match c {
        "x" | "0" => Some(0),
        "y" | "1" => Some(1),
        "z" | "2" => Some(2),
        _ => None,
    };
    for sep in [':', '.', '_'] {
        if let Some((base, c)) = n.rsplit_once(sep) {
            if let Some(k) = axis(c) {
                return (base.to_string(), Some(k));
            }
        }
    }
    // `x`, `vx`, `px`: a one-letter base and an axis letter.
    match n.len() {
        1 if axis(n).is_some() && n.chars().all(char::is_alphabetic) => (String::new(), axis(n)),
        2 => match axis(&n[1..]).filter(|_| n[1..].chars().all(char::is_alphabetic)) {
            Some(k) => (n[..1].to_string(), Some(k)),
            None => (n.to_string(), None),
        },
        _ => (n.to_string(), None),
    }
}

/// A PLY element: name, count, properties (name, type).
type Element = (String, usize, Vec<(String, String)>);

/// How a PLY file stores its rows.
#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// The scalar types PLY names, and their sizes.
fn type_size(name: &str) -> Option<usize> {
    Some(match name {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
        "double" | "float64" => 8,
        _ => return None,
    })
}

fn read_ply(bytes: &[u8]) -> Result<Particles, String> {
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
                    other => return Err(format!("unknown PLY format '{other}'")),
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
                if type_size(ty).is_none() {
                    return Err(format!("property {name}: unknown type '{ty}'"));
                }
                // Which of two would be meant cannot be known.
                if element.2.iter().any(|(n, _)| n == name) {
                    return Err(format!(
                        "property {name} appears twice in element {}",
                        element.0
                    ));
                }
                element.2.push((name.to_string(), ty.to_string()));
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            _ => return Err(format!("unreadable PLY header line '{line}'")),
        }
    }
    let format = format.ok_or("PLY header has no format line")?;
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
    let data = &bytes[body.min(bytes.len())..];
    // The header's count is only a claim (found by cargo fuzz: 4.6 trillion vertices asked
    // for a 200-byte file): reserve no more rows than the bytes could hold.
    let capacity = (*count).min(data.len());
    let mut positions = Vec::with_capacity(capacity);
    let mut radii = radius.map(|_| Vec::with_capacity(capacity));
    let mut velocities = velocity.map(|_| Vec::with_capacity(capacity));
    let mut ids = id.map(|_| Vec::with_capacity(capacity));
    let mut push = |row: &[f64]| {
        positions.push(Vec3::new(row[x] as f32, row[y] as f32, row[z] as f32));
        if let (Some(r), Some(radii)) = (radius, radii.as_mut()) {
            radii.push(row[r] as f32);
        }
        if let (Some((a, b, c)), Some(v)) = (velocity, velocities.as_mut()) {
            v.push(Vec3::new(row[a] as f32, row[b] as f32, row[c] as f32));
        }
        if let (Some(k), Some(ids)) = (id, ids.as_mut()) {
            ids.push(row[k] as i64);
        }
    };
    match format {
        Encoding::Ascii => {
            let text = std::str::from_utf8(data).map_err(|_| "PLY body is not text")?;
            let mut rows = text.lines().filter(|l| !l.trim().is_empty());
            for i in 0..*count {
                let line = rows
                    .next()
                    .ok_or(format!("{count} vertices announced, {i} found"))?;
                let row: Result<Vec<f64>, _> = line.split_whitespace().map(str::parse).collect();
                let row = row.map_err(|_| format!("vertex {i}: not numbers"))?;
                if row.len() < properties.len() {
                    return Err(format!(
                        "vertex {i}: {} values, {} expected",
                        row.len(),
                        properties.len()
                    ));
                }
                push(&row);
            }
        }
        Encoding::Little | Encoding::Big => {
            let sizes: Vec<usize> = properties
                .iter()
                .map(|p| type_size(&p.1).unwrap_or(0))
                .collect();
            let stride: usize = sizes.iter().sum();
            if stride
                .checked_mul(*count)
                .map_or(true, |needed| data.len() < needed)
            {
                return Err(format!(
                    "{count} vertices announced, {} bytes hold {}",
                    data.len(),
                    data.len() / stride.max(1)
                ));
            }
            let mut row = vec![0.0f64; properties.len()];
            for v in 0..*count {
                let mut at = v * stride;
                for (k, (_, ty)) in properties.iter().enumerate() {
                    let raw = &data[at..at + sizes[k]];
                    row[k] = scalar(ty, raw, format == Encoding::Little);
                    at += sizes[k];
                }
                push(&row);
            }
        }
    }
    Ok(Particles {
        positions,
        radii,
        velocities,
        ids,
    })
}

/// One binary PLY scalar as f64.
fn scalar(ty: &str, raw: &[u8], little: bool) -> f64 {
    macro_rules! num {
        ($t:ty) => {{
            let bytes = raw.try_into().expect("sized by type_size");
            f64::from(if little {
                <$t>::from_le_bytes(bytes)
            } else {
                <$t>::from_be_bytes(bytes)
            })
        }};
    }
    match ty {
        "char" | "int8" => num!(i8),
        "uchar" | "uint8" => num!(u8),
        "short" | "int16" => num!(i16),
        "ushort" | "uint16" => num!(u16),
        "int" | "int32" => num!(i32),
        "uint" | "uint32" => num!(u32),
        "float" | "float32" => num!(f32),
        _ => num!(f64),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_headers_name_the_columns_in_any_order() {
        let p = |text: &str| read_text(text.as_bytes());
        // Swapped axes and extra columns, read by name.
        let swapped = p("z,y,x,density\n3,2,1,1000\n6,5,4,999\n").unwrap();
        assert_eq!(
            swapped.positions,
            vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, 5.0, 6.0)]
        );
        assert_eq!(swapped.radii, None);
        let ids = p("id,x,y,z,pscale\n7,1,2,3,0.5\n").unwrap();
        assert_eq!((ids.ids, ids.radii), (Some(vec![7]), Some(vec![0.5])));
        assert_eq!(ids.positions, vec![Vec3::new(1.0, 2.0, 3.0)]);
        // ParaView's Save Data CSV.
        let paraview = p("\"velocity:0\",\"velocity:1\",\"velocity:2\",\"id\",\"Points:0\",\"Points:1\",\"Points:2\"\n0,-0.45,0,12,0.04,0.05,0.06\n").unwrap();
        assert_eq!(paraview.positions, vec![Vec3::new(0.04, 0.05, 0.06)]);
        assert_eq!(paraview.velocities, Some(vec![Vec3::new(0.0, -0.45, 0.0)]));
        assert_eq!(paraview.ids, Some(vec![12]));
        // DualSPHysics' PartVTK -SaveCsv: semicolons, units.
        let dual = p("Pos.x [m];Pos.y [m];Pos.z [m];Idp;Vel.x [m/s];Vel.y [m/s];Vel.z [m/s];Rhop [kg/m^3]\n1;2;3;4;0.1;0.2;0.3;1000\n").unwrap();
        assert_eq!(dual.positions, vec![Vec3::new(1.0, 2.0, 3.0)]);
        assert_eq!(dual.velocities, Some(vec![Vec3::new(0.1, 0.2, 0.3)]));
        assert_eq!(dual.ids, Some(vec![4]));
        // Short names and bracketed indices.
        let short = p("px py pz vx vy vz\n1 2 3 4 5 6\n").unwrap();
        assert_eq!(short.velocities, Some(vec![Vec3::new(4.0, 5.0, 6.0)]));
        let indexed = p("p[0],p[1],p[2]\n1,2,3\n").unwrap();
        assert_eq!(indexed.positions, vec![Vec3::new(1.0, 2.0, 3.0)]);
        // No header: x y z [radius] as before.
        let plain = p("1 2 3 0.5\n4 5 6 0.5\n").unwrap();
        assert_eq!(plain.radii, Some(vec![0.5, 0.5]));
        // A header naming no position, a row short of the header: one line each.
        let e = p("a,b,c\n1,2,3\n").unwrap_err();
        assert!(e.contains("no x, y and z") && e.contains("a,b,c"), "{e}");
        let e = p("x,y,z,id\n1,2,3\n").unwrap_err();
        assert!(e.contains("line 2") && e.contains("4 columns"), "{e}");
    }

    #[test]
    fn ply_velocities_are_read_by_either_name_and_must_be_finite() {
        for names in [
            ["vx", "vy", "vz"],
            ["velocity_x", "velocity_y", "velocity_z"],
        ] {
            let ply = format!(
                "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float {}\nproperty float {}\nproperty float {}\nend_header\n0 0 0 1 2 3\n1 1 1 -4 5 -6\n",
                names[0], names[1], names[2]
            );
            let p = parse(ply.as_bytes(), Format::Ply).unwrap();
            assert_eq!(
                p.velocities,
                Some(vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 5.0, -6.0)])
            );
        }
        let nan = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float vx\nproperty float vy\nproperty float vz\nend_header\n0 0 0 nan 0 0\n";
        let err = parse(nan.as_bytes(), Format::Ply).unwrap_err();
        assert!(err.contains("velocity"), "{err}");
        // Without them: none.
        let plain = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
        assert_eq!(
            parse(plain.as_bytes(), Format::Ply).unwrap().velocities,
            None
        );
    }

    #[test]
    fn ascii_and_binary_ply_and_text_agree() {
        let points = [Vec3::new(0.5, -1.0, 2.0), Vec3::new(3.0, 4.0, -0.25)];
        let ascii = "ply\nformat ascii 1.0\ncomment test\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float radius\nend_header\n0.5 -1 2 0.1\n3 4 -0.25 0.2\n";
        let p = read_ply(ascii.as_bytes()).unwrap();
        assert_eq!(p.positions, points);
        assert_eq!(p.radii, Some(vec![0.1, 0.2]));

        let mut binary = b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\nproperty uchar id\nend_header\n".to_vec();
        for q in points {
            for c in q.to_array() {
                binary.extend_from_slice(&f64::from(c).to_le_bytes());
            }
            binary.push(7);
        }
        let p = read_ply(&binary).unwrap();
        assert_eq!(p.positions, points);
        assert_eq!(p.radii, None);

        let mut big = b"ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n".to_vec();
        for q in points {
            for c in q.to_array() {
                big.extend_from_slice(&c.to_be_bytes());
            }
        }
        assert_eq!(read_ply(&big).unwrap().positions, points);

        let csv = "x,y,z\n0.5,-1,2\n3,4,-0.25\n";
        assert_eq!(read_text(csv.as_bytes()).unwrap().positions, points);
    }

    #[test]
    fn broken_files_are_named_errors() {
        let truncated = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
        assert!(read_ply(truncated)
            .unwrap_err()
            .contains("3 vertices announced"));
        let bad_type =
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty quaternion x\nend_header\n";
        assert!(read_ply(bad_type.as_bytes())
            .unwrap_err()
            .contains("unknown type"));
        let twice = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float x\nend_header\n1 2 3 4\n";
        let e = read_ply(twice.as_bytes()).unwrap_err();
        assert!(e.contains("property x appears twice"), "{e}");
        let few = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n";
        assert!(read_ply(few.as_bytes())
            .unwrap_err()
            .contains("2 vertices announced, 1 found"));
        assert!(read_ply(b"hello").unwrap_err().contains("not a PLY file"));
        assert!(read_text(b"1 2\n").unwrap_err().contains("expected x y z"));
    }

    /// Found by cargo fuzz: a header announcing trillions of vertices made the reader ask
    /// for terabytes before finding the file short; a count whose byte size overflows
    /// must not wrap either.
    #[test]
    fn absurd_vertex_counts_are_errors_not_allocations() {
        for (format, count) in [
            ("binary_big_endian", "4666666666666"),
            ("binary_little_endian", "18446744073709551615"),
            ("ascii", "4666666666666"),
        ] {
            let header = format!(
                "ply\nformat {format} 1.0\nelement vertex {count}\nproperty double x\n\
                 property double y\nproperty uint16 z\nend_header\n"
            );
            let mut bytes = header.into_bytes();
            if format == "ascii" {
                bytes.extend_from_slice(b"1 2 3\n");
            } else {
                bytes.extend_from_slice(&[0x3f; 40]);
            }
            let err = parse(&bytes, Format::Ply).unwrap_err();
            assert!(err.contains("vertices announced"), "{format}: {err}");
        }
    }
}
