//! The two halves of a distributed similarity matrix (`qcshape.dask`): `prepare_pairs` runs the
//! per-deformation part of the pipeline once (interpolation, alignment, transfer, scaling) and
//! returns plain arrays that pickle and scatter; `pair_distances` computes the eq. 13
//! distances of a batch of pairs from those arrays, paying the per-topology set-up (metric
//! pattern, solver layout) once per batch. Together they give the bits of `similarity_matrix`.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use qcshape::similarity::{compute, prepare, Comparison, Run, Selection};
use qcshape::space::ShapeSpace;

use crate::convert::{deformations, deformations_out, faces_out, index_pairs};
use crate::data::PyDataset;
use crate::errors;
use crate::options::PipelineKw;
use crate::run::detached;
use crate::space::topology_from;

/// The output of `prepare_pairs`: poses, faces, names, converged.
type Prepared<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Vec<String>, bool);

/// prepare_pairs(dataset, **options) -> (poses, faces, names, converged): the prepared data set of
/// `similarity_matrix(dataset, **options)`: poses (n, K, nV, 3) float64, every deformation
/// transferred to the common base and multiplied by the normalization factor (the base
/// pose's mean edge becomes 1); faces (nF, 3) int64 of the base; the names; whether
/// every transfer geodesic converged.
#[pyfunction]
#[pyo3(signature = (dataset, **options))]
pub fn prepare_pairs<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Prepared<'py>> {
    let ds = dataset
        .cast::<PyDataset>()
        .map_err(|_| pyo3::exceptions::PyValueError::new_err("dataset: expected a qcshape.Dataset"))?;
    let ds = ds.get();
    let kw = PipelineKw::from_kwargs(options)?;
    let names: Vec<String> = ds.defs.iter().map(|d| d.name.clone()).collect();
    if names.len() < 2 {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "dataset: a similarity matrix needs at least two deformations",
        ));
    }
    let opts = kw.options(&names)?;
    let base = &ds.defs[opts.base];
    let space =
        ShapeSpace::new(base.topology.clone(), opts.metric, opts.geodesic.clone()).map_err(errors::space)?;
    let opts = space.pipeline_options(opts);
    let defs = ds.defs.clone();
    let prepared = detached(py, kw.threads, |w| {
        let opts = qcshape::similarity::PipelineOptions {
            geodesic: w.geodesic(&opts.geodesic),
            ..opts.clone()
        };
        prepare(&defs, &opts, &|_| {}).map_err(|e| errors::space(e.into()))
    })?;
    let poses = deformations_out(py, &prepared.scaled())?;
    let faces = faces_out(py, prepared.topology.faces())?;
    Ok((poses, faces, prepared.names.clone(), prepared.converged))
}

/// pair_distances(poses, faces, pairs, **options) -> (distances, converged): `similarity(i, j)`
/// (eq. 13) for every row `(i, j)` of `pairs` (m, 2), from the output of `prepare_pairs` with the same
/// options: distances (m,) float64 in the metric's units, and whether every geodesic of the batch
/// converged. Only the metric, solver and approx options matter here.
#[pyfunction]
#[pyo3(signature = (poses, faces, pairs, **options))]
pub fn pair_distances<'py>(
    py: Python<'py>,
    poses: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    pairs: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyAny>, bool)> {
    let kw = PipelineKw::from_kwargs(options)?;
    let defs = deformations(poses, "poses")?;
    let nv = defs[0][0].len();
    let topo = topology_from(faces, "faces", nv)?;
    let todo = index_pairs(pairs, "pairs", defs.len())?;
    let names: Vec<String> = (0..defs.len()).map(|i| i.to_string()).collect();
    let opts = kw.options(&names)?;
    let out = detached(py, kw.threads, |w| {
        let opts = qcshape::similarity::PipelineOptions {
            geodesic: w.geodesic(&opts.geodesic),
            ..opts.clone()
        };
        // Every transferred deformation starts at the (scaled) base pose: the pipeline's
        // calibration, bit for bit.
        let calibration = opts
            .metric
            .calibrate(&topo, &[&defs[0][0]])
            .map_err(|e| errors::space(qcshape::geodesic::GeodesicError::from(e).into()))?;
        let metric = opts.metric.build(&calibration);
        // The poses are already in the solver's coordinates (factor 1).
        let input = Comparison {
            names: &names,
            topology: topo,
            metric: metric.as_ref(),
            factor: 1.0,
            poses: &defs,
        };
        let run = Run {
            selection: Selection::Listed(todo),
            cancel: Some(w.flag()),
            ..Default::default()
        };
        compute(&input, &opts, &run)
            .map(|o| o.pairs)
            .map_err(|e| errors::space(e.into()))
    })?;
    let converged = out.iter().all(|p| p.converged);
    let d: Vec<f64> = out.iter().map(|p| p.distance).collect();
    Ok((numpy::PyArray1::from_vec(py, d).into_any(), converged))
}
