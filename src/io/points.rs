//! Per-point arrays as the particle formats read them (the attributes beside positions).

/// A per-point array read from a particle file: its name as written, components per point
/// and values row by row (integers as floats, exact up to 2⁵³).
#[derive(Debug, Clone, PartialEq)]
pub struct PointArray {
    /// The array's name in the file.
    pub name: String,
    /// Values per point (3 for a vector).
    pub components: usize,
    /// `components` values per point, point by point.
    pub values: Vec<f64>,
}

/// The array of `arrays` called one of `names` (ASCII case ignored) with `components`
/// components.
pub fn find_array<'a>(
    arrays: &'a [PointArray],
    names: &[&str],
    components: usize,
) -> Option<&'a PointArray> {
    arrays.iter().find(|a| {
        a.components == components && names.iter().any(|n| a.name.eq_ignore_ascii_case(n))
    })
}
