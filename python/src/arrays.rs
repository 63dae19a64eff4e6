//! numpy arrays in and out: checked shapes, one conversion, no copy out.

use super::*;

/// What `object` is, for a message: its shape when it has one, else its type.
pub(crate) fn described(object: &Bound<'_, PyAny>) -> String {
    match object.getattr("shape") {
        Ok(shape) => format!("shape {shape}"),
        Err(_) => match object.get_type().name() {
            Ok(name) => format!("a {name}"),
            Err(_) => "something else".into(),
        },
    }
}

/// `object` as a 2-D array of float32 (converted once, any strides), or a `ValueError`
/// naming the argument.
pub(crate) fn array2<'py>(
    name: &str,
    object: &Bound<'py, PyAny>,
) -> PyResult<PyArrayLike2<'py, f32, AllowTypeChange>> {
    object.extract().map_err(|_| {
        PyValueError::new_err(format!(
            "{name} must be an (n, 3) array of numbers, got {}",
            described(object)
        ))
    })
}

/// `object` as a 1-D array of `n` values, copied, or a `ValueError` naming the argument.
pub(crate) fn array1<T: numpy::Element + Copy>(
    name: &str,
    object: &Bound<'_, PyAny>,
    n: usize,
) -> PyResult<Vec<T>>
where
    for<'a, 'py> PyArrayLike1<'py, T, AllowTypeChange>: FromPyObject<'a, 'py>,
{
    let wrong = || {
        PyValueError::new_err(format!(
            "{name} must be an ({n},) array of numbers, one per particle, got {}",
            described(object)
        ))
    };
    let array: PyArrayLike1<T, AllowTypeChange> = object.extract().map_err(|_| wrong())?;
    let view = array.as_array();
    // The length first: a broadcast view of billions of rows is never copied.
    if view.len() != n {
        return Err(wrong());
    }
    Ok(view.to_vec())
}

/// `n` particles within the memory budget, before their arrays are copied: a
/// `MemoryError` otherwise (a copy past the machine's memory would abort the process,
/// and the artist's Blender with it).
pub(crate) fn fits(name: &str, n: usize) -> PyResult<()> {
    use activeskin::budget;
    budget::particles_fit(n).map_err(|needed| {
        PyMemoryError::new_err(format!(
            "{name}: {n} particles would take at least {}, over the memory budget of {}: activeskin.set_memory_budget(gb) allows more",
            budget::size(needed),
            budget::size(budget::bytes())
        ))
    })
}

/// `n × 3` floats as points, checked: shape, then the memory budget, then copied.
pub(crate) fn points(
    name: &str,
    array: &PyArrayLike2<f32, AllowTypeChange>,
) -> PyResult<Vec<Vec3>> {
    let view = array.as_array();
    if view.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must be an (n, 3) array, got shape {:?}",
            view.shape()
        )));
    }
    fits(name, view.nrows())?;
    Ok(view
        .rows()
        .into_iter()
        .map(|r| Vec3::new(r[0], r[1], r[2]))
        .collect())
}

/// Vectors as an `n × 3` numpy array, handed over without a copy.
pub(crate) fn vectors_array(py: Python<'_>, vectors: Vec<Vec3>) -> Bound<'_, PyArray2<f32>> {
    let n = vectors.len();
    let flat: Vec<f32> = flatten(vectors);
    Array2::from_shape_vec((n, 3), flat)
        .expect("3 floats a vector")
        .into_pyarray(py)
}

/// `Vec<Vec3>` as its floats, without copying them.
pub(crate) fn flatten(vectors: Vec<Vec3>) -> Vec<f32> {
    let mut vectors = std::mem::ManuallyDrop::new(vectors);
    let (ptr, len, capacity) = (vectors.as_mut_ptr(), vectors.len(), vectors.capacity());
    // SAFETY: glam's `Vec3` is `#[repr(C)]` of three `f32` (size 12, alignment 4, no
    // SIMD padding), so an allocation of `capacity` vectors is one of `3 * capacity`
    // floats with the same layout, and the first `3 * len` are initialised.
    unsafe { Vec::from_raw_parts(ptr.cast::<f32>(), 3 * len, 3 * capacity) }
}

/// Attributes as numpy arrays by name, `(n,)` or `(n, c)`, handed over without a copy.
pub(crate) fn attributes_dict(
    py: Python<'_>,
    attributes: Vec<Attribute>,
) -> PyResult<Bound<'_, PyDict>> {
    let named = PyDict::new(py);
    for a in attributes {
        let array = match a.components {
            1 => Array1::from_vec(a.values).into_pyarray(py).into_any(),
            c => Array2::from_shape_vec((a.values.len() / c, c), a.values)
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?
                .into_pyarray(py)
                .into_any(),
        };
        named.set_item(a.name, array)?;
    }
    Ok(named)
}

/// An attribute's array, `(n,)` or `(n, c)` of any number type: its components and its
/// values as floats, row by row.
/// An attribute's `(n,)` or `(n, 3)` values and its components, checked before they are
/// copied.
pub(crate) fn attribute_values(
    name: &str,
    array: &Bound<'_, PyAny>,
    n: usize,
) -> PyResult<(usize, Vec<f32>)> {
    let wrong = || {
        PyValueError::new_err(format!(
            "attribute '{name}' must be an ({n},) or ({n}, 3) array, got {}",
            described(array)
        ))
    };
    match array.extract::<PyArrayLike2<f32, AllowTypeChange>>() {
        Ok(two) => {
            let view = two.as_array();
            if view.nrows() != n || view.ncols() != 3 {
                return Err(wrong());
            }
            Ok((3, view.iter().copied().collect()))
        }
        Err(_) => Ok((
            1,
            array1(&format!("attribute '{name}'"), array, n).map_err(|_| wrong())?,
        )),
    }
}

/// `region=((x0, y0, z0), (x1, y1, z1))` (any two sequences of three numbers, a numpy
/// (2, 3) array too) as a box; whether it holds anything the library checks.
pub(crate) fn region_box(region: &Bound<'_, PyAny>) -> PyResult<activeskin::grid::Aabb> {
    let corners: Vec<Vec<f32>> = region.extract().unwrap_or_default();
    match corners[..] {
        [ref lo, ref hi] if lo.len() == 3 && hi.len() == 3 => Ok(activeskin::grid::Aabb {
            min: Vec3::from_slice(lo),
            max: Vec3::from_slice(hi),
        }),
        _ => Err(PyValueError::new_err(
            "region must be two corners, ((x0, y0, z0), (x1, y1, z1))",
        )),
    }
}

/// `collider=` (a VDB level set or a closed OBJ, or a frame pattern of them, `#` for the
/// frame number) with `collider_gap=` and `collider_depth=`, as the command's
/// `--collider`.
pub(crate) fn collider_spec(
    files: Option<std::path::PathBuf>,
    gap: Option<f32>,
    depth: f32,
) -> PyResult<Option<activeskin::frames::ColliderSpec>> {
    let Some(files) = files else {
        return Ok(None);
    };
    let files = files.to_string_lossy();
    let spec = activeskin::frames::ColliderSpec::new(&files, gap, depth).map_err(value_error)?;
    Ok(Some(spec))
}
