//! USD shots (`--usd shot.usda`): the skin's surface as one time-sampled `UsdGeomMesh`
//! (`/Skin/surface`) over the whole shot, with its normals, velocities and particle
//! attributes (vertex primvars), and the stage's up axis, units and frame rate, as
//! Houdini Solaris, Blender, Maya and Omniverse open it.
//!
//! Each frame is a layer of its own (`shot/shot.0012.usda`), and the stage stitches them
//! with value clips: a frame is written once, whole, like a mesh file, so a resumed run
//! and farm chunks writing frames apart make the same shot as one uninterrupted run, and
//! a killed run leaves no half-written stage. The stage lists every frame of the shot up
//! front; each run writes it again, byte for byte the same.
//!
//! Written as text (`.usda`) by hand: the pure-Rust `openusd` crate writes binary `.usdc`
//! readably only from 0.8 (rustc 1.96, newer than this project's); 0.6's `.usdc` keeps
//! its prims' children as a `token[]` Pixar's library does not read (a stage of no prims,
//! measured with usd-core 26.11).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::Vec3;
use rayon::prelude::*;

use super::mesh_write::{write_with, MeshError, VertexValues};
use crate::mesh::Mesh;
use crate::particles::Attribute;
use crate::render::Up;
use crate::sequence::FramePattern;

/// The extensions a stage may have: USD reads text under either.
pub const EXTENSIONS: &[&str] = &["usda", "usd"];

/// The stage's root prim, and the mesh under it.
const ROOT: &str = "Skin";
const MESH: &str = "surface";

/// A shot being written: where, over which frames, at what rate and in which units.
#[derive(Debug, Clone)]
pub struct Shot {
    stage: PathBuf,
    /// Every frame of the shot (a farm chunk's stage lists them all).
    pub frames: (i64, i64),
    /// The stage's time codes per second.
    pub fps: f64,
    /// The stage's up axis.
    pub up: Up,
    /// The stage's `metersPerUnit`.
    pub meters_per_unit: f64,
}

/// What each frame's mesh carries besides its points, normals and faces: the stage
/// declares it once.
#[derive(Debug, Clone, PartialEq)]
pub struct Carried {
    /// Each frame's vertex velocities (for motion blur).
    pub velocities: bool,
    /// Each attribute's primvar name and USD type.
    pub primvars: Vec<(String, &'static str)>,
}

impl Carried {
    pub fn of(values: &VertexValues) -> Self {
        Carried {
            velocities: values.velocities.is_some(),
            primvars: primvars(values.attributes),
        }
    }
}

impl Shot {
    /// The shot whose stage is `stage` (checked by the caller to end in [`EXTENSIONS`]).
    pub fn new(stage: &Path, frames: (i64, i64), fps: f64, up: Up, meters_per_unit: f64) -> Self {
        Shot {
            stage: stage.to_path_buf(),
            frames,
            fps,
            up,
            meters_per_unit,
        }
    }

    pub fn stage(&self) -> &Path {
        &self.stage
    }

    /// The stage's name without its extension: its frames' folder and file stem.
    fn stem(&self) -> String {
        self.stage
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "shot".into())
    }

    /// The folder of the frames' layers, beside the stage.
    pub fn folder(&self) -> PathBuf {
        self.stage.with_file_name(self.stem())
    }

    /// Frame `frame`'s layer, relative to the stage (as the stage names it).
    fn relative(&self, name: &str) -> String {
        format!("./{}/{name}", self.stem())
    }

    /// The frames' layers, `shot/shot.0012.usda` beside `shot.usda`.
    pub fn frame_pattern(&self) -> FramePattern {
        let prefix = self.folder().join(format!("{}.", self.stem()));
        FramePattern::numbered(&prefix.to_string_lossy(), 4, ".usda")
    }

    fn frame_name(&self, frame: i64) -> String {
        let path = self.frame_path(frame);
        path.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    /// The layer holding frame `frame`'s mesh.
    pub fn frame_path(&self, frame: i64) -> PathBuf {
        self.frame_pattern().path(frame)
    }

    /// The layer declaring what the frames' layers hold (value clips' manifest).
    pub fn manifest_path(&self) -> PathBuf {
        self.folder().join("manifest.usda")
    }

    /// Writes the stage and the frames' manifest (each whole or not at all).
    pub fn write_stage(&self, carried: &Carried) -> Result<(), MeshError> {
        let manifest = format!(
            "#usda 1.0\n\nover \"{ROOT}\"\n{{\n    over \"{MESH}\"\n    {{\n{}    }}\n}}\n",
            declarations(carried, false)
        );
        write_with(&self.manifest_path(), |w| w.write_all(manifest.as_bytes()))?;
        write_with(&self.stage, |w| {
            w.write_all(self.stage_text(carried).as_bytes())
        })
    }

    fn stage_text(&self, carried: &Carried) -> String {
        let (first, last) = self.frames;
        let frames = first..=last;
        let mut s = String::from("#usda 1.0\n(\n");
        let _ = writeln!(s, "    defaultPrim = \"{ROOT}\"");
        let _ = writeln!(
            s,
            "    doc = \"activeskin {}: frames {first}-{last}, one layer each in {}\"",
            env!("CARGO_PKG_VERSION"),
            self.relative(""),
        );
        let _ = writeln!(s, "    endTimeCode = {last}");
        let _ = writeln!(s, "    framesPerSecond = {}", self.fps);
        let _ = writeln!(s, "    metersPerUnit = {}", self.meters_per_unit);
        let _ = writeln!(s, "    startTimeCode = {first}");
        let _ = writeln!(s, "    timeCodesPerSecond = {}", self.fps);
        let axis = match self.up {
            Up::Y => "Y",
            Up::Z => "Z",
        };
        let _ = writeln!(s, "    upAxis = \"{axis}\"\n)\n");
        let _ = writeln!(
            s,
            "def Xform \"{ROOT}\" (\n    clips = {{\n        dictionary default = {{"
        );
        let list = |item: &dyn Fn(usize, i64) -> String| {
            frames
                .clone()
                .enumerate()
                .map(|(i, f)| item(i, f))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            s,
            "            double2[] active = [{}]",
            list(&|i, f| format!("({f}, {i})"))
        );
        let _ = writeln!(
            s,
            "            asset[] assetPaths = [{}]",
            list(&|_, f| format!("@{}@", self.relative(&self.frame_name(f))))
        );
        let _ = writeln!(
            s,
            "            asset manifestAssetPath = @{}@",
            self.relative("manifest.usda")
        );
        let _ = writeln!(s, "            string primPath = \"/{ROOT}\"");
        let _ = writeln!(
            s,
            "            double2[] times = [{}]",
            list(&|_, f| format!("({f}, {f})"))
        );
        s += "        }\n    }\n)\n{\n";
        let _ = writeln!(s, "    def Mesh \"{MESH}\"\n    {{");
        s += "        uniform token subdivisionScheme = \"none\"\n";
        s += &declarations(carried, true);
        s += "    }\n}\n";
        s
    }

    /// Writes frame `frame`'s layer: the mesh and `values` sampled at time `frame`.
    pub fn write_frame(
        &self,
        frame: i64,
        mesh: &Mesh,
        values: VertexValues,
    ) -> Result<(), MeshError> {
        let n = mesh.positions.len();
        let time = frame.to_string();
        let mut parts: Vec<String> = Vec::new();
        let sample = |parts: &mut Vec<String>, ty: &str, name: &str, body: Vec<String>| {
            parts.push(format!(
                "        {ty} {name}.timeSamples = {{\n            {time}: ["
            ));
            parts.extend(body);
            parts.push("],\n        }\n".into());
        };
        if let Some((lo, hi)) = extent(&mesh.positions) {
            sample(&mut parts, "float3[]", "extent", vectors(&[lo, hi]));
        }
        let threes = formatted(&mesh.triangles, |_, s| s.push('3'));
        sample(&mut parts, "int[]", "faceVertexCounts", threes);
        sample(
            &mut parts,
            "int[]",
            "faceVertexIndices",
            indices(&mesh.triangles),
        );
        sample(&mut parts, "normal3f[]", "normals", vectors(&mesh.normals));
        sample(&mut parts, "point3f[]", "points", vectors(&mesh.positions));
        for ((name, ty), attribute) in primvars(values.attributes).iter().zip(values.attributes) {
            let body = match attribute.components {
                3 => vectors(&triples(&attribute.values)),
                _ => scalars(&attribute.values),
            };
            sample(&mut parts, ty, &format!("primvars:{name}"), body);
        }
        if let Some(v) = values.velocities.filter(|v| v.len() == n) {
            sample(&mut parts, "vector3f[]", "velocities", vectors(v));
        }
        write_with(&self.frame_path(frame), |w| {
            write!(
                w,
                "#usda 1.0\n(\n    doc = \"activeskin {}: frame {frame} of {}\"\n)\n\nover \"{ROOT}\"\n{{\n    over \"{MESH}\"\n    {{\n",
                env!("CARGO_PKG_VERSION"),
                self.stage.file_name().map(|n| n.to_string_lossy()).unwrap_or_default(),
            )?;
            for part in &parts {
                w.write_all(part.as_bytes())?;
            }
            w.write_all(b"    }\n}\n")
        })
    }
}

/// The mesh's attributes as the stage declares them (`with_metadata`: vertex
/// interpolation on normals and primvars), or as the manifest does (types only).
fn declarations(carried: &Carried, with_metadata: bool) -> String {
    let vertex = if with_metadata {
        " (\n            interpolation = \"vertex\"\n        )"
    } else {
        ""
    };
    let mut s = String::new();
    s += "        float3[] extent\n";
    s += "        int[] faceVertexCounts\n";
    s += "        int[] faceVertexIndices\n";
    let _ = writeln!(s, "        normal3f[] normals{vertex}");
    s += "        point3f[] points\n";
    for (name, ty) in &carried.primvars {
        let _ = writeln!(s, "        {ty} primvars:{name}{vertex}");
    }
    if carried.velocities {
        s += "        vector3f[] velocities\n";
    }
    s
}

/// Each attribute's primvar name (letters, digits and `_`, not starting with a digit;
/// a clash gets `_` appended) and type: `color3f[]` for a colour (`Cd`, `color`,
/// `displayColor`), `float3[]` for another vector, `float[]` for a scalar.
pub fn primvars(attributes: &[Attribute]) -> Vec<(String, &'static str)> {
    let mut used: Vec<String> = Vec::new();
    attributes
        .iter()
        .map(|a| {
            let mut name: String = a
                .name
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect();
            if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit()) {
                name.insert(0, '_');
            }
            while used.contains(&name) {
                name.push('_');
            }
            used.push(name.clone());
            let colour = ["Cd", "color", "colour", "displayColor"]
                .iter()
                .any(|c| a.name.eq_ignore_ascii_case(c));
            let ty = match (a.components, colour) {
                (3, true) => "color3f[]",
                (3, false) => "float3[]",
                _ => "float[]",
            };
            (name, ty)
        })
        .collect()
}

/// The smallest box holding `points`, none for no points.
fn extent(points: &[Vec3]) -> Option<(Vec3, Vec3)> {
    let first = *points.first()?;
    Some(
        points
            .par_iter()
            .fold(|| (first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)))
            .reduce(|| (first, first), |a, b| (a.0.min(b.0), a.1.max(b.1))),
    )
}

/// A flat `[x, y, z, …]` as vectors (a partial last triple left out).
fn triples(values: &[f32]) -> Vec<Vec3> {
    values.chunks_exact(3).map(Vec3::from_slice).collect()
}

/// Items formatted in parallel chunks of text, `, ` between them, in order.
fn formatted<T: Sync>(items: &[T], each: impl Fn(&T, &mut String) + Sync) -> Vec<String> {
    const CHUNK: usize = 1 << 15;
    items
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut s = String::with_capacity(chunk.len() * 32);
            for (i, item) in chunk.iter().enumerate() {
                if c > 0 || i > 0 {
                    s.push_str(", ");
                }
                each(item, &mut s);
            }
            s
        })
        .collect()
}

/// Floats as their shortest round-trip text (ryu), which USD reads back exactly.
fn push_float(s: &mut String, x: f32, buffer: &mut ryu::Buffer) {
    let x = if x.is_finite() { x } else { 0.0 };
    s.push_str(buffer.format_finite(x));
}

fn vectors(items: &[Vec3]) -> Vec<String> {
    formatted(items, |v, s| {
        let mut buffer = ryu::Buffer::new();
        s.push('(');
        push_float(s, v.x, &mut buffer);
        s.push_str(", ");
        push_float(s, v.y, &mut buffer);
        s.push_str(", ");
        push_float(s, v.z, &mut buffer);
        s.push(')');
    })
}

fn scalars(items: &[f32]) -> Vec<String> {
    formatted(items, |&x, s| push_float(s, x, &mut ryu::Buffer::new()))
}

fn indices(triangles: &[[u32; 3]]) -> Vec<String> {
    formatted(triangles, |t, s| {
        let mut buffer = itoa::Buffer::new();
        s.push_str(buffer.format(t[0]));
        s.push_str(", ");
        s.push_str(buffer.format(t[1]));
        s.push_str(", ");
        s.push_str(buffer.format(t[2]));
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primvar_names_are_identifiers_and_colours_are_colours() {
        let attribute = |name: &str, components| Attribute {
            name: name.into(),
            components,
            values: Vec::new(),
        };
        let got = primvars(&[
            attribute("T [K]", 1),
            attribute("Cd", 3),
            attribute("2nd", 1),
            attribute("T__K_", 1),
            attribute("vorticity", 3),
        ]);
        assert_eq!(
            got,
            [
                ("T__K_".to_string(), "float[]"),
                ("Cd".into(), "color3f[]"),
                ("_2nd".into(), "float[]"),
                ("T__K__".into(), "float[]"),
                ("vorticity".into(), "float3[]"),
            ]
        );
    }

    #[test]
    fn arrays_are_comma_separated_across_chunks() {
        let many: Vec<f32> = (0..70_000).map(|i| i as f32).collect();
        let text: String = scalars(&many).concat();
        let parsed: Vec<f32> = text.split(", ").map(|x| x.parse().unwrap()).collect();
        assert_eq!(parsed, many);
    }
}
