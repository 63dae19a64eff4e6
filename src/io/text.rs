//! Particles as text: `x y z [radius]` per line, or a CSV whose header names its
//! columns (ParaView's, DualSPHysics', and the usual spellings).

use glam::Vec3;
use rayon::prelude::*;

use crate::particles::{Attribute, Particles};

/// Text particles: `x y z [radius]` per line (spaces, commas or semicolons), or a CSV
/// whose header names its columns in any order — `x y z`, ParaView's `Points:0`,
/// DualSPHysics' `Pos.x [m]`, `position_x`, …; radius (`radius`, `pscale`), velocity
/// (`vx`, `velocity:0`, `Vel.x`, `v_x`, …) and id (`id`, `Idp`) read by name, every
/// other column an attribute under its header's name (`particles --attribute`).
/// A text particle file that cannot be read: what is wrong, where (a line, an element).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct TextError(pub String);

impl From<String> for TextError {
    fn from(message: String) -> Self {
        TextError(message)
    }
}

impl From<&str> for TextError {
    fn from(message: &str) -> Self {
        TextError(message.to_string())
    }
}

pub(crate) fn read_text(bytes: &[u8]) -> Result<Particles, TextError> {
    parse_text(bytes)
}

fn parse_text(bytes: &[u8]) -> Result<Particles, TextError> {
    let text = std::str::from_utf8(bytes).map_err(|_| "not a text file".to_string())?;
    let split = |line: &str| -> Vec<String> { fields(line).map(str::to_string).collect() };
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
    // The rows, each parsed on its own (in parallel, numbers into a buffer per thread).
    let rows: Vec<(usize, &str)> = first.into_iter().chain(lines).collect();
    let parsed: Vec<Row> = rows
        .par_iter()
        .map_init(Vec::new, |numbers, &(n, line)| {
            numbers.clear();
            for field in fields(line) {
                let number = field
                    .trim_matches('"')
                    .parse::<f64>()
                    .map_err(|_| format!("line {n}: not numbers: '{line}'"))?;
                numbers.push(number);
            }
            row(n, numbers, columns.as_ref())
        })
        .collect::<Vec<Result<Row, TextError>>>()
        .into_iter()
        // The first bad line, whichever thread met it.
        .collect::<Result<_, TextError>>()?;
    let with_radius = parsed.iter().filter(|r| r.radius.is_some()).count();
    if with_radius != 0 && with_radius != parsed.len() {
        return Err("some lines have a radius and others not".into());
    }
    // Velocity and id columns are the header's: every row has them, or none.
    let has_velocity = parsed.first().is_some_and(|r| r.velocity.is_some());
    let has_id = parsed.first().is_some_and(|r| r.id.is_some());
    let extra = columns.as_ref().map_or(&[][..], |c| &c.extra[..]);
    Ok(Particles {
        positions: parsed.iter().map(|r| r.position).collect(),
        radii: (with_radius != 0).then(|| parsed.iter().filter_map(|r| r.radius).collect()),
        velocities: has_velocity.then(|| parsed.iter().filter_map(|r| r.velocity).collect()),
        ids: has_id.then(|| parsed.iter().filter_map(|r| r.id).collect()),
        attributes: extra
            .iter()
            .enumerate()
            .map(|(k, (name, _))| Attribute {
                name: name.clone(),
                components: 1,
                values: parsed.iter().map(|r| r.extra[k]).collect(),
            })
            .collect(),
    })
}

/// One row's particle.
struct Row {
    position: Vec3,
    radius: Option<f32>,
    velocity: Option<Vec3>,
    id: Option<i64>,
    /// The header's other columns, in its order.
    extra: Vec<f32>,
}

/// A line's fields: split at commas, semicolons or tabs when it has any (names may hold
/// spaces: `Pos.x [m]`), else at spaces; trimmed, empty ones dropped.
fn fields(line: &str) -> impl Iterator<Item = &str> {
    let separated = line.contains([',', ';', '\t']);
    let (a, b) = if separated {
        (Some(line.split([',', ';', '\t'])), None)
    } else {
        (None, Some(line.split_whitespace()))
    };
    a.into_iter()
        .flatten()
        .chain(b.into_iter().flatten())
        .map(str::trim)
        .filter(|f| !f.is_empty())
}

/// Row `n`'s particle from its `numbers`, by the header's columns or, without one, as
/// `x y z [radius]`.
fn row(n: usize, numbers: &[f64], columns: Option<&Columns>) -> Result<Row, TextError> {
    let at = |k: usize| numbers[k] as f32;
    match columns {
        Some(c) => {
            if numbers.len() < c.width {
                return Err(format!(
                    "line {n}: {} numbers, the header names {} columns",
                    numbers.len(),
                    c.width
                )
                .into());
            }
            Ok(Row {
                position: Vec3::new(at(c.x[0]), at(c.x[1]), at(c.x[2])),
                radius: c.radius.map(at),
                velocity: c.velocity.map(|v| Vec3::new(at(v[0]), at(v[1]), at(v[2]))),
                id: c.id.map(|k| numbers[k] as i64),
                extra: c.extra.iter().map(|&(_, k)| at(k)).collect(),
            })
        }
        None => match numbers.len() {
            3 | 4 => Ok(Row {
                position: Vec3::new(at(0), at(1), at(2)),
                radius: (numbers.len() == 4).then(|| at(3)),
                velocity: None,
                id: None,
                extra: Vec::new(),
            }),
            k => Err(format!(
                "line {n}: {k} numbers, expected x y z [radius] (or a header naming the columns)"
            )
            .into()),
        },
    }
}

/// Where a CSV header puts the columns read.
#[derive(Debug, PartialEq)]
struct Columns {
    x: [usize; 3],
    radius: Option<usize>,
    velocity: Option<[usize; 3]>,
    id: Option<usize>,
    /// Every other column: its name as the header gives it, its index.
    extra: Vec<(String, usize)>,
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
        let read: Vec<usize> = x
            .iter()
            .chain(velocity.iter().flatten())
            .chain(radius.iter())
            .chain(id.iter())
            .copied()
            .collect();
        let extra: Vec<(String, usize)> = (0..names.len())
            .filter(|k| !read.contains(k))
            .map(|k| (names[k].trim().trim_matches('"').to_string(), k))
            .collect();
        let width = read
            .iter()
            .chain(extra.iter().map(|(_, k)| k))
            .max()
            .map_or(0, |&k| k + 1);
        Some(Columns {
            x,
            radius,
            velocity,
            id,
            extra,
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
