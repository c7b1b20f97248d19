//! Arrays in and out: every input is converted with `numpy.require(x, float64, "CA")` (C order,
//! aligned) and its shape checked, with a `ValueError` that names the argument.

use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A C-ordered float64 copy of `obj` and its shape.
fn float_array(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    // C order and aligned: arrays unpickled from a network frame (Dask) can be misaligned.
    kwargs.set_item("requirements", "CA")?;
    let arr = np
        .call_method("require", (obj,), Some(&kwargs))
        .map_err(|e| PyValueError::new_err(format!("{name}: cannot be read as a float64 array ({e})")))?;
    let arr = arr
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|_| PyValueError::new_err(format!("{name}: not a float64 array after conversion")))?;
    let ro = arr.readonly();
    let shape = ro.shape().to_vec();
    let data = ro
        .as_slice()
        .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))?
        .to_vec();
    Ok((shape, data))
}

fn shape_text(shape: &[usize]) -> String {
    let parts: Vec<String> = shape.iter().map(|s| s.to_string()).collect();
    format!("({})", parts.join(", "))
}

fn rows3(data: &[f64]) -> Vec<[f64; 3]> {
    data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// `obj` as positions (#V x 3). With `nv`, the row count must be `nv`.
pub fn points(obj: &Bound<'_, PyAny>, name: &str, nv: Option<usize>) -> PyResult<Vec<[f64; 3]>> {
    let (shape, data) = float_array(&crate::meshes::points_arg(obj)?, name)?;
    if shape.len() != 2 || shape[1] != 3 || nv.is_some_and(|n| shape[0] != n) {
        let want = nv.map_or("(nV, 3)".to_string(), |n| format!("({n}, 3)"));
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape {want}, got {}",
            shape_text(&shape)
        )));
    }
    if let Some(i) = data.iter().position(|c| !c.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name}: vertex {} has a non-finite coordinate",
            i / 3
        )));
    }
    Ok(rows3(&data))
}

/// `obj` as a sequence of poses (K x #V x 3), K >= `min`; with `nv`, #V must be `nv`.
pub fn sequence(
    obj: &Bound<'_, PyAny>,
    name: &str,
    nv: Option<usize>,
    min: usize,
) -> PyResult<Vec<Vec<[f64; 3]>>> {
    let (shape, data) = float_array(&crate::meshes::poses_arg(obj)?, name)?;
    if shape.len() != 3
        || nv.is_some_and(|n| shape[1] != n)
        || shape[2] != 3
        || shape[0] < min
        || shape[1] == 0
    {
        let v = nv.map_or("nV".to_string(), |n| n.to_string());
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape (K, {v}, 3) with K >= {min}, got {}",
            shape_text(&shape)
        )));
    }
    let nv = shape[1];
    if let Some(i) = data.iter().position(|c| !c.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name}: pose {}, vertex {} has a non-finite coordinate",
            i / (3 * nv),
            (i / 3) % nv
        )));
    }
    Ok(data.chunks_exact(3 * nv).map(rows3).collect())
}

/// `obj` as n deformations of K poses each (n x K x #V x 3), n >= 1, K >= 1.
pub fn deformations(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Vec<Vec<[f64; 3]>>>> {
    let (shape, data) = float_array(obj, name)?;
    if shape.len() != 4 || shape[3] != 3 || shape[..3].contains(&0) {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape (n, K, nV, 3), none of them 0, got {}",
            shape_text(&shape)
        )));
    }
    if let Some(i) = data.iter().position(|c| !c.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name}: element {i} is not a finite number"
        )));
    }
    let (k, nv) = (shape[1], shape[2]);
    Ok(data
        .chunks_exact(3 * nv * k)
        .map(|d| d.chunks_exact(3 * nv).map(rows3).collect())
        .collect())
}

/// `obj` as pairs (m x 2) of indices `i < j < n`.
pub fn index_pairs(obj: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<(usize, usize)>> {
    let (shape, data) = float_array(obj, name)?;
    if !(shape.len() == 2 && shape[1] == 2 || shape == [0]) {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an integer array of shape (m, 2), got {}",
            shape_text(&shape)
        )));
    }
    data.chunks_exact(2)
        .enumerate()
        .map(|(k, c)| {
            let ok = |x: f64| x >= 0.0 && x.fract() == 0.0 && x < n as f64;
            if !(ok(c[0]) && ok(c[1]) && c[0] < c[1]) {
                return Err(PyValueError::new_err(format!(
                    "{name}: row {k} is ({}, {}), not a pair i < j of {n} deformations",
                    c[0], c[1]
                )));
            }
            Ok((c[0] as usize, c[1] as usize))
        })
        .collect()
}

/// A (n, K, nV, 3) float64 array of n deformations of K poses.
pub fn deformations_out<'py>(py: Python<'py>, defs: &[Vec<Vec<[f64; 3]>>]) -> PyResult<Bound<'py, PyAny>> {
    let k = defs.first().map_or(0, Vec::len);
    let nv = defs.first().and_then(|d| d.first()).map_or(0, Vec::len);
    let flat: Vec<f64> = defs.iter().flatten().flatten().flatten().copied().collect();
    Ok(PyArray1::from_vec(py, flat)
        .reshape([defs.len(), k, nv, 3])?
        .into_any())
}

/// `obj` as triangles (#F x 3) of non-negative integer vertex indices (a mesh object's faces,
/// see [`crate::meshes`]).
pub fn faces(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<[u32; 3]>> {
    let (shape, data) = float_array(&crate::meshes::faces_arg(obj)?.0, name)?;
    if shape.len() != 2 || shape[1] != 3 || shape[0] == 0 {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an integer array of shape (nF, 3) with nF >= 1, got {}",
            shape_text(&shape)
        )));
    }
    if let Some(i) = data
        .iter()
        .position(|&x| !(x >= 0.0 && x.fract() == 0.0 && x < qcshape::limits::MAX_VERTICES as f64))
    {
        return Err(PyValueError::new_err(format!(
            "{name}: face {} has the index {}, not a non-negative integer below {} (the vertex limit)",
            i / 3,
            data[i],
            qcshape::limits::MAX_VERTICES
        )));
    }
    Ok(data
        .chunks_exact(3)
        .map(|c| [c[0] as u32, c[1] as u32, c[2] as u32])
        .collect())
}

/// `obj` as a square matrix (n x n, row-major).
pub fn square(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(usize, Vec<f64>)> {
    let (shape, data) = float_array(obj, name)?;
    if shape.len() != 2 || shape[0] != shape[1] {
        return Err(PyValueError::new_err(format!(
            "{name}: expected a square array of shape (n, n), got {}",
            shape_text(&shape)
        )));
    }
    Ok((shape[0], data))
}

/// `obj` as a vector of `n` finite values.
pub fn vector(obj: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<f64>> {
    let (shape, data) = float_array(obj, name)?;
    if shape != [n] {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape ({n},), got {}",
            shape_text(&shape)
        )));
    }
    if data.iter().any(|c| !c.is_finite()) {
        return Err(PyValueError::new_err(format!("{name}: has non-finite values")));
    }
    Ok(data)
}

/// An (n, 3) float64 array.
pub fn points_out<'py>(py: Python<'py>, p: &[[f64; 3]]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f64> = p.iter().flatten().copied().collect();
    Ok(PyArray1::from_vec(py, flat).reshape([p.len(), 3])?.into_any())
}

/// A (K, n, 3) float64 array (n from the first pose).
pub fn sequence_out<'py>(py: Python<'py>, poses: &[Vec<[f64; 3]>]) -> PyResult<Bound<'py, PyAny>> {
    let nv = poses.first().map_or(0, Vec::len);
    let flat: Vec<f64> = poses.iter().flatten().flatten().copied().collect();
    Ok(PyArray1::from_vec(py, flat)
        .reshape([poses.len(), nv, 3])?
        .into_any())
}

/// An (nF, 3) int64 array.
pub fn faces_out<'py>(py: Python<'py>, f: &[[u32; 3]]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<i64> = f.iter().flatten().map(|&i| i as i64).collect();
    Ok(PyArray1::from_vec(py, flat).reshape([f.len(), 3])?.into_any())
}

/// An (rows, cols) float64 array from row-major values.
pub fn matrix_out<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, values).reshape([rows, cols])?.into_any())
}

/// A 1-D int64 array.
pub fn labels_out<'py>(py: Python<'py>, v: &[usize]) -> Bound<'py, PyAny> {
    PyArray1::from_vec(py, v.iter().map(|&x| x as i64).collect()).into_any()
}

/// A Python `int` of any size (or anything with `__index__`), kept as it is so that the bounds
/// check ([`count`]) can name the argument: `steps=-1` or `insert=10**30` give a `ValueError`
/// "steps: must be >= 0" instead of a bare `OverflowError`. `None` inside: beyond `i128`.
#[derive(Debug, Clone, Copy)]
pub struct AnyInt(Option<i128>);

impl AnyInt {
    /// The value `v` (for signature defaults).
    pub const fn new(v: i128) -> AnyInt {
        AnyInt(Some(v))
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for AnyInt {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        match obj.extract::<i128>() {
            Ok(v) => Ok(AnyInt(Some(v))),
            Err(e) if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) => Ok(AnyInt(None)),
            Err(e) => Err(e),
        }
    }
}

/// `v` as a count in `min..=max` (the bounds of [`qcshape::limits`]), else a `ValueError`
/// naming `name`.
pub fn count(name: &str, v: AnyInt, min: usize, max: usize) -> PyResult<usize> {
    match v.0 {
        Some(x) if x < 0 => Err(PyValueError::new_err(format!("{name}: must be >= 0, got {x}"))),
        Some(x) if x < min as i128 => Err(PyValueError::new_err(format!(
            "{name}: must be at least {min}, got {x}"
        ))),
        Some(x) if x <= max as i128 => Ok(x as usize),
        Some(x) => Err(PyValueError::new_err(format!(
            "{name}: must be at most {max}, got {x}"
        ))),
        None => Err(PyValueError::new_err(format!(
            "{name}: must be at most {max}, got a number beyond 2**127 in size"
        ))),
    }
}

/// [`count`] of an optional argument.
pub fn opt_count(name: &str, v: Option<AnyInt>, min: usize, max: usize) -> PyResult<Option<usize>> {
    v.map(|v| count(name, v, min, max)).transpose()
}

/// [`opt_count`] for the whole-number setting `s` ([`qcshape::settings`]): its keyword and range
/// from the declaration.
pub fn opt_setting(s: &qcshape::settings::Setting, v: Option<AnyInt>) -> PyResult<Option<usize>> {
    match s.value {
        qcshape::settings::Value::Count { min, max } => opt_count(s.python, v, min, max),
        _ => unreachable!("--{} is a count", s.key),
    }
}
