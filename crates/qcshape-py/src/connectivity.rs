//! Mesh objects passed as poses checked against a space's connectivity (issue 60).

use pyo3::prelude::*;

/// `obj` checked against the connectivity `topo` when it is a mesh object (`poses`: a list of
/// them, a pose sequence), by `qcshape._meshes._points_on` / `_poses_on`: its faces must be
/// `topo`'s face for face, the CLI's message ("shapes do not share one connectivity: face 0 is
/// ... in one and ... in the other") otherwise, or the same after renumbering its vertices, which
/// are then renumbered with a `QcshapeWarning` saying so. Arrays (no faces) pass unchanged.
pub fn on_connectivity<'py>(
    obj: &Bound<'py, PyAny>,
    topo: &qcshape::mesh::Topology,
    name: &str,
    poses: bool,
) -> PyResult<Bound<'py, PyAny>> {
    if crate::meshes::is_array(obj) {
        return Ok(obj.clone());
    }
    let py = obj.py();
    let faces = crate::convert::faces_out(py, topo.faces())?;
    let hook = if poses { "_poses_on" } else { "_points_on" };
    let (out, warning): (Bound<'py, PyAny>, Option<String>) = py
        .import("qcshape._meshes")?
        .getattr(hook)?
        .call1((obj, faces, topo.n_vertices(), name))?
        .extract()?;
    if let Some(w) = warning {
        crate::warn::warn(py, &w)?;
    }
    Ok(out)
}
