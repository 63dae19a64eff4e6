//! A structural check of a VDB file, done in Rust before OpenVDB reads it.
//!
//! OpenVDB trusts the counts in a file's header: cut inside the header, it may loop for
//! minutes on a failed stream or report a file with no grids. Walking the header, the file
//! metadata and each grid descriptor (whose end offset must lie inside the file) turns every
//! truncation into a clear error, while reading only a few hundred bytes.

use std::io::{Read, Seek, SeekFrom};

/// `OPENVDB_MAGIC` as the 8 little-endian bytes every VDB file starts with.
pub const MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];

// File format versions at which the header changed (openvdb/version.h).
const VERSION_LIBRARY_NUMBERS: u32 = 211;
const VERSION_GRID_OFFSETS_FLAG: u32 = 212;
const VERSION_INSTANCING: u32 = 216;
const VERSION_UUID_AS_TEXT: u32 = 218;
const VERSION_SELECTIVE_COMPRESSION: u32 = 220;
const VERSION_PER_GRID_COMPRESSION: u32 = 222;

/// Far more than any real file holds; a larger count means a corrupt header.
const MAX_COUNT: u32 = 1 << 20;

/// Why a file's layout cannot be walked, or the grid asked for is not in it.
#[derive(Debug, thiserror::Error)]
pub enum LayoutError {
    /// The file could not be read where the walk needed it.
    #[error("cannot read {what}: {source}")]
    Io {
        what: String,
        #[source]
        source: std::io::Error,
    },
    /// The bytes are not a whole VDB file, or do not hold the grid asked for.
    #[error("{0}")]
    Bad(String),
}

impl From<String> for LayoutError {
    fn from(message: String) -> Self {
        LayoutError::Bad(message)
    }
}

impl From<&str> for LayoutError {
    fn from(message: &str) -> Self {
        LayoutError::Bad(message.to_string())
    }
}

/// What the walk found: enough to describe the file, nothing OpenVDB needs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// The file format version.
    pub version: u32,
    /// Whether grid descriptors carry offsets (then `grids` lists them all).
    pub has_offsets: bool,
    /// `(name, type)` of each grid descriptor, when the file records grid offsets.
    pub grids: Vec<(String, String)>,
    /// Each grid's size in memory as its writer recorded it (OpenVDB's `file_mem_bytes`
    /// statistic, written by default), beside `grids`: what reading it will take,
    /// known before it is read.
    pub memory: Vec<Option<u64>>,
}

/// OpenVDB's separator in a file's unique grid names: the second grid named `a` is
/// `a\x1e1`, an unnamed one `\x1e0` (`GridDescriptor::addSuffix`).
const UNIQUE_SEPARATOR: char = '\x1e';

/// A unique grid name as OpenVDB prints it: `a[1]`, `[0]`.
pub fn printable_name(unique: &str) -> String {
    match unique.split_once(UNIQUE_SEPARATOR) {
        Some((name, n)) => format!("{name}[{n}]"),
        None => unique.to_string(),
    }
}

/// The grid's own name within a unique name (`a` of `a\x1e1`).
fn base_name(unique: &str) -> &str {
    unique
        .split_once(UNIQUE_SEPARATOR)
        .map_or(unique, |(name, _)| name)
}

/// The value type a tree type holds, as OpenVDB and `info` name it: `Tree_float_5_4_3`
/// and `Tree_float_5_4_3_HalfFloat` are `float`, `Tree_vec3s_5_4_3` is `vec3s`.
pub fn value_type(tree: &str) -> &str {
    let Some(rest) = tree.strip_prefix("Tree_") else {
        return tree;
    };
    // The value type ends where the node sizes begin.
    rest.match_indices('_')
        .find(|(i, _)| rest[i + 1..].starts_with(|c: char| c.is_ascii_digit()))
        .map_or(rest, |(i, _)| &rest[..i])
}

impl Layout {
    /// `grids: 'a' (float), ...` for error messages.
    pub fn describe_grids(&self) -> String {
        if self.grids.is_empty() {
            return "the file has no grids".into();
        }
        let list: Vec<String> = self
            .grids
            .iter()
            .map(|(name, kind)| format!("'{}' ({})", printable_name(name), value_type(kind)))
            .collect();
        format!("grids: {}", list.join(", "))
    }

    /// What a Mantaflow liquid cache without `phi` lacks: Blender writes only the
    /// particles and velocity the final surface needs unless the cache is resumable.
    fn mantaflow_hint(&self) -> &'static str {
        let has = |name: &str, kind: &str| {
            self.grids
                .iter()
                .any(|(g, k)| base_name(g) == name && value_type(k).starts_with(kind))
        };
        if has("particles", "ptdataidx") && has("velocity", "vec3") && !has("phi", "") {
            "; a Mantaflow cache keeps phi only when baked resumable: tick the domain's Cache > Is Resumable and bake again"
        } else {
            ""
        }
    }

    /// The grid `wanted` names: a grid of that name (the first of several), of that
    /// printed unique name (`a[1]`, `[0]`), else the grid at that index in file order.
    fn find(&self, wanted: &str) -> Option<&(String, String)> {
        self.position(wanted).map(|i| &self.grids[i])
    }

    /// [`Layout::find`]'s index in `grids`.
    fn position(&self, wanted: &str) -> Option<usize> {
        let by = |matches: &dyn Fn(&str) -> bool| self.grids.iter().position(|(g, _)| matches(g));
        by(&|g| g == wanted)
            .or_else(|| by(&|g| printable_name(g) == wanted))
            .or_else(|| by(&|g| base_name(g) == wanted))
            .or_else(|| {
                wanted
                    .parse::<usize>()
                    .ok()
                    .filter(|&i| i < self.grids.len())
            })
    }
}

impl Layout {
    /// The most memory reading a grid of `name` ([`Layout::find`]), or any grid whose
    /// type starts with `kind` when `None`, will take, as the writer recorded it.
    pub fn recorded_memory(&self, name: Option<&str>, kind: &str) -> Option<u64> {
        let chosen: Vec<usize> = match name {
            Some(n) => self.position(n).into_iter().collect(),
            None => (0..self.grids.len())
                .filter(|&i| self.grids[i].1.starts_with(kind))
                .collect(),
        };
        chosen
            .into_iter()
            .filter_map(|i| self.memory.get(i).copied().flatten())
            .max()
    }

    /// The grid to read, by its unique name in the file as OpenVDB's lookup takes it
    /// (`a[1]`: given as stored, `a\x1e1`, it finds the first `a`): `name`
    /// ([`Layout::find`]), or else the level set a simulation names ([`LEVEL_SET_NAMES`]:
    /// Mantaflow writes `phi` after `phi_obstacle` and others), or else the first float
    /// grid in file order (OpenVDB's own lookup goes by sorted name). `Err` explains,
    /// listing the grids.
    pub fn choose_float_grid(&self, name: Option<&str>) -> Result<String, LayoutError> {
        let is_float = |kind: &str| kind.starts_with("Tree_float_");
        match name {
            Some(n) => match self.find(n) {
                None => Err(format!(
                    "no grid named '{n}' ({}){}",
                    self.describe_grids(),
                    self.mantaflow_hint()
                )
                .into()),
                Some((_, kind)) if !is_float(kind) => {
                    Err(format!("grid '{n}' is a {kind}, not a float grid").into())
                }
                Some((g, _)) => Ok(printable_name(g)),
            },
            None => LEVEL_SET_NAMES
                .iter()
                .find_map(|n| self.grids.iter().find(|(g, kind)| g == n && is_float(kind)))
                .or_else(|| self.grids.iter().find(|(_, kind)| is_float(kind)))
                .map(|(g, _)| printable_name(g))
                .ok_or_else(|| {
                    format!(
                        "no float grid ({}){}",
                        self.describe_grids(),
                        self.mantaflow_hint()
                    )
                    .into()
                }),
        }
    }
}

/// The float grids read without `--grid` before the file's first: the level sets
/// Houdini (`surface`) and Mantaflow (`phi`) write beside others.
pub const LEVEL_SET_NAMES: &[&str] = &["surface", "phi"];

struct Walker<R> {
    reader: R,
    len: u64,
    pos: u64,
}

impl<R: Read + Seek> Walker<R> {
    fn truncated(&self, what: &str, needed: u64) -> LayoutError {
        LayoutError::Bad(format!(
            "truncated or corrupt VDB file: {what} needs bytes up to {needed} but the file has {}",
            self.len
        ))
    }

    fn io(what: &str) -> impl FnOnce(std::io::Error) -> LayoutError + '_ {
        move |source| LayoutError::Io {
            what: what.to_string(),
            source,
        }
    }

    fn bytes<const N: usize>(&mut self, what: &str) -> Result<[u8; N], LayoutError> {
        let end = self.pos + N as u64;
        if end > self.len {
            return Err(self.truncated(what, end));
        }
        let mut buf = [0u8; N];
        self.reader.read_exact(&mut buf).map_err(Self::io(what))?;
        self.pos = end;
        Ok(buf)
    }

    fn u32(&mut self, what: &str) -> Result<u32, LayoutError> {
        self.bytes::<4>(what).map(u32::from_le_bytes)
    }

    fn i64(&mut self, what: &str) -> Result<i64, LayoutError> {
        self.bytes::<8>(what).map(i64::from_le_bytes)
    }

    fn count(&mut self, what: &str) -> Result<u32, LayoutError> {
        let n = self.u32(what)?;
        if n > MAX_COUNT {
            return Err(format!("corrupt VDB file: {what} is {n}").into());
        }
        Ok(n)
    }

    fn skip(&mut self, n: u64, what: &str) -> Result<(), LayoutError> {
        let end = self.pos + n;
        if end > self.len {
            return Err(self.truncated(what, end));
        }
        self.seek(end)
    }

    fn seek(&mut self, to: u64) -> Result<(), LayoutError> {
        self.reader
            .seek(SeekFrom::Start(to))
            .map_err(Self::io("a seek"))?;
        self.pos = to;
        Ok(())
    }

    fn string(&mut self, what: &str) -> Result<String, LayoutError> {
        let n = u64::from(self.u32(what)?);
        let end = self.pos + n;
        if end > self.len {
            return Err(self.truncated(what, end));
        }
        let mut buf = vec![0u8; n as usize];
        self.reader.read_exact(&mut buf).map_err(Self::io(what))?;
        self.pos = end;
        Ok(String::from_utf8_lossy(&buf).into_owned())
    }
}

/// Walks the file's header and grid descriptors; `Err` says what is wrong, on one line.
pub fn check<R: Read + Seek>(reader: R, len: u64) -> Result<Layout, LayoutError> {
    let mut w = Walker {
        reader,
        len,
        pos: 0,
    };
    if len < MAGIC.len() as u64 {
        return Err(LayoutError::from(if len == 0 {
            "empty file, not a VDB file"
        } else {
            "not a VDB file (too short)"
        }));
    }
    if w.bytes::<8>("magic number")? != MAGIC {
        return Err("not a VDB file (no VDB magic number)".into());
    }
    let mut version = w.u32("file version")?;
    if version < VERSION_LIBRARY_NUMBERS {
        // Before 211 the version was stored as major, minor, patch.
        let minor = w.u32("file version")?;
        let patch = w.u32("file version")?;
        version = 100 * version + 10 * minor + patch;
    } else {
        w.u32("library version")?;
        w.u32("library version")?;
    }
    let has_offsets = if version >= VERSION_GRID_OFFSETS_FLAG {
        w.bytes::<1>("grid offsets flag")?[0] != 0
    } else {
        true
    };
    if (VERSION_SELECTIVE_COMPRESSION..VERSION_PER_GRID_COMPRESSION).contains(&version) {
        w.bytes::<1>("compression flag")?;
    }
    let uuid_len = if version >= VERSION_UUID_AS_TEXT {
        36
    } else {
        16
    };
    w.skip(uuid_len, "file UUID")?;

    let metadata = w.count("file metadata count")?;
    for _ in 0..metadata {
        w.string("metadata name")?;
        w.string("metadata type")?;
        let size = w.u32("metadata size")?;
        w.skip(u64::from(size), "metadata value")?;
    }

    let grid_count = w.count("grid count")?;
    let mut grids = Vec::with_capacity(grid_count as usize);
    if !has_offsets {
        // Grids follow one another with no index to check; OpenVDB reads them in turn.
        return Ok(Layout {
            version,
            has_offsets,
            grids,
            memory: Vec::new(),
        });
    }
    let mut memory = Vec::with_capacity(grid_count as usize);
    for _ in 0..grid_count {
        let name = w.string("grid name")?;
        let kind = w.string("grid type")?;
        if version >= VERSION_INSTANCING {
            w.string("instance parent name")?;
        }
        let what = format!("grid '{name}'");
        let grid_pos = w.i64(&what)?;
        let block_pos = w.i64(&what)?;
        let end_pos = w.i64(&what)?;
        let ordered = (w.pos as i64) <= grid_pos && grid_pos <= block_pos && block_pos <= end_pos;
        if !ordered {
            return Err(format!("corrupt VDB file: bad offsets for {what}").into());
        }
        if end_pos as u64 > len {
            return Err(w.truncated(&what, end_pos as u64));
        }
        // A statistic, not the grid: metadata OpenVDB would not read fails when it reads.
        memory.push(w.recorded_memory(grid_pos as u64, version).unwrap_or(None));
        // The next descriptor follows the grid.
        w.seek(end_pos as u64)?;
        grids.push((name, kind));
    }
    Ok(Layout {
        version,
        has_offsets,
        grids,
        memory,
    })
}

impl<R: Read + Seek> Walker<R> {
    /// The `file_mem_bytes` entry of the grid's metadata at `grid_pos`, which follows
    /// the grid's compression flags (`Archive::readGrid`).
    fn recorded_memory(&mut self, grid_pos: u64, version: u32) -> Result<Option<u64>, LayoutError> {
        self.seek(grid_pos)?;
        if version >= VERSION_PER_GRID_COMPRESSION {
            self.u32("grid compression")?;
        }
        let entries = self.count("grid metadata count")?;
        for _ in 0..entries {
            let name = self.string("metadata name")?;
            let kind = self.string("metadata type")?;
            let size = self.u32("metadata size")?;
            if name == "file_mem_bytes" && kind == "int64" && size == 8 {
                let bytes = self.i64("file_mem_bytes")?;
                return Ok(u64::try_from(bytes).ok());
            }
            self.skip(u64::from(size), "metadata value")?;
        }
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    /// A minimal version-224 file: one metadata entry, one grid descriptor of `payload` bytes.
    fn file(payload: usize) -> Vec<u8> {
        let mut f = MAGIC.to_vec();
        for v in [224u32, 10, 0] {
            f.extend(v.to_le_bytes());
        }
        f.push(1);
        f.extend([b'0'; 36]);
        let string = |f: &mut Vec<u8>, s: &str| {
            f.extend((s.len() as u32).to_le_bytes());
            f.extend(s.as_bytes());
        };
        f.extend(1u32.to_le_bytes());
        string(&mut f, "creator");
        string(&mut f, "string");
        string(&mut f, "me");
        f.extend(1u32.to_le_bytes());
        string(&mut f, "surface");
        string(&mut f, "Tree_float_5_4_3");
        string(&mut f, "");
        let grid_pos = f.len() as i64 + 24;
        let end = grid_pos + payload as i64;
        for p in [grid_pos, grid_pos, end] {
            f.extend(p.to_le_bytes());
        }
        f.resize(end as usize, 7);
        f
    }

    fn check_bytes(bytes: &[u8]) -> Result<Layout, String> {
        check(Cursor::new(bytes), bytes.len() as u64).map_err(|e| e.to_string())
    }

    #[test]
    fn whole_file_passes() {
        let layout = check_bytes(&file(100)).unwrap();
        assert_eq!(layout.version, 224);
        assert!(layout.has_offsets);
        assert_eq!(
            layout.grids,
            vec![("surface".to_string(), "Tree_float_5_4_3".to_string())]
        );
        // Its payload is no grid's metadata: the size is unknown, the file still whole.
        assert_eq!(layout.memory, vec![None]);
    }

    #[test]
    fn every_truncation_is_an_error() {
        let f = file(100);
        for cut in 0..f.len() {
            let err = check_bytes(&f[..cut]).unwrap_err();
            assert!(!err.contains('\n'), "{err}");
        }
    }

    fn layout(grids: &[(&str, &str)]) -> Layout {
        Layout {
            version: 224,
            has_offsets: true,
            grids: grids
                .iter()
                .map(|(n, k)| (n.to_string(), k.to_string()))
                .collect(),
            memory: vec![None; grids.len()],
        }
    }

    /// Without a name, a simulation's level set before the file's first float grid; a
    /// Mantaflow cache without `phi` (not resumable) says how to get one.
    #[test]
    fn the_float_grid_chosen() {
        let float = "Tree_float_5_4_3";
        let mantaflow = layout(&[
            ("velocity", "Tree_vec3s_5_4_3"),
            ("phi_obstacle", float),
            ("phi", float),
        ]);
        assert_eq!(mantaflow.choose_float_grid(None).unwrap(), "phi");
        assert_eq!(
            mantaflow.choose_float_grid(Some("phi_obstacle")).unwrap(),
            "phi_obstacle"
        );
        let houdini = layout(&[("density", float), ("surface", float)]);
        assert_eq!(houdini.choose_float_grid(None).unwrap(), "surface");
        let other = layout(&[("density", float), ("temperature", float)]);
        assert_eq!(other.choose_float_grid(None).unwrap(), "density");
        let final_cache = layout(&[
            ("velocity", "Tree_vec3s_5_4_3"),
            ("particles", "Tree_ptdataidx32_5_4_3"),
        ]);
        for name in [None, Some("phi")] {
            let e = final_cache.choose_float_grid(name).unwrap_err().to_string();
            assert!(
                e.ends_with("tick the domain's Cache > Is Resumable and bake again"),
                "{e}"
            );
        }
        let e = other
            .choose_float_grid(Some("phi"))
            .unwrap_err()
            .to_string();
        assert!(!e.contains("Resumable"), "{e}");
    }

    #[test]
    fn huge_counts_are_corrupt_not_a_hang() {
        let mut f = file(10);
        let at = 8 + 12 + 1 + 36; // metadata count
        f[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(check_bytes(&f).unwrap_err().contains("corrupt"));
    }
}
