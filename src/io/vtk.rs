//! Legacy VTK files (`# vtk DataFile Version 2.0–5.1`) as particle simulators write them:
//! SPlisHSPlasH (`enableVTKExport`: binary big-endian `UNSTRUCTURED_GRID`, point data in
//! a `FIELD`), DualSPHysics' `PartVTK` (`POLYDATA`, `SCALARS`/`VECTORS`), meshio and
//! ParaView (ASCII or binary, version 5.1 `OFFSETS`/`CONNECTIVITY` cells, `METADATA`).
//! Only the points and their point data are kept; cells are read past.

use super::points::PointArray;
use super::scalar::Scalar;

/// A legacy VTK file that cannot be read as points.
#[derive(Debug, thiserror::Error)]
pub enum VtkError {
    #[error("not a legacy VTK file (it must start with '# vtk DataFile Version')")]
    NotVtk,
    #[error("line {line}: {message}")]
    Syntax { line: usize, message: String },
    #[error("the file ends inside {0}")]
    Truncated(String),
    #[error("no POINTS section")]
    NoPoints,
}

/// The points of a legacy VTK file and their point-data arrays.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VtkPoints {
    /// x y z per point, as read (float or double).
    pub positions: Vec<[f64; 3]>,
    /// The point data arrays.
    pub arrays: Vec<PointArray>,
}

/// Reads the bytes of a legacy VTK file.
pub fn parse(bytes: &[u8]) -> Result<VtkPoints, VtkError> {
    let mut r = Reader {
        bytes,
        at: 0,
        line: 0,
        binary: false,
    };
    if !r.line_text()?.starts_with("# vtk DataFile Version") {
        return Err(VtkError::NotVtk);
    }
    r.line_text()?; // title
    r.binary = match r.line_text()?.trim().to_ascii_uppercase().as_str() {
        "ASCII" => false,
        "BINARY" => true,
        other => return Err(r.syntax(format!("'{other}': expected ASCII or BINARY"))),
    };
    let mut out = VtkPoints::default();
    let mut have_points = false;
    // Which data section the arrays belong to: POINT_DATA's are kept, CELL_DATA's skipped.
    let mut in_point_data = false;
    while let Some(line) = r.next_keyword_line()? {
        let words: Vec<&str> = line.split_whitespace().collect();
        let keyword = words[0].to_ascii_uppercase();
        let line_no = r.line;
        let count = |i: usize, what: &str| -> Result<usize, VtkError> {
            words
                .get(i)
                .and_then(|w| w.parse().ok())
                .ok_or_else(|| VtkError::Syntax {
                    line: line_no,
                    message: format!("{what}: expected a count in '{line}'"),
                })
        };
        match keyword.as_str() {
            "DATASET" => {
                let kind = words
                    .get(1)
                    .map(|w| w.to_ascii_uppercase())
                    .unwrap_or_default();
                if !matches!(
                    kind.as_str(),
                    "UNSTRUCTURED_GRID" | "POLYDATA" | "STRUCTURED_GRID"
                ) {
                    return Err(r.syntax(format!(
                        "DATASET {kind}: only point sets (UNSTRUCTURED_GRID, POLYDATA) hold particles"
                    )));
                }
            }
            "POINTS" => {
                let n = count(1, "POINTS")?;
                let kind = value_type(words.get(2).copied(), &r)?;
                let values = r.values(
                    n.checked_mul(3).ok_or_else(|| r.too_many())?,
                    kind,
                    "POINTS",
                )?;
                out.positions = values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
                have_points = true;
            }
            "CELLS" | "VERTICES" | "LINES" | "POLYGONS" | "TRIANGLE_STRIPS" => {
                let size = count(2, &keyword)?;
                skip_cells(&mut r, &keyword, size, count(1, &keyword))?;
            }
            "CELL_TYPES" => {
                let n = count(1, "CELL_TYPES")?;
                r.values(n, Scalar::I32, "CELL_TYPES")?;
            }
            "POINT_DATA" | "CELL_DATA" => in_point_data = keyword == "POINT_DATA",
            "FIELD" => {
                let arrays = field_arrays(&mut r, count(2, "FIELD")?)?;
                if in_point_data {
                    out.arrays.extend(arrays);
                }
            }
            "SCALARS" | "VECTORS" | "NORMALS" | "COLOR_SCALARS" | "TENSORS" => {
                let points = out.positions.len();
                let array = attribute(&mut r, &words, points, count(2, "COLOR_SCALARS"))?;
                if in_point_data {
                    out.arrays.push(array);
                }
            }
            "LOOKUP_TABLE" => {
                let n = count(2, "LOOKUP_TABLE")?;
                let kind = if r.binary { Scalar::U8 } else { Scalar::F32 };
                r.values(n * 4, kind, "LOOKUP_TABLE")?;
            }
            // VTK 9's information keys: lines up to a blank one.
            "METADATA" => r.skip_metadata()?,
            _ if !words[0].chars().all(|c| c.is_ascii_graphic()) => {
                return Err(r.syntax("binary data where a keyword was expected".into()))
            }
            _ => {
                let word = super::file::printable(words[0], 40);
                return Err(r.syntax(format!("unexpected '{word}'")));
            }
        }
    }
    if !have_points {
        return Err(VtkError::NoPoints);
    }
    Ok(out)
}

/// Reads past a cell section (`keyword` with `size` values; version 5.1 puts OFFSETS and
/// CONNECTIVITY arrays after it, counting `cells` + 1 offsets).
fn skip_cells(
    r: &mut Reader,
    keyword: &str,
    size: usize,
    cells: Result<usize, VtkError>,
) -> Result<(), VtkError> {
    if r.peek_keyword()?.as_deref() != Some("OFFSETS") {
        r.values(size, Scalar::I32, keyword)?;
        return Ok(());
    }
    let mut cells = Some(cells);
    for part in ["OFFSETS", "CONNECTIVITY"] {
        let header = r.next_keyword_line()?.ok_or_else(|| r.truncated(part))?;
        let kind = value_type(header.split_whitespace().nth(1), r)?;
        let n = match cells.take() {
            Some(cells) => cells?,
            None => size,
        };
        r.values(n, kind, part)?;
    }
    Ok(())
}

/// The `arrays` arrays of a FIELD section, each `name components tuples type` then its
/// values.
fn field_arrays(r: &mut Reader, arrays: usize) -> Result<Vec<PointArray>, VtkError> {
    let mut out = Vec::new();
    for _ in 0..arrays {
        let header = r.next_keyword_line()?.ok_or_else(|| r.truncated("FIELD"))?;
        let w: Vec<&str> = header.split_whitespace().collect();
        let number = |i: usize| -> Result<usize, VtkError> {
            w.get(i).and_then(|s| s.parse().ok()).ok_or_else(|| {
                r.syntax(format!(
                    "FIELD array: expected 'name components tuples type', got '{header}'"
                ))
            })
        };
        let (components, tuples) = (number(1)?, number(2)?);
        let kind = value_type(w.get(3).copied(), r)?;
        let n = components.checked_mul(tuples).ok_or_else(|| r.too_many())?;
        let values = r.values(n, kind, w[0])?;
        out.push(PointArray {
            name: w[0].to_string(),
            components,
            values,
        });
    }
    Ok(out)
}

/// A dataset attribute (SCALARS, VECTORS, NORMALS, COLOR_SCALARS, TENSORS) whose line
/// is `words`, one tuple for each of `points`; `colors` is COLOR_SCALARS's count.
fn attribute(
    r: &mut Reader,
    words: &[&str],
    points: usize,
    colors: Result<usize, VtkError>,
) -> Result<PointArray, VtkError> {
    let keyword = words[0].to_ascii_uppercase();
    let name = words
        .get(1)
        .ok_or_else(|| r.syntax(format!("{keyword} without a name")))?
        .to_string();
    let (components, kind) = match keyword.as_str() {
        "SCALARS" => {
            let kind = value_type(words.get(2).copied(), r)?;
            let components = match words.get(3) {
                Some(c) => c
                    .parse()
                    .ok()
                    .filter(|&n: &usize| n > 0)
                    .ok_or_else(|| r.syntax(format!("SCALARS {name}: bad component count")))?,
                None => 1,
            };
            if r.peek_keyword()?.as_deref() == Some("LOOKUP_TABLE") {
                r.next_keyword_line()?;
            }
            (components, kind)
        }
        "COLOR_SCALARS" => (colors?, if r.binary { Scalar::U8 } else { Scalar::F32 }),
        "TENSORS" => (9, value_type(words.get(2).copied(), r)?),
        _ => (3, value_type(words.get(2).copied(), r)?),
    };
    let values = r.values(
        points.checked_mul(components).ok_or_else(|| r.too_many())?,
        kind,
        &name,
    )?;
    Ok(PointArray {
        name,
        components,
        values,
    })
}

/// A data type, by legacy VTK's name for it.
fn value_type(word: Option<&str>, r: &Reader) -> Result<Scalar, VtkError> {
    Ok(match word.map(str::to_ascii_lowercase).as_deref() {
        Some("unsigned_char" | "bit") => Scalar::U8,
        Some("char") => Scalar::I8,
        Some("unsigned_short") => Scalar::U16,
        Some("short") => Scalar::I16,
        Some("unsigned_int") => Scalar::U32,
        Some("int") => Scalar::I32,
        Some("unsigned_long" | "vtktypeuint64") => Scalar::U64,
        Some("long" | "vtktypeint64" | "vtkidtype") => Scalar::I64,
        Some("float") => Scalar::F32,
        Some("double") => Scalar::F64,
        other => {
            return Err(r.syntax(format!(
                "data type '{}' is not one VTK writes",
                other.unwrap_or("")
            )))
        }
    })
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    line: usize,
    binary: bool,
}

impl Reader<'_> {
    fn syntax(&self, message: String) -> VtkError {
        VtkError::Syntax {
            line: self.line,
            message,
        }
    }

    fn truncated(&self, what: &str) -> VtkError {
        VtkError::Truncated(what.to_string())
    }

    fn too_many(&self) -> VtkError {
        self.syntax("a count too large for this machine".into())
    }

    /// The next line, without its end.
    fn line_text(&mut self) -> Result<String, VtkError> {
        if self.at >= self.bytes.len() {
            return Err(self.truncated("the header"));
        }
        let rest = &self.bytes[self.at..];
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        self.at += (end + 1).min(rest.len());
        self.line += 1;
        Ok(String::from_utf8_lossy(&rest[..end])
            .trim_end_matches('\r')
            .to_string())
    }

    /// The next non-blank line, `None` at the end of the file.
    fn next_keyword_line(&mut self) -> Result<Option<String>, VtkError> {
        while self.at < self.bytes.len() {
            let line = self.line_text()?;
            if !line.trim().is_empty() {
                return Ok(Some(line.trim().to_string()));
            }
        }
        Ok(None)
    }

    /// The first word of the next non-blank line, upper case, without moving.
    fn peek_keyword(&mut self) -> Result<Option<String>, VtkError> {
        let (at, line) = (self.at, self.line);
        let next = self.next_keyword_line()?;
        self.at = at;
        self.line = line;
        Ok(next.and_then(|l| l.split_whitespace().next().map(str::to_ascii_uppercase)))
    }

    fn skip_metadata(&mut self) -> Result<(), VtkError> {
        while self.at < self.bytes.len() {
            if self.line_text()?.trim().is_empty() {
                break;
            }
        }
        Ok(())
    }

    /// `n` values of `kind` for the section `what`: raw big-endian bytes in a binary file
    /// (then the line's end), whitespace-separated numbers in an ASCII one.
    fn values(&mut self, n: usize, kind: Scalar, what: &str) -> Result<Vec<f64>, VtkError> {
        if self.binary {
            let size = n.checked_mul(kind.size()).ok_or_else(|| self.too_many())?;
            let end = self.at.checked_add(size).filter(|&e| e <= self.bytes.len());
            let end = end.ok_or_else(|| self.truncated(what))?;
            let values = self.bytes[self.at..end]
                .chunks_exact(kind.size())
                .map(|b| kind.read(b, true))
                .collect();
            self.at = end;
            // The newline closing the block, when there is one.
            if self.bytes.get(self.at) == Some(&b'\n') {
                self.at += 1;
            }
            self.line += 1;
            return Ok(values);
        }
        // The count comes from the file: never reserve more than the file could hold.
        let mut values = Vec::with_capacity(n.min(self.bytes.len() / 2));
        while values.len() < n {
            let line = self.line_text().map_err(|_| self.truncated(what))?;
            for word in line.split_whitespace() {
                let v: f64 = word
                    .parse()
                    .map_err(|_| self.syntax(format!("{what}: '{word}' is not a number")))?;
                values.push(v);
            }
        }
        if values.len() != n {
            return Err(self.syntax(format!("{what}: {} values, expected {n}", values.len())));
        }
        Ok(values)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::points::find_array;

    fn be32(values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_be_bytes()).collect()
    }

    #[test]
    fn binary_unstructured_grid_with_a_field_as_splishsplash_writes_it() {
        let mut b = b"# vtk DataFile Version 4.1\nSPlisHSPlasH particle data\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 2 float\n".to_vec();
        b.extend(be32(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
        b.extend(b"\nCELLS 2 4\n");
        b.extend([1i32, 0, 1, 1].iter().flat_map(|v| v.to_be_bytes()));
        b.extend(b"\nCELL_TYPES 2\n");
        b.extend([1i32, 1].iter().flat_map(|v| v.to_be_bytes()));
        b.extend(b"\nPOINT_DATA 2\nFIELD FieldData 2\nid 1 2 unsigned_int\n");
        b.extend([7u32, 9].iter().flat_map(|v| v.to_be_bytes()));
        b.extend(b"\nvelocity 3 2 float\n");
        b.extend(be32(&[0.5, 0.0, 0.0, 0.0, -1.0, 0.0]));
        b.push(b'\n');
        let p = parse(&b).unwrap();
        assert_eq!(p.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(
            find_array(&p.arrays, &["id"], 1).unwrap().values,
            vec![7.0, 9.0]
        );
        assert_eq!(
            find_array(&p.arrays, &["velocity"], 3).unwrap().values[4],
            -1.0
        );
    }

    #[test]
    fn ascii_polydata_with_scalars_vectors_and_version_5_cells() {
        let text = "# vtk DataFile Version 5.1\nparts\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n0 0 0 1 0 0\n0 1 0\n\
                    METADATA\nINFORMATION 0\n\nVERTICES 4 3\nOFFSETS vtktypeint64\n0 1 2 3\nCONNECTIVITY vtktypeint64\n0 1 2\n\
                    CELL_DATA 3\nSCALARS Type int 1\nLOOKUP_TABLE default\n1 1 1\n\
                    POINT_DATA 3\nSCALARS Idp unsigned_int\nLOOKUP_TABLE default\n5 6 7\nVECTORS Vel float\n1 0 0 0 1 0 0 0 1\n";
        let p = parse(text.as_bytes()).unwrap();
        assert_eq!(p.positions.len(), 3);
        assert_eq!(p.positions[2], [0.0, 1.0, 0.0]);
        assert_eq!(p.arrays.len(), 2, "the cell data is not kept");
        assert_eq!(
            find_array(&p.arrays, &["idp"], 1).unwrap().values,
            vec![5.0, 6.0, 7.0]
        );
        assert_eq!(find_array(&p.arrays, &["vel"], 3).unwrap().values[8], 1.0);
    }

    #[test]
    fn broken_files_say_where() {
        assert!(matches!(parse(b"ply\n"), Err(VtkError::NotVtk)));
        let cut = b"# vtk DataFile Version 3.0\nx\nBINARY\nDATASET POLYDATA\nPOINTS 1000000000 float\n\0\0";
        assert!(matches!(parse(cut), Err(VtkError::Truncated(_))));
        let bad =
            "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 zero 0\n";
        let e = parse(bad.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("line 6") && e.contains("zero"), "{e}");
        let grid = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n";
        assert!(parse(grid.as_bytes())
            .unwrap_err()
            .to_string()
            .contains("STRUCTURED_POINTS"));
        let empty = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\n";
        assert!(matches!(parse(empty.as_bytes()), Err(VtkError::NoPoints)));
    }
}
