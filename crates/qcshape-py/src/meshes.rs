//! Mesh objects as arguments: every position, pose-sequence and face argument that is not a
//! numpy array goes through the hooks of `qcshape._meshes` (pure Python), which turn a
//! `trimesh.Trimesh`, `pyvista.PolyData` or `meshio.Mesh` (and pyvista's flat face layout) into
//! arrays and return anything else unchanged. numpy arrays skip the call.

use numpy::PyUntypedArray;
use pyo3::prelude::*;

fn hook<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    obj.py().import("qcshape._meshes")?.getattr(name)?.call1((obj,))
}

pub(crate) fn is_array(obj: &Bound<'_, PyAny>) -> bool {
    obj.is_instance_of::<PyUntypedArray>()
}

/// The positions of a mesh object, else `obj`.
pub fn points_arg<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if is_array(obj) {
        return Ok(obj.clone());
    }
    hook(obj, "_points")
}

/// A list of mesh objects as a (K, nV, 3) array, else `obj`.
pub fn poses_arg<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if is_array(obj) {
        return Ok(obj.clone());
    }
    hook(obj, "_poses")
}

/// The faces of a mesh object with its vertex count, a flat `[3, a, b, c, ...]` array as
/// (nF, 3), else (`obj`, None).
pub fn faces_arg<'py>(obj: &Bound<'py, PyAny>) -> PyResult<(Bound<'py, PyAny>, Option<usize>)> {
    let is_2d = obj
        .cast::<PyUntypedArray>()
        .is_ok_and(|a| numpy::PyUntypedArrayMethods::ndim(a) == 2);
    if is_2d {
        return Ok((obj.clone(), None));
    }
    hook(obj, "_faces")?.extract()
}

/// "; the faces look numbered from 1 ..." when `f`'s indices run from 1 to `nv` (1-based faces
/// of an nv-vertex mesh), else "".
fn one_based_hint(f: &[[u32; 3]], nv: usize) -> String {
    let min = f.iter().flatten().copied().min().unwrap_or(0);
    let max = f.iter().flatten().copied().max().unwrap_or(0) as usize;
    if min == 1 && max == nv {
        format!("; the faces look numbered from 1 (indices 1..{nv}): pass F - 1")
    } else {
        String::new()
    }
}

/// The topology of `nv` vertices and the faces `f` (argument `name`); a face index past the
/// vertex count names the face and the index (and says when the faces look 1-based).
pub fn topology(
    nv: usize,
    f: Vec<[u32; 3]>,
    name: &str,
) -> PyResult<std::sync::Arc<qcshape::mesh::Topology>> {
    let hint = one_based_hint(&f, nv);
    qcshape::mesh::Topology::new(nv, f).map_err(|e| {
        let hint = match e {
            qcshape::mesh::MeshError::IndexOutOfRange { .. } => hint.as_str(),
            _ => "",
        };
        pyo3::exceptions::PyValueError::new_err(format!("{name}: {e}{hint}"))
    })
}

/// The error for positions `what` with `rows` vertices given to a space whose vertex count was
/// inferred from its faces `f` (largest index + 1 > rows): the first face with an index past
/// the positions, and the index.
pub fn index_error(f: &[[u32; 3]], rows: usize, what: &str) -> PyErr {
    let hit = f
        .iter()
        .enumerate()
        .find_map(|(k, t)| t.iter().find(|&&i| i as usize >= rows).map(|&i| (k, i)));
    let (face, index) = hit.unwrap_or((0, 0));
    pyo3::exceptions::PyValueError::new_err(format!(
        "faces: face {face} has index {index}, but {what} has {rows} vertices (the space took its vertex \
         count from the faces' largest index; give n_vertices= or a mesh object to fix it){}",
        one_based_hint(f, rows)
    ))
}
