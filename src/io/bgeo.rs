//! Houdini's classic binary geometry (`BgeoV` version 5) as partio writes it — the BGEO
//! of SPlisHSPlasH's `enablePartioExport` and of other partio-based tools, gzipped or not.
//! Only the points and their attributes are kept. Houdini 12+'s own `.bgeo` is binary
//! JSON, another format, named as such when met.

use std::io::Read;

use rayon::prelude::*;

use super::points::PointArray;
use super::scalar::Scalar;

/// A BGEO file that cannot be read as points.
#[derive(Debug, thiserror::Error)]
pub enum BgeoError {
    #[error("not a classic BGEO file (it must start with 'BgeoV', optionally gzipped)")]
    NotBgeo,
    #[error("Houdini's binary JSON geometry (the .bgeo Houdini 12+ saves) is not read; save the points as classic BGEO, PLY or VDB points")]
    JsonGeometry,
    #[error("BGEO version {0}: only version 5 (partio's) is read")]
    Version(i32),
    #[error("the gzip stream is broken")]
    Gzip(#[source] std::io::Error),
    #[error("the file ends inside {0}")]
    Truncated(&'static str),
    #[error("attribute '{name}': {message}")]
    Attribute { name: String, message: String },
}

/// The points of a BGEO file and their attributes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BgeoPoints {
    /// The points' `P`.
    pub positions: Vec<[f32; 3]>,
    /// The other point attributes (`v`, `id`, `pscale`, ...).
    pub attributes: Vec<PointArray>,
}

/// The bytes past a gzip header inflated (at most `limit` bytes), or as they are.
fn inflated(bytes: &[u8], limit: u64) -> Result<std::borrow::Cow<'_, [u8]>, BgeoError> {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        flate2::read::MultiGzDecoder::new(bytes)
            .take(limit)
            .read_to_end(&mut out)
            .map_err(BgeoError::Gzip)?;
        return Ok(out.into());
    }
    Ok(bytes.into())
}

/// Reads a BGEO file's bytes. A gzipped file inflates to at most `limit` bytes (the
/// caller's memory bound); beyond, it reads as truncated.
pub fn parse(bytes: &[u8], limit: u64) -> Result<BgeoPoints, BgeoError> {
    let bytes = inflated(bytes, limit)?;
    if bytes.starts_with(b"\x7fNSJ") || bytes.first() == Some(&b'[') {
        return Err(BgeoError::JsonGeometry);
    }
    if !bytes.starts_with(b"BgeoV") {
        return Err(BgeoError::NotBgeo);
    }
    let mut r = Cursor {
        bytes: &bytes,
        at: 5,
    };
    let version = r.i32("the header")?;
    if version != 5 {
        return Err(BgeoError::Version(version));
    }
    let mut header = [0i32; 8];
    for h in header.iter_mut() {
        *h = r.i32("the header")?;
    }
    let [points, _prims, _point_groups, _prim_groups, point_attributes, ..] = header;
    let count =
        |v: i32, what: &'static str| usize::try_from(v).map_err(|_| BgeoError::Truncated(what));
    let (points, point_attributes) = (
        count(points, "the header")?,
        count(point_attributes, "the header")?,
    );
    // Each point takes 16 bytes at least: never reserve more than the file holds.
    if points.saturating_mul(16) > bytes.len() {
        return Err(BgeoError::Truncated("the points"));
    }
    let mut layout = Vec::with_capacity(point_attributes.min(1024));
    for _ in 0..point_attributes {
        let length = usize::from(r.u16("an attribute's name")?);
        let name = String::from_utf8_lossy(r.take(length, "an attribute's name")?).into_owned();
        let components = usize::from(r.u16("an attribute")?);
        let kind = match r.i32("an attribute")? {
            0 | 5 => Scalar::F32,
            1 => Scalar::I32,
            other => {
                return Err(BgeoError::Attribute {
                    name,
                    message: format!("Houdini type {other} (strings, indices) is not read"),
                })
            }
        };
        r.take(components * 4, "an attribute's default")?;
        layout.push((name, components, kind));
    }
    // Fixed-size records, big endian: P as x y z w, then each attribute's components.
    // Checked whole once, then read in parallel, a column at a time.
    let record = 16 + layout.iter().map(|(_, c, _)| 4 * c).sum::<usize>();
    let body = r.take(
        points
            .checked_mul(record)
            .ok_or(BgeoError::Truncated("the points"))?,
        "the points",
    )?;
    let records = || body.par_chunks_exact(record);
    let value = |b: &[u8], k: usize, kind: Scalar| kind.read(&b[4 * k..], true);
    let positions = records()
        .map(|b| {
            let p = [0, 1, 2].map(|k| value(b, k, Scalar::F32) as f32);
            let w = value(b, 3, Scalar::F32) as f32;
            // Homogeneous, as Houdini's points are; partio writes w = 1.
            if w != 0.0 && w != 1.0 {
                p.map(|c| c / w)
            } else {
                p
            }
        })
        .collect();
    let mut first = 4;
    let mut attributes = Vec::with_capacity(layout.len());
    for (name, components, kind) in layout {
        let mut values = vec![0.0; points * components];
        values
            .par_chunks_exact_mut(components.max(1))
            .zip(records())
            .for_each(|(row, b)| {
                for (v, k) in row.iter_mut().zip(first..) {
                    *v = value(b, k, kind);
                }
            });
        attributes.push(PointArray {
            name,
            components,
            values,
        });
        first += components;
    }
    let out = BgeoPoints {
        positions,
        attributes,
    };
    Ok(out)
}

struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], BgeoError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or(BgeoError::Truncated(what))?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }
    fn u16(&mut self, what: &'static str) -> Result<u16, BgeoError> {
        Ok(u16::from_be_bytes(self.take(2, what)?.try_into().unwrap()))
    }
    fn i32(&mut self, what: &'static str) -> Result<i32, BgeoError> {
        Ok(i32::from_be_bytes(self.take(4, what)?.try_into().unwrap()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::points::find_array;

    /// A partio-style file: `points` with an int `id` and a vector `v`.
    fn partio(points: &[([f32; 3], i32, [f32; 3])]) -> Vec<u8> {
        let mut b = b"BgeoV".to_vec();
        let header = [5, points.len() as i32, 0, 0, 0, 2, 0, 0, 0];
        b.extend(header.iter().flat_map(|v: &i32| v.to_be_bytes()));
        for (name, size, kind) in [("id", 1u16, 1i32), ("v", 3, 5)] {
            b.extend((name.len() as u16).to_be_bytes());
            b.extend(name.as_bytes());
            b.extend(size.to_be_bytes());
            b.extend(kind.to_be_bytes());
            b.extend(vec![0u8; 4 * size as usize]);
        }
        for (p, id, v) in points {
            b.extend(p.iter().chain(&[1.0]).flat_map(|c| c.to_be_bytes()));
            b.extend(id.to_be_bytes());
            b.extend(v.iter().flat_map(|c| c.to_be_bytes()));
        }
        b.extend([0x00, 0xff]);
        b
    }

    #[test]
    fn points_and_attributes_gzipped_or_not() {
        let raw = partio(&[
            ([1.0, 2.0, 3.0], 7, [0.0, -1.0, 0.5]),
            ([4.0, 5.0, 6.0], 9, [1.0; 3]),
        ]);
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut gz, &raw).unwrap();
        for bytes in [raw.clone(), gz.finish().unwrap()] {
            let p = parse(&bytes, 1 << 20).unwrap();
            assert_eq!(p.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
            assert_eq!(
                find_array(&p.attributes, &["id"], 1).unwrap().values,
                vec![7.0, 9.0]
            );
            assert_eq!(
                find_array(&p.attributes, &["v"], 3).unwrap().values[1],
                -1.0
            );
        }
    }

    #[test]
    fn other_files_are_named() {
        assert!(matches!(parse(b"ply\n", 100), Err(BgeoError::NotBgeo)));
        assert!(matches!(
            parse(b"\x7fNSJb....", 100),
            Err(BgeoError::JsonGeometry)
        ));
        let raw = partio(&[([1.0, 2.0, 3.0], 7, [0.0; 3])]);
        assert!(matches!(
            parse(&raw[..60], 100),
            Err(BgeoError::Truncated(_))
        ));
        // A header claiming a billion points in a small file: refused before reserving.
        let mut lying = raw.clone();
        lying[9..13].copy_from_slice(&1_000_000_000i32.to_be_bytes());
        assert!(matches!(
            parse(&lying, 1 << 20),
            Err(BgeoError::Truncated(_))
        ));
    }
}
