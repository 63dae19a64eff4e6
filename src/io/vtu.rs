//! VTK's XML files of points as ParaView, meshio and SPH codes save them: `.vtu`
//! (`UnstructuredGrid`) and `.vtp` (`PolyData`), every piece; data arrays in `ascii`,
//! inline `binary` (base64) or `appended` (raw or base64), uncompressed or compressed
//! by block (zlib, LZ4 or LZMA, as `vtkXMLWriter` does), headers of 32 or 64 bits,
//! either byte order. `.pvtu`/`.pvtp` list their piece files ([`piece_sources`]).
//! Only the points and their point data are kept; cells are read past.

use std::io::Read;

use rayon::prelude::*;

use quick_xml::events::{BytesStart, Event};

use super::points::PointArray;
use super::scalar::Scalar;

/// A VTK XML file that cannot be read as points.
#[derive(Debug, thiserror::Error)]
pub enum VtuError {
    #[error("not a VTK XML file (no <VTKFile> element)")]
    NotVtu,
    #[error("VTKFile type '{0}': only point sets (UnstructuredGrid, PolyData) hold particles")]
    Type(String),
    #[error("the XML is malformed")]
    Xml(#[source] quick_xml::Error),
    #[error("attribute {name}=\"{value}\": {message}")]
    Attribute {
        name: String,
        value: String,
        message: &'static str,
    },
    #[error("array '{name}': {message}")]
    Array { name: String, message: String },
    #[error("compressor '{0}' is not one VTK writes (zlib, LZ4, LZMA)")]
    Compressor(String),
    #[error("a compressed block does not inflate")]
    Inflate(#[source] std::io::Error),
    #[error("no <Points> array in a piece")]
    NoPoints,
    #[error("the file ends inside <{0}>")]
    Truncated(String),
}

/// The points of a VTK XML file (every piece, in order) and the point-data arrays that
/// every piece has.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VtuPoints {
    /// The points.
    pub positions: Vec<[f64; 3]>,
    /// The point data arrays.
    pub arrays: Vec<PointArray>,
}

/// How binary data is laid out, from the `<VTKFile>` element.
#[derive(Debug, Clone, Copy)]
struct Layout {
    big_endian: bool,
    /// Bytes of a header integer: 4 (`UInt32`, the default) or 8 (`UInt64`).
    header: usize,
    compressor: Compressor,
    /// The most bytes any array may inflate to (the caller's memory bound).
    limit: u64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Compressor {
    None,
    Zlib,
    Lz4,
    Lzma,
}

/// A `<DataArray>` of the point data or the points, before its values are decoded.
struct ArrayTag {
    name: String,
    kind: Scalar,
    components: usize,
    format: Format,
    /// Appended arrays: where the array starts in the appended data.
    offset: usize,
    text: String,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Binary,
    Appended,
}

/// An array's element type, by VTK XML's name for it (both spellings).
fn scalar_type(name: &str) -> Option<Scalar> {
    Some(match name {
        "Int8" | "Char" => Scalar::I8,
        "UInt8" | "UnsignedChar" => Scalar::U8,
        "Int16" | "Short" => Scalar::I16,
        "UInt16" | "UnsignedShort" => Scalar::U16,
        "Int32" | "Int" => Scalar::I32,
        "UInt32" | "UnsignedInt" => Scalar::U32,
        "Int64" | "Long" | "IdType" => Scalar::I64,
        "UInt64" | "UnsignedLong" => Scalar::U64,
        "Float32" | "Float" => Scalar::F32,
        "Float64" | "Double" => Scalar::F64,
        _ => return None,
    })
}

/// One `<Piece>`'s point count and the arrays read in it.
#[derive(Default)]
struct Piece {
    points: usize,
    positions: Option<ArrayTag>,
    data: Vec<ArrayTag>,
}

/// The `Source` files a parallel `.pvtu`/`.pvtp` names, in order (relative to its folder).
pub fn piece_sources(bytes: &[u8]) -> Result<Vec<String>, VtuError> {
    let mut reader = quick_xml::Reader::from_reader(bytes);
    let mut sources = Vec::new();
    let mut root = false;
    loop {
        match reader.read_event().map_err(VtuError::Xml)? {
            Event::Start(e) | Event::Empty(e) => match e.name().as_ref() {
                b"VTKFile" => root = true,
                b"Piece" => {
                    if let Some(source) = attribute(&e, "Source")? {
                        sources.push(source);
                    }
                }
                _ => {}
            },
            Event::Eof => break,
            _ => {}
        }
    }
    if !root {
        return Err(VtuError::NotVtu);
    }
    Ok(sources)
}

/// Reads a `.vtu`/`.vtp` file's bytes. Compressed arrays inflate to at most `limit`
/// bytes each (the caller's memory bound); beyond, the file is refused.
pub fn parse(bytes: &[u8], limit: u64) -> Result<VtuPoints, VtuError> {
    // Raw appended data is not XML: the markup ends where it starts.
    let (markup, appended) = split_appended(bytes);
    let (layout, pieces) = read_markup(markup, appended.is_some(), limit)?;
    join_pieces(&pieces, &layout.ok_or(VtuError::NotVtu)?, appended)
}

/// The markup's layout (`<VTKFile>`'s attributes) and its pieces' arrays, as tags; with
/// `appended` data after it, the markup ends where that starts.
fn read_markup(
    markup: &[u8],
    appended: bool,
    limit: u64,
) -> Result<(Option<Layout>, Vec<Piece>), VtuError> {
    let mut reader = quick_xml::Reader::from_reader(markup);
    let mut layout = None;
    let mut pieces: Vec<Piece> = Vec::new();
    // Where the reader is: inside <Points>, inside <PointData>, inside a DataArray.
    let (mut in_points, mut in_point_data) = (false, false);
    let mut current: Option<ArrayTag> = None;
    // The elements open, innermost last: the file must close them all.
    let mut open: Vec<String> = Vec::new();
    loop {
        let event = match reader.read_event() {
            Ok(event) => event,
            // The markup was cut where the appended data starts.
            Err(_) if appended && layout.is_some() => break,
            Err(e) => return Err(VtuError::Xml(e)),
        };
        let (start, empty) = match &event {
            Event::Start(e) => (Some(e), false),
            Event::Empty(e) => (Some(e), true),
            _ => (None, false),
        };
        if let Some(e) = start {
            if !empty {
                open.push(String::from_utf8_lossy(e.name().as_ref()).into_owned());
            }
            match e.name().as_ref() {
                b"VTKFile" => layout = Some(read_layout(e, limit)?),
                b"Piece" => {
                    let points = match attribute(e, "NumberOfPoints")? {
                        Some(n) => number(&n, "NumberOfPoints")?,
                        None => 0,
                    };
                    pieces.push(Piece {
                        points,
                        ..Piece::default()
                    });
                }
                b"Points" => in_points = !empty,
                b"PointData" => in_point_data = !empty,
                b"DataArray" if in_points || in_point_data => {
                    let tag = array_tag(e)?;
                    if empty {
                        keep(&mut pieces, tag, in_points)?;
                    } else {
                        current = Some(tag);
                    }
                }
                _ => {}
            }
            continue;
        }
        match event {
            Event::Text(t) => {
                if let Some(tag) = &mut current {
                    let text = t.unescape().map_err(VtuError::Xml)?;
                    tag.text.push_str(&text);
                }
            }
            Event::CData(t) => {
                if let Some(tag) = &mut current {
                    tag.text.push_str(&String::from_utf8_lossy(&t));
                }
            }
            Event::End(e) => {
                open.pop();
                match e.name().as_ref() {
                    b"Points" => in_points = false,
                    b"PointData" => in_point_data = false,
                    b"DataArray" => {
                        if let Some(tag) = current.take() {
                            keep(&mut pieces, tag, in_points)?;
                        }
                    }
                    _ => {}
                }
            }
            Event::Eof => {
                // Appended data cuts the markup inside <VTKFile>: that is its end.
                if !appended {
                    if let Some(inner) = open.pop() {
                        return Err(VtuError::Truncated(inner));
                    }
                }
                break;
            }
            _ => {}
        }
    }
    Ok((layout, pieces))
}

/// The pieces' points one after another, with the arrays every piece has, decoded.
fn join_pieces(
    pieces: &[Piece],
    layout: &Layout,
    appended: Option<(&[u8], bool)>,
) -> Result<VtuPoints, VtuError> {
    let mut out = VtuPoints::default();
    let mut arrays: Option<Vec<PointArray>> = None;
    for piece in pieces {
        let tag = piece.positions.as_ref().ok_or(VtuError::NoPoints)?;
        if tag.components != 3 {
            return Err(VtuError::Array {
                name: "Points".into(),
                message: format!("{} components, not 3", tag.components),
            });
        }
        let values = decode(tag, piece.points, layout, appended)?;
        out.positions
            .extend(values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        let mut these = Vec::new();
        for tag in &piece.data {
            these.push(PointArray {
                name: tag.name.clone(),
                components: tag.components,
                values: decode(tag, piece.points, layout, appended)?,
            });
        }
        // Only the arrays every piece has, appended piece after piece.
        arrays = Some(match arrays {
            None => these,
            Some(mut so_far) => {
                so_far.retain_mut(|a| {
                    match these
                        .iter()
                        .find(|b| b.name == a.name && b.components == a.components)
                    {
                        Some(b) => {
                            a.values.extend_from_slice(&b.values);
                            true
                        }
                        None => false,
                    }
                });
                so_far
            }
        });
    }
    out.arrays = arrays.unwrap_or_default();
    Ok(out)
}

/// The markup before `<AppendedData …>` and the appended bytes after its `_` (with the
/// element's encoding), when the file has some.
fn split_appended(bytes: &[u8]) -> (&[u8], Option<(&[u8], bool)>) {
    let tag = b"<AppendedData";
    let Some(at) = bytes.windows(tag.len()).position(|w| w == tag) else {
        return (bytes, None);
    };
    let rest = &bytes[at..];
    let Some(close) = rest.iter().position(|&b| b == b'>') else {
        return (&bytes[..at], None);
    };
    let head = String::from_utf8_lossy(&rest[..close]);
    let base64 = head.contains("\"base64\"") || head.contains("'base64'");
    let after = &rest[close + 1..];
    let data = match after.iter().position(|&b| b == b'_') {
        Some(u) => &after[u + 1..],
        None => &after[after.len()..],
    };
    (&bytes[..at], Some((data, base64)))
}

/// The `<VTKFile>` attributes that say how binary data is laid out.
fn read_layout(e: &BytesStart, limit: u64) -> Result<Layout, VtuError> {
    let kind = attribute(e, "type")?.unwrap_or_default();
    if !matches!(kind.as_str(), "UnstructuredGrid" | "PolyData") {
        return Err(VtuError::Type(kind));
    }
    let big_endian = attribute(e, "byte_order")?.as_deref() == Some("BigEndian");
    let header = match attribute(e, "header_type")?.as_deref() {
        None | Some("UInt32") => 4,
        Some("UInt64") => 8,
        Some(other) => {
            return Err(VtuError::Attribute {
                name: "header_type".into(),
                value: other.into(),
                message: "expected UInt32 or UInt64",
            })
        }
    };
    let compressor = match attribute(e, "compressor")?.as_deref() {
        None | Some("") => Compressor::None,
        Some("vtkZLibDataCompressor") => Compressor::Zlib,
        Some("vtkLZ4DataCompressor") => Compressor::Lz4,
        Some("vtkLZMADataCompressor") => Compressor::Lzma,
        Some(other) => return Err(VtuError::Compressor(other.into())),
    };
    Ok(Layout {
        big_endian,
        header,
        compressor,
        limit,
    })
}

fn array_tag(e: &BytesStart) -> Result<ArrayTag, VtuError> {
    let name = attribute(e, "Name")?.unwrap_or_default();
    let kind_name = attribute(e, "type")?.unwrap_or_default();
    let kind = scalar_type(&kind_name).ok_or_else(|| VtuError::Array {
        name: name.clone(),
        message: format!("type '{kind_name}' is not a number type"),
    })?;
    let components = match attribute(e, "NumberOfComponents")? {
        Some(n) => number(&n, "NumberOfComponents")?,
        None => 1,
    };
    if components == 0 {
        return Err(VtuError::Array {
            name,
            message: "0 components".into(),
        });
    }
    let format = match attribute(e, "format")?.as_deref() {
        None | Some("ascii") => Format::Ascii,
        Some("binary") => Format::Binary,
        Some("appended") => Format::Appended,
        Some(other) => {
            return Err(VtuError::Attribute {
                name: "format".into(),
                value: other.into(),
                message: "expected ascii, binary or appended",
            })
        }
    };
    let offset = match attribute(e, "offset")? {
        Some(n) => number(&n, "offset")?,
        None => 0,
    };
    Ok(ArrayTag {
        name,
        kind,
        components,
        format,
        offset,
        text: String::new(),
    })
}

/// Files a finished DataArray with the last piece: the points' or the point data's.
fn keep(pieces: &mut [Piece], tag: ArrayTag, in_points: bool) -> Result<(), VtuError> {
    let piece = pieces.last_mut().ok_or(VtuError::Array {
        name: tag.name.clone(),
        message: "outside any <Piece>".into(),
    })?;
    if in_points {
        piece.positions = Some(tag);
    } else {
        piece.data.push(tag);
    }
    Ok(())
}

fn attribute(e: &BytesStart, name: &str) -> Result<Option<String>, VtuError> {
    match e
        .try_get_attribute(name)
        .map_err(|err| VtuError::Xml(err.into()))?
    {
        Some(a) => Ok(Some(
            a.unescape_value().map_err(VtuError::Xml)?.into_owned(),
        )),
        None => Ok(None),
    }
}

fn number(text: &str, name: &str) -> Result<usize, VtuError> {
    text.trim().parse().map_err(|_| VtuError::Attribute {
        name: name.into(),
        value: text.into(),
        message: "expected a count",
    })
}

/// The array's `points × components` values, whatever its format.
fn decode(
    tag: &ArrayTag,
    points: usize,
    layout: &Layout,
    appended: Option<(&[u8], bool)>,
) -> Result<Vec<f64>, VtuError> {
    let fail = |message: String| VtuError::Array {
        name: tag.name.clone(),
        message,
    };
    let n = points
        .checked_mul(tag.components)
        .ok_or_else(|| fail("too many values".into()))?;
    let bytes = n
        .checked_mul(tag.kind.size())
        .filter(|&b| b as u64 <= layout.limit)
        .ok_or_else(|| fail(format!("{points} points: more than the file can hold")))?;
    let raw = match tag.format {
        Format::Ascii => {
            let mut values = Vec::with_capacity(n.min(tag.text.len() / 2 + 1));
            for word in tag.text.split_ascii_whitespace().take(n) {
                values.push(
                    word.parse::<f64>()
                        .map_err(|_| fail(format!("'{word}' is not a number")))?,
                );
            }
            if values.len() < n {
                return Err(fail(format!("{} values for {n}", values.len())));
            }
            return Ok(values);
        }
        Format::Binary => {
            let mut stream = Stream::Base64(tag.text.as_bytes(), 0, Vec::new());
            block(&mut stream, layout)
        }
        Format::Appended => {
            let (data, base64) = appended.ok_or_else(|| fail("no <AppendedData>".into()))?;
            let mut stream = if base64 {
                Stream::Base64(data, tag.offset, Vec::new())
            } else {
                Stream::Raw(data, tag.offset)
            };
            block(&mut stream, layout)
        }
    }
    // The stream's errors name no array: this one.
    .map_err(|e| match e {
        VtuError::Array { name, message } if name.is_empty() => fail(message),
        other => other,
    })?;
    if raw.len() < bytes {
        return Err(fail(format!("{} bytes for {bytes}", raw.len())));
    }
    let size = tag.kind.size();
    Ok(raw[..bytes]
        .chunks_exact(size)
        .map(|b| tag.kind.read(b, layout.big_endian))
        .collect())
}

/// Where an array's binary bytes come from: raw appended bytes, or base64 text (inline,
/// or appended) decoded four characters at a time — VTK encodes a header and its data
/// separately, each padded, so the text is several base64 strings end to end.
enum Stream<'a> {
    Raw(&'a [u8], usize),
    /// The text, where the next quartet starts, and the bytes decoded but not taken yet.
    Base64(&'a [u8], usize, Vec<u8>),
}

impl Stream<'_> {
    /// The next `n` bytes.
    fn take(&mut self, n: usize) -> Result<Vec<u8>, VtuError> {
        let short = |what: &str| VtuError::Array {
            name: String::new(),
            message: format!("the data ends {what}"),
        };
        match self {
            Stream::Raw(bytes, at) => {
                let end = at.checked_add(n).filter(|&e| e <= bytes.len());
                let end = end.ok_or_else(|| short("early"))?;
                let out = bytes[*at..end].to_vec();
                *at = end;
                Ok(out)
            }
            Stream::Base64(text, at, pending) => {
                // Four characters make at most three bytes: what is left cannot hold n.
                if n.saturating_sub(pending.len())
                    > (text.len() - (*at).min(text.len())) / 4 * 3 + 3
                {
                    return Err(short("early"));
                }
                let mut out = std::mem::take(pending);
                out.reserve(n.saturating_sub(out.len()));
                let mut quad = [0u8; 4];
                while out.len() < n {
                    // Four base64 characters in a row (nearly all of them): by table.
                    if let Some(q) = text.get(*at..*at + 4) {
                        let [a, b, c, d] = [0, 1, 2, 3].map(|k| BASE64[usize::from(q[k])]);
                        if a | b | c | d < 64 {
                            let w = u32::from(a) << 18
                                | u32::from(b) << 12
                                | u32::from(c) << 6
                                | u32::from(d);
                            out.extend_from_slice(&w.to_be_bytes()[1..]);
                            *at += 4;
                            continue;
                        }
                    }
                    let mut k = 0;
                    while k < 4 {
                        let c = *text
                            .get(*at)
                            .ok_or_else(|| short("inside the base64 text"))?;
                        *at += 1;
                        if !c.is_ascii_whitespace() {
                            quad[k] = c;
                            k += 1;
                        }
                    }
                    let bytes = base64_quad(quad)
                        .ok_or_else(|| short("at a character that is not base64"))?;
                    out.extend_from_slice(bytes.as_slice());
                }
                *pending = out.split_off(n);
                Ok(out)
            }
        }
    }

    fn header(&mut self, layout: &Layout) -> Result<u64, VtuError> {
        let b = self.take(layout.header)?;
        let mut v = [0u8; 8];
        if layout.big_endian {
            v[8 - layout.header..].copy_from_slice(&b);
            Ok(u64::from_be_bytes(v))
        } else {
            v[..layout.header].copy_from_slice(&b);
            Ok(u64::from_le_bytes(v))
        }
    }
}

/// Each byte's base64 value; 64 and above for padding, white space and other bytes.
const BASE64: [u8; 256] = {
    let mut table = [255u8; 256];
    let mut k = 0;
    while k < 64 {
        let c = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/"[k];
        table[c as usize] = k as u8;
        k += 1;
    }
    table
};

/// Up to three bytes from four base64 characters (`=` pads).
struct Quad {
    bytes: [u8; 3],
    len: usize,
}

impl Quad {
    fn as_slice(&self) -> &[u8] {
        &self.bytes[..self.len]
    }
}

fn base64_quad(q: [u8; 4]) -> Option<Quad> {
    let value = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let pads = q.iter().rev().take_while(|&&c| c == b'=').count();
    if pads > 2 {
        return None;
    }
    let mut word = 0u32;
    for &c in &q[..4 - pads] {
        word = word << 6 | value(c)?;
    }
    word <<= 6 * pads as u32;
    let b = word.to_be_bytes();
    Some(Quad {
        bytes: [b[1], b[2], b[3]],
        len: 3 - pads,
    })
}

/// One array's bytes from its stream: a byte count then the data, or, compressed, block
/// counts and sizes then each block.
fn block(stream: &mut Stream, layout: &Layout) -> Result<Vec<u8>, VtuError> {
    let too_big = || VtuError::Array {
        name: String::new(),
        message: "its sizes exceed what the file can hold".into(),
    };
    if layout.compressor == Compressor::None {
        let size = stream.header(layout)?;
        if size > layout.limit {
            return Err(too_big());
        }
        return stream.take(size as usize);
    }
    let blocks = stream.header(layout)?;
    let block_size = stream.header(layout)?;
    let last = stream.header(layout)?;
    let total = match blocks {
        0 => Some(0),
        _ if last == 0 => blocks.checked_mul(block_size),
        _ => (blocks - 1)
            .checked_mul(block_size)
            .and_then(|t| t.checked_add(last)),
    };
    let total = total.filter(|&t| t <= layout.limit).ok_or_else(too_big)?;
    let mut sizes = Vec::new();
    for _ in 0..blocks {
        sizes.push(stream.header(layout)?);
    }
    // The blocks, taken in order, then inflated on all threads (VTK compresses each
    // block on its own, 32 KiB by default).
    let mut packed = Vec::with_capacity(sizes.len());
    for (k, &size) in sizes.iter().enumerate() {
        let expected = if k as u64 + 1 == blocks && last != 0 {
            last
        } else {
            block_size
        };
        if size > layout.limit {
            return Err(too_big());
        }
        packed.push((stream.take(size as usize)?, expected));
    }
    let parts = packed
        .par_iter()
        .enumerate()
        .map(|(k, (packed, expected))| {
            let mut part = Vec::new();
            inflate(packed, *expected, layout.compressor, &mut part)?;
            if part.len() as u64 != *expected {
                return Err(VtuError::Array {
                    name: String::new(),
                    message: format!("block {k} inflates to {} bytes, not {expected}", part.len()),
                });
            }
            Ok(part)
        })
        .collect::<Result<Vec<_>, VtuError>>()?;
    let mut out = Vec::with_capacity(total as usize);
    for part in parts {
        out.extend_from_slice(&part);
    }
    Ok(out)
}

/// Appends one compressed block, inflated to at most `expected` bytes, to `out`.
fn inflate(
    packed: &[u8],
    expected: u64,
    how: Compressor,
    out: &mut Vec<u8>,
) -> Result<(), VtuError> {
    match how {
        Compressor::None => out.extend_from_slice(packed),
        Compressor::Zlib => {
            // One byte past the stated size: a block longer than it says is an error
            // (the caller compares the sizes), not cut silently.
            flate2::read::ZlibDecoder::new(packed)
                .take(expected + 1)
                .read_to_end(out)
                .map_err(VtuError::Inflate)?;
        }
        Compressor::Lz4 => {
            let block = lz4_flex::block::decompress(packed, expected as usize)
                .map_err(|e| VtuError::Inflate(std::io::Error::other(e)))?;
            out.extend_from_slice(&block);
        }
        Compressor::Lzma => {
            // lzma-rs holds a whole xz block in memory before writing any of it: the
            // chunks' stated sizes are summed first, so that a bomb stops before it
            // inflates.
            let unpacked = xz_unpacked_size(packed, expected).map_err(|e| {
                VtuError::Inflate(std::io::Error::other(format!("LZMA block: {e}")))
            })?;
            if unpacked > expected {
                return Err(VtuError::Inflate(std::io::Error::other(
                    "the block inflates past its stated size",
                )));
            }
            let mut block = Bounded {
                out,
                room: expected,
            };
            lzma_rs::xz_decompress(&mut std::io::BufReader::new(packed), &mut block)
                .map_err(|e| VtuError::Inflate(std::io::Error::other(e.to_string())))?;
        }
    }
    Ok(())
}

/// The bytes an xz stream's LZMA2 chunks say they hold, read from their headers without
/// decompressing; at most a little past `limit` (the walk stops once the sum passes it).
/// The xz layout: a 12-byte stream header, then blocks (a header of 4·(n+1) bytes, LZMA2
/// chunks up to a 0 byte, padding to 4 bytes, the check), then the index.
fn xz_unpacked_size(xz: &[u8], limit: u64) -> Result<u64, &'static str> {
    const MAGIC: [u8; 6] = [0xFD, b'7', b'z', b'X', b'Z', 0];
    let truncated = "truncated";
    if xz.len() < 12 || xz[..6] != MAGIC {
        return Err("not an xz stream");
    }
    let check = match xz[7] & 0x0F {
        0 => 0,
        t => 4usize << ((t - 1) / 3),
    };
    let (mut at, mut total) = (12usize, 0u64);
    let byte = |at: usize| xz.get(at).copied().ok_or(truncated);
    let pair = |at: usize| Ok::<u64, &str>(u64::from(byte(at)?) << 8 | u64::from(byte(at + 1)?));
    loop {
        let start = at;
        let header = byte(at)?;
        if header == 0 {
            // The index: every block read.
            return Ok(total);
        }
        at += 4 * (usize::from(header) + 1);
        loop {
            let control = byte(at)?;
            at += 1;
            let (unpacked, packed) = match control {
                0 => break,
                // Stored chunks, with or without a dictionary reset.
                1 | 2 => {
                    let n = pair(at)? + 1;
                    at += 2;
                    (n, n)
                }
                0x80..=0xFF => {
                    let unpacked = (u64::from(control & 0x1F) << 16 | pair(at)?) + 1;
                    let packed = pair(at + 2)? + 1;
                    at += 4 + usize::from(control >= 0xC0);
                    (unpacked, packed)
                }
                _ => return Err("not an LZMA2 chunk"),
            };
            total += unpacked;
            if total > limit {
                return Ok(total);
            }
            at = at.checked_add(packed as usize).ok_or(truncated)?;
        }
        at += (4 - (at - start) % 4) % 4 + check;
    }
}

/// A writer that takes at most `room` more bytes: a block that inflates past its stated
/// size fails instead of filling the memory.
struct Bounded<'a> {
    out: &'a mut Vec<u8>,
    room: u64,
}

impl std::io::Write for Bounded<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if buf.len() as u64 > self.room {
            return Err(std::io::Error::other(
                "the block inflates past its stated size",
            ));
        }
        self.room -= buf.len() as u64;
        self.out.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}
