//! `qcshape` for Python: a pure-Rust layer (PyO3, numpy) over the qcshape library. Arrays in
//! and out are numpy float64 (positions, (nV, 3)) and int64 (faces, (nF, 3)); every
//! computation releases the GIL and stops at Ctrl-C. The module is built by maturin
//! (`pip install ./crates/qcshape-py`) and re-exported by `python/qcshape/__init__.py`.

mod analysis;
mod connectivity;
mod convert;
mod data;
mod distributed;
mod errors;
mod fit;
mod meshes;
mod options;
mod run;
mod space;
mod warn;

use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// Deformation similarity in quasi-conformal shape space (Rust core).
#[pymodule]
fn _qcshape(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("QcshapeWarning", m.py().get_type::<warn::QcshapeWarning>())?;
    // The registries of metrics and terms (qcshape::metric::METRICS, TERMS): their names.
    let py = m.py();
    m.add(
        "METRICS",
        PyTuple::new(py, qcshape::metric::METRICS.map(|i| i.name))?,
    )?;
    m.add("TERMS", PyTuple::new(py, qcshape::metric::TERMS.map(|i| i.name))?)?;
    m.add_class::<space::PyShapeSpace>()?;
    m.add_class::<space::PyGeodesic>()?;
    m.add_class::<data::PyDataset>()?;
    m.add_class::<analysis::PyKMedoids>()?;
    m.add_class::<analysis::PyKMeans>()?;
    m.add_function(wrap_pyfunction!(data::read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(data::write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(data::icosphere, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit, m)?)?;
    m.add_function(wrap_pyfunction!(data::similarity_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::prepare_pairs, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::pair_distances, m)?)?;
    m.add_function(wrap_pyfunction!(data::pair_contributions, m)?)?;
    m.add_function(wrap_pyfunction!(data::motion_maps, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::mds, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::scores, m)?)?;
    m.add_function(wrap_pyfunction!(options::settings, m)?)?;
    Ok(())
}
