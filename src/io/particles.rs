//! Particle frames from files (paper §6.1), the format chosen by extension: PLY
//! ([`super::ply`]), legacy VTK ([`super::vtk`]), VTK XML ([`super::vtu`]), partio BGEO
//! ([`super::bgeo`]), splashsurf's JSON ([`super::json`]), XYZ/CSV text ([`super::text`]),
//! and OpenVDB point data grids through the bridge (feature `vdb`). Whatever the format,
//! positions must be finite, velocities finite and radii positive.

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::json::read_json;
use super::ply::read_ply;
use super::text::read_text;
use crate::particles::{Attribute, Particles};

/// A particle file that cannot be read or written: the file, and the cause (its whole
/// chain in the message, one line).
#[derive(Debug, thiserror::Error)]
#[error("{}: {}", path.display(), super::file::error_chain(source))]
pub struct ParticleError {
    /// The particle file read.
    pub path: PathBuf,
    #[source]
    /// What is wrong with it.
    pub source: ParticleFault,
}

impl ParticleError {
    pub(crate) fn new(path: &Path, source: impl Into<ParticleFault>) -> Self {
        ParticleError {
            path: path.to_path_buf(),
            source: source.into(),
        }
    }
}

/// What is wrong with a particle file.
#[derive(Debug, thiserror::Error)]
pub enum ParticleFault {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// A directory, a pipe, a device ([`super::file::not_a_file`]).
    #[error("{0}")]
    NotAFile(String),
    #[error("particle files must end in {}", extensions_listed())]
    Extension,
    #[error(transparent)]
    Ply(#[from] super::ply::PlyError),
    #[error(transparent)]
    Text(#[from] super::text::TextError),
    #[error("not a JSON array of [x, y, z] points")]
    Json(#[from] serde_json::Error),
    #[error(transparent)]
    Vtk(#[from] super::vtk::VtkError),
    #[error(transparent)]
    Vtu(#[from] super::vtu::VtuError),
    #[error(transparent)]
    Bgeo(#[from] super::bgeo::BgeoError),
    /// Every x holds its particle's id bits (as the pysplishsplash 2.19 build that made
    /// `data/sph/bgeo` wrote them; SPlisHSPlasH's own partio export writes P right):
    /// x cannot be had back.
    #[error("every x holds the particle's id, not a coordinate (a partio export that wrote ids into P); export VTK (enableVTKExport) instead")]
    IdsInX,
    #[error("lists no <Piece Source=...> files")]
    NoPieces,
    #[error("lists piece {0:?} more than once")]
    PieceTwice(String),
    #[error("array '{name}' has {rows} rows for {points} points")]
    Rows {
        name: String,
        rows: usize,
        points: usize,
    },
    #[error("piece {}", path.display())]
    Piece {
        path: PathBuf,
        #[source]
        source: Box<ParticleFault>,
    },
    #[error(transparent)]
    Invalid(#[from] crate::particles::InvalidParticle),
    /// OpenVDB's reason, through the bridge.
    #[error("{0}")]
    Vdb(String),
    #[error("VDB point files need activeskin built with the `vdb` feature")]
    NoVdb,
}

/// A particle file format read from bytes: what it is called, the extensions that name
/// it (lowercase, matched at the end of the file's name, `bgeo.gz` too) and its reader,
/// which checks nothing ([`parse`] does). A new format is its module in `io/` and one
/// line in [`FORMATS`].
#[derive(Debug, Clone, Copy)]
pub struct Format {
    /// How messages name it.
    pub name: &'static str,
    /// The ends of file names that are this format, lower case, without the dot.
    pub extensions: &'static [&'static str],
    read: fn(&[u8]) -> Result<Particles, ParticleFault>,
}

/// Every format read from a file's bytes. Two more are read from the path ([`read`]):
/// `.pvtu`/`.pvtp`, which name their piece files, and `.vdb` points, through OpenVDB.
pub const FORMATS: [Format; 6] = [
    Format {
        name: "PLY",
        extensions: &["ply"],
        read: |b| Ok(read_ply(b)?),
    },
    Format {
        name: "legacy VTK",
        extensions: &["vtk"],
        read: read_vtk,
    },
    Format {
        name: "VTK XML",
        extensions: &["vtu", "vtp"],
        read: read_vtu,
    },
    Format {
        name: "partio BGEO",
        extensions: &["bgeo", "bgeo.gz", "geo"],
        read: read_bgeo,
    },
    Format {
        name: "splashsurf JSON",
        extensions: &["json"],
        read: |b| Ok(read_json(b)?),
    },
    Format {
        name: "XYZ/CSV text",
        extensions: &["xyz", "csv", "txt"],
        read: |b| Ok(read_text(b)?),
    },
];

/// Read from the path, not the bytes: parallel VTK files, VDB point grids.
const PATH_EXTENSIONS: [&str; 3] = ["pvtu", "pvtp", "vdb"];

impl Format {
    pub const PLY: Format = FORMATS[0];
    pub const VTK: Format = FORMATS[1];
    pub const VTU: Format = FORMATS[2];
    pub const BGEO: Format = FORMATS[3];
    pub const JSON: Format = FORMATS[4];
    pub const TEXT: Format = FORMATS[5];

    /// The format the end of `path`'s file name names (any case).
    pub fn of(path: &Path) -> Option<Format> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        FORMATS.into_iter().find(|f| {
            f.extensions
                .iter()
                .any(|e| name.strip_suffix(e).is_some_and(|n| n.ends_with('.')))
        })
    }
}

/// Every extension a particle file may have, for a message: `.ply, .vtk, … or .vdb`.
fn extensions_listed() -> String {
    let all: Vec<String> = FORMATS
        .iter()
        .flat_map(|f| f.extensions.iter())
        .chain(&PATH_EXTENSIONS)
        .map(|e| format!(".{e}"))
        .collect();
    match all.split_last() {
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    }
}

/// Reads a frame by extension: a format of [`FORMATS`], `.pvtu` / `.pvtp` (every piece
/// file they list) or `.vdb` (the first point data grid).
pub fn read(path: &Path) -> Result<Particles, ParticleError> {
    let error = |fault: ParticleFault| ParticleError::new(path, fault);
    if let Some(why) = super::file::not_a_file(path) {
        return Err(error(ParticleFault::NotAFile(why)));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if ext.as_deref() == Some("vdb") {
        #[cfg(feature = "vdb")]
        {
            // The VDB reader names the file in its own errors.
            let particles = read_vdb(path).map_err(|e| error(ParticleFault::Vdb(e.reason())))?;
            return check(particles).map_err(error);
        }
        #[cfg(not(feature = "vdb"))]
        return Err(error(ParticleFault::NoVdb));
    }
    if matches!(ext.as_deref(), Some("pvtu" | "pvtp")) {
        return read_pieces(path).map_err(error);
    }
    let format = Format::of(path).ok_or_else(|| error(ParticleFault::Extension))?;
    let bytes = super::file::read_regular(path).map_err(|e| error(e.into()))?;
    parse(&bytes, format).map_err(error)
}

/// Parses a frame's bytes: positions finite, radii (when given) positive.
pub fn parse(bytes: &[u8], format: Format) -> Result<Particles, ParticleFault> {
    check((format.read)(bytes)?)
}

/// A gzipped frame inflates to at most this many times its size (float data compresses
/// 1.2–6×): a bomb reads as truncated instead of filling the memory.
const INFLATE_LIMIT: u64 = 256;

/// A partio BGEO's points, with the attributes simulators name velocity (`v`, partio's
/// and Houdini's; SPlisHSPlasH `velocity`), identity (`id`) and radius (`pscale`).
fn read_bgeo(bytes: &[u8]) -> Result<Particles, ParticleFault> {
    let limit = (bytes.len() as u64)
        .saturating_mul(INFLATE_LIMIT)
        .max(1 << 20);
    let points = super::bgeo::parse(bytes, limit)?;
    let n = points.positions.len();
    let column =
        |names: &[&str], components: usize| column(&points.attributes, n, names, components);
    let ids: Option<Vec<i64>> = column(&["id"], 1)?.map(|v| v.iter().map(|&i| i as i64).collect());
    // A partio export that wrote each particle's id into the bits of its x (y, z and the
    // attributes right, as in data/sph/bgeo): x cannot be had back.
    if let Some(ids) = &ids {
        let x_is_id = points
            .positions
            .iter()
            .zip(ids)
            .all(|(p, &id)| i64::from(p[0].to_bits()) == id);
        if n > 1 && x_is_id {
            return Err(ParticleFault::IdsInX);
        }
    }
    Ok(Particles {
        positions: points
            .positions
            .iter()
            .map(|p| Vec3::from_array(*p))
            .collect(),
        radii: column(&["pscale", "radius"], 1)?.map(|v| v.iter().map(|&r| r as f32).collect()),
        velocities: column(&["v", "velocity", "vel"], 3)?.map(vectors),
        ids,
        attributes: attributes(
            &points.attributes,
            n,
            &["pscale", "radius", "v", "velocity", "vel", "id"],
        )?,
    })
}

/// The scalar and vector arrays with a row for each of the `n` points, but those read as
/// `known` (ASCII case ignored): the attributes `--attribute` may carry onto the surface.
fn attributes(
    arrays: &[super::points::PointArray],
    n: usize,
    known: &[&str],
) -> Result<Vec<Attribute>, ParticleFault> {
    let mut out = Vec::new();
    for a in arrays
        .iter()
        .filter(|a| !known.iter().any(|k| a.name.eq_ignore_ascii_case(k)))
        .filter(|a| matches!(a.components, 1 | 3))
    {
        // Said, not dropped: an --attribute asking for it would be told the file has none.
        row_per_point(a, n)?;
        out.push(Attribute {
            name: a.name.clone(),
            components: a.components,
            values: a.values.iter().map(|&v| v as f32).collect(),
        });
    }
    Ok(out)
}

/// The values of the array called one of `names` with `components` components; an error
/// when it has not a row for each of the `n` points (a velocity silently dropped would
/// change the motion the skin follows).
fn column<'a>(
    arrays: &'a [super::points::PointArray],
    n: usize,
    names: &[&str],
    components: usize,
) -> Result<Option<&'a [f64]>, ParticleFault> {
    let found = super::points::find_array(arrays, names, components);
    found.map(|a| row_per_point(a, n)).transpose()?;
    Ok(found.map(|a| a.values.as_slice()))
}

/// Point data `a` holds a row for each of the `n` points.
fn row_per_point(a: &super::points::PointArray, n: usize) -> Result<(), ParticleFault> {
    match a.values.len() == n * a.components {
        true => Ok(()),
        false => Err(ParticleFault::Rows {
            name: a.name.clone(),
            rows: a.values.len() / a.components.max(1),
            points: n,
        }),
    }
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
fn read_vtk(bytes: &[u8]) -> Result<Particles, ParticleFault> {
    let points = super::vtk::parse(bytes)?;
    from_arrays(&points.positions, &points.arrays)
}

/// A VTK XML file's points (every piece), with the point data named as in legacy VTK.
fn read_vtu(bytes: &[u8]) -> Result<Particles, ParticleFault> {
    let limit = (bytes.len() as u64)
        .saturating_mul(INFLATE_LIMIT)
        .max(1 << 20);
    let points = super::vtu::parse(bytes, limit)?;
    from_arrays(&points.positions, &points.arrays)
}

/// A parallel `.pvtu`/`.pvtp`: the points of every piece file it lists, in order, with
/// the attributes every piece has.
fn read_pieces(path: &Path) -> Result<Particles, ParticleFault> {
    let bytes = super::file::read_regular(path)?;
    let sources = super::vtu::piece_sources(&bytes)?;
    if sources.is_empty() {
        return Err(ParticleFault::NoPieces);
    }
    let folder = path.parent().unwrap_or(Path::new(""));
    // A piece named twice would be its particles twice, each on top of its copy.
    let mut named = std::collections::HashSet::new();
    for source in &sources {
        let piece = folder.join(source);
        if !named.insert(std::fs::canonicalize(&piece).unwrap_or(piece)) {
            return Err(ParticleFault::PieceTwice(source.clone()));
        }
    }
    let mut all = Particles::default();
    for (k, source) in sources.iter().enumerate() {
        let piece = folder.join(source);
        let part = super::file::read_regular(&piece)
            .map_err(ParticleFault::from)
            .and_then(|b| read_vtu(&b))
            .and_then(check)
            .map_err(|e| ParticleFault::Piece {
                path: piece.clone(),
                source: Box::new(e),
            })?;
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
        // The attributes every piece has, in the first piece's order.
        all.attributes.retain_mut(|a| {
            let same = |b: &&Attribute| b.name == a.name && b.components == a.components;
            match part.attributes.iter().find(same) {
                Some(b) => {
                    a.values.extend_from_slice(&b.values);
                    true
                }
                None => false,
            }
        });
    }
    Ok(all)
}

/// Particles from positions and the point-data arrays simulators name velocity
/// (SPlisHSPlasH `velocity`, DualSPHysics `Vel`), identity (`id`, `Idp`) and radius.
fn from_arrays(
    positions: &[[f64; 3]],
    arrays: &[super::points::PointArray],
) -> Result<Particles, ParticleFault> {
    let n = positions.len();
    let column = |names: &[&str], components: usize| column(arrays, n, names, components);
    Ok(Particles {
        positions: positions
            .iter()
            .map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32))
            .collect(),
        radii: column(&["radius", "pscale"], 1)?.map(|v| v.iter().map(|&r| r as f32).collect()),
        velocities: column(&["velocity", "velocities", "vel", "v"], 3)?.map(vectors),
        ids: column(&["id", "idp", "ids"], 1)?.map(|v| v.iter().map(|&i| i as i64).collect()),
        attributes: attributes(
            arrays,
            n,
            &[
                "radius",
                "pscale",
                "velocity",
                "velocities",
                "vel",
                "v",
                "id",
                "idp",
                "ids",
            ],
        )?,
    })
}

fn check(particles: Particles) -> Result<Particles, ParticleFault> {
    particles.check()?;
    Ok(particles)
}

#[cfg(feature = "vdb")]
fn read_vdb(path: &Path) -> Result<Particles, super::vdb::VdbError> {
    let points = super::vdb::read_points(path, None)?;
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
        ids: (!points.attributes.ids.is_empty()).then(|| points.attributes.ids.clone()),
        attributes: {
            let extra = points.attributes;
            let n = points.positions.len() / 3;
            let mut at = 0;
            extra
                .names
                .into_iter()
                .zip(extra.components)
                .map(|(name, components)| {
                    let count = components as usize * n;
                    let values = extra.values[at..at + count].to_vec();
                    at += count;
                    crate::particles::Attribute {
                        name,
                        components: components as usize,
                        values,
                    }
                })
                .collect()
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::ply::read_ply;
    use crate::io::text::read_text;

    /// The table names each extension once, finds formats by the end of a file's name in
    /// any case, and the message for an unknown one lists them all.
    #[test]
    fn formats_are_found_by_their_extensions() {
        let mut seen = std::collections::HashSet::new();
        for f in FORMATS {
            for e in f.extensions {
                assert!(seen.insert(*e), "{e} twice");
                let found = Format::of(Path::new(&format!("a/b.0001.{}", e.to_uppercase())));
                assert_eq!(found.map(|f| f.name), Some(f.name), "{e}");
            }
        }
        assert_eq!(
            Format::of(Path::new("x.bgeo.gz")).map(|f| f.name),
            Some("partio BGEO")
        );
        assert_eq!(Format::of(Path::new("x.gz")).map(|f| f.name), None);
        assert_eq!(Format::of(Path::new("xply")).map(|f| f.name), None);
        let said = ParticleFault::Extension.to_string();
        for e in seen.iter().chain(&PATH_EXTENSIONS) {
            assert!(said.contains(&format!(".{e}")), "{said}");
        }
    }

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
        let e = p("a,b,c\n1,2,3\n").unwrap_err().to_string();
        assert!(e.contains("no x, y and z") && e.contains("a,b,c"), "{e}");
        let e = p("x,y,z,id\n1,2,3\n").unwrap_err().to_string();
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
            let p = parse(ply.as_bytes(), Format::PLY).unwrap();
            assert_eq!(
                p.velocities,
                Some(vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 5.0, -6.0)])
            );
        }
        let nan = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float vx\nproperty float vy\nproperty float vz\nend_header\n0 0 0 nan 0 0\n";
        let err = parse(nan.as_bytes(), Format::PLY).unwrap_err().to_string();
        assert!(err.contains("velocity"), "{err}");
        // Without them: none.
        let plain = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
        assert_eq!(
            parse(plain.as_bytes(), Format::PLY).unwrap().velocities,
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
            .to_string()
            .contains("3 vertices announced"));
        let bad_type =
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty quaternion x\nend_header\n";
        assert!(read_ply(bad_type.as_bytes())
            .unwrap_err()
            .to_string()
            .contains("unknown type"));
        let twice = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float x\nend_header\n1 2 3 4\n";
        let e = read_ply(twice.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("property x appears twice"), "{e}");
        let few = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n";
        assert!(read_ply(few.as_bytes())
            .unwrap_err()
            .to_string()
            .contains("2 vertices announced, 1 found"));
        assert!(read_ply(b"hello")
            .unwrap_err()
            .to_string()
            .contains("not a PLY file"));
        assert!(read_text(b"1 2\n")
            .unwrap_err()
            .to_string()
            .contains("expected x y z"));
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
            let err = parse(&bytes, Format::PLY).unwrap_err().to_string();
            assert!(err.contains("vertices announced"), "{format}: {err}");
        }
    }
}
