//! Clustering, embedding and scores on distance matrices: `KMedoids`, `KMeans` (kernel k-means on
//! a matrix, or eq. 14's intrinsic k-means on a Dataset), `mds` (eq. 16), `scores` (eq. 15).

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use qcshape::cluster::IntrinsicOptions;
use qcshape::cluster::{kernel_kmeans, kmedoids, ClusterOptions, Clustering};
use qcshape::embed::{smacof, MdsOptions};
use qcshape::eval::{adjusted_rand_index, encode_labels, matched_confusion, one_vs_rest};
use qcshape::similarity::DistanceMatrix;
use qcshape::space::ShapeSpace;

use crate::convert::{labels_out, matrix_out, opt_count, square, AnyInt};
use crate::data::{run_pipeline, PyDataset};
use crate::errors;
use crate::options::PipelineKw;
use crate::run::detached;

/// A (n, n) distance matrix argument as the library's checked matrix.
fn distance_matrix(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<DistanceMatrix> {
    let (n, values) = square(obj, name)?;
    let names = (0..n).map(|i| i.to_string()).collect();
    DistanceMatrix::new(names, values).map_err(|e| PyValueError::new_err(format!("{name}: {e}")))
}

fn cluster_options(
    k: Option<AnyInt>,
    n_init: Option<AnyInt>,
    seed: Option<u64>,
    max_iter: Option<AnyInt>,
) -> PyResult<ClusterOptions> {
    let d = ClusterOptions::default();
    let k = opt_count("n_clusters", k, 1, qcshape::limits::MAX_CLUSTERS)?;
    let n_init = opt_count("n_init", n_init, 1, qcshape::limits::MAX_RESTARTS)?;
    let max_iter = opt_count("max_iter", max_iter, 1, qcshape::limits::MAX_ITERATIONS)?;
    Ok(ClusterOptions {
        k: k.unwrap_or(d.k),
        restarts: n_init.unwrap_or(d.restarts),
        seed: seed.unwrap_or(d.seed),
        max_iterations: max_iter.unwrap_or(d.max_iterations),
    })
}

/// PAM k-medoids on a precomputed distance matrix, the best of ``n_init`` seeded runs.
///
/// ``KMedoids(n_clusters=2, n_init=10, random_state=0, max_iter=100).fit(D)`` with D (n, n)
/// symmetric, zero diagonal; then ``labels_`` (n,) int64, ``medoid_indices_`` (n_clusters,),
/// ``inertia_`` (sum of distances to the medoids), ``n_iter_``. Defaults are the library's.
#[pyclass(name = "KMedoids", module = "qcshape")]
pub struct PyKMedoids {
    opts: ClusterOptions,
    fitted: Option<Clustering>,
}

#[pymethods]
impl PyKMedoids {
    #[new]
    #[pyo3(signature = (n_clusters=None, n_init=None, random_state=None, max_iter=None))]
    fn new(
        n_clusters: Option<AnyInt>,
        n_init: Option<AnyInt>,
        random_state: Option<u64>,
        max_iter: Option<AnyInt>,
    ) -> PyResult<Self> {
        Ok(PyKMedoids {
            opts: cluster_options(n_clusters, n_init, random_state, max_iter)?,
            fitted: None,
        })
    }

    /// fit(D) -> self: clusters the items of the distance matrix D (n, n).
    fn fit<'py>(mut slf: PyRefMut<'py, Self>, d: &Bound<'py, PyAny>) -> PyResult<PyRefMut<'py, Self>> {
        let m = distance_matrix(d, "D")?;
        let opts = slf.opts;
        let c = detached(d.py(), None, |_| {
            kmedoids(&m, &opts).map_err(|e| PyValueError::new_err(e.to_string()))
        })?;
        slf.fitted = Some(c);
        Ok(slf)
    }

    /// fit_predict(D) -> labels (n,) int64.
    fn fit_predict<'py>(slf: PyRefMut<'py, Self>, d: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let py = d.py();
        let s = Self::fit(slf, d)?;
        s.labels_(py)
    }

    /// Cluster of each item, (n,) int64.
    #[getter]
    fn labels_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(labels_out(py, &fitted(&self.fitted)?.assignments))
    }

    /// The medoid (item index) of each cluster.
    #[getter]
    fn medoid_indices_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(labels_out(
            py,
            fitted(&self.fitted)?.medoids.as_deref().unwrap_or(&[]),
        ))
    }

    /// Sum of the distances of the items to their medoids.
    #[getter]
    fn inertia_(&self) -> PyResult<f64> {
        Ok(fitted(&self.fitted)?.objective)
    }

    /// Swaps of the kept run.
    #[getter]
    fn n_iter_(&self) -> PyResult<usize> {
        Ok(fitted(&self.fitted)?.iterations)
    }
}

fn fitted(c: &Option<Clustering>) -> PyResult<&Clustering> {
    c.as_ref()
        .ok_or_else(|| PyValueError::new_err("not fitted: call fit first"))
}

/// k-means in shape space.
///
/// ``KMeans(n_clusters=2, n_init=10, random_state=0, max_iter=100)``. ``fit(D)`` with a
/// distance matrix D (n, n): kernel k-means on D (the best of n_init seeded runs).
/// ``fit(dataset, **options)`` with a Dataset: k-means with intrinsic means (eq. 14): the
/// similarity matrix is computed as by ``similarity_matrix(dataset, **options)``, kernel
/// k-means on it gives the start, and the class means are Karcher means of the members'
/// transferred poses. Then ``labels_`` (n,) int64, ``inertia_`` (the objective: sum of squared
/// distances to the centres), ``n_iter_``; with a Dataset also ``kernel_labels_`` (the start)
/// and ``distances_`` (the (n, n) matrix).
#[pyclass(name = "KMeans", module = "qcshape")]
pub struct PyKMeans {
    opts: ClusterOptions,
    fitted: Option<Clustering>,
    kernel: Option<Vec<usize>>,
    matrix: Option<(usize, Vec<f64>)>,
}

#[pymethods]
impl PyKMeans {
    #[new]
    #[pyo3(signature = (n_clusters=None, n_init=None, random_state=None, max_iter=None))]
    fn new(
        n_clusters: Option<AnyInt>,
        n_init: Option<AnyInt>,
        random_state: Option<u64>,
        max_iter: Option<AnyInt>,
    ) -> PyResult<Self> {
        Ok(PyKMeans {
            opts: cluster_options(n_clusters, n_init, random_state, max_iter)?,
            fitted: None,
            kernel: None,
            matrix: None,
        })
    }

    /// fit(X, **options) -> self: X a distance matrix (n, n) (kernel k-means) or a Dataset
    /// (intrinsic k-means, eq. 14; options as for similarity_matrix).
    #[pyo3(signature = (x, **options))]
    fn fit<'py>(
        mut slf: PyRefMut<'py, Self>,
        x: &Bound<'py, PyAny>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = x.py();
        let opts = slf.opts;
        if let Ok(ds) = x.cast::<PyDataset>() {
            let kw = PipelineKw::from_kwargs(options)?;
            let (r, popts) = run_pipeline(py, ds.get(), &kw, qcshape::similarity::Sink::Memory)?;
            let (kernel, intrinsic) = detached(py, kw.threads, |_| {
                let kernel =
                    kernel_kmeans(&r.matrix, &opts).map_err(|e| PyValueError::new_err(e.to_string()))?;
                let space =
                    ShapeSpace::new(r.prepared.topology.clone(), popts.metric, popts.geodesic.clone())
                        .map_err(errors::space)?;
                let i = space
                    .intrinsic_kmeans(
                        &r.prepared,
                        &kernel.assignments,
                        opts.k,
                        &IntrinsicOptions::default(),
                    )
                    .map_err(errors::space)?;
                Ok((kernel, i))
            })?;
            let n = r.matrix.len();
            slf.matrix = Some((n, r.matrix.values().to_vec()));
            slf.kernel = Some(kernel.assignments);
            slf.fitted = Some(Clustering {
                k: opts.k,
                assignments: intrinsic.assignments,
                medoids: None,
                objective: intrinsic.objective,
                iterations: intrinsic.iterations,
                converged: intrinsic.converged,
                restart: 0,
                restart_objectives: Vec::new(),
            });
        } else {
            if options.is_some_and(|o| !o.is_empty()) {
                return Err(PyValueError::new_err(
                    "options: pipeline keywords apply only when fitting a Dataset",
                ));
            }
            let m = distance_matrix(x, "X")?;
            let c = detached(py, None, |_| {
                kernel_kmeans(&m, &opts).map_err(|e| PyValueError::new_err(e.to_string()))
            })?;
            slf.fitted = Some(c);
            slf.kernel = None;
            slf.matrix = None;
        }
        Ok(slf)
    }

    /// Cluster of each item, (n,) int64.
    #[getter]
    fn labels_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(labels_out(py, &fitted(&self.fitted)?.assignments))
    }

    /// The minimized objective (sum of squared distances to the centres).
    #[getter]
    fn inertia_(&self) -> PyResult<f64> {
        Ok(fitted(&self.fitted)?.objective)
    }

    /// Rounds of the kept run.
    #[getter]
    fn n_iter_(&self) -> PyResult<usize> {
        Ok(fitted(&self.fitted)?.iterations)
    }

    /// The kernel k-means start of an intrinsic fit (None after fit(D)).
    #[getter]
    fn kernel_labels_<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        self.kernel.as_ref().map(|k| labels_out(py, k))
    }

    /// The similarity matrix of an intrinsic fit, (n, n) (None after fit(D)).
    #[getter]
    fn distances_<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.matrix
            .as_ref()
            .map(|(n, v)| matrix_out(py, v.clone(), *n, *n))
            .transpose()
    }
}

/// mds(D, n_components=2, random_state=0) -> (X, stress): SMACOF metric MDS (eq. 16) of the
/// distance matrix D (n, n), started from classical MDS: X (n, n_components) float64 centred
/// coordinates, stress the raw stress sum_{i<j} (|x_i - x_j| - d_ij)^2. Defaults are the
/// library's (n_components 1-3).
#[pyfunction]
#[pyo3(signature = (d, n_components=None, random_state=None))]
pub fn mds<'py>(
    py: Python<'py>,
    d: &Bound<'py, PyAny>,
    n_components: Option<AnyInt>,
    random_state: Option<u64>,
) -> PyResult<Bound<'py, PyTuple>> {
    let m = distance_matrix(d, "D")?;
    let def = MdsOptions::default();
    let opts = MdsOptions {
        dims: opt_count("n_components", n_components, 1, 3)?.unwrap_or(def.dims),
        seed: random_state.unwrap_or(def.seed),
        ..def
    };
    let e = detached(py, None, |_| {
        smacof(&m, &opts).map_err(|e| PyValueError::new_err(format!("mds: {e}")))
    })?;
    let n = e.coords.len();
    let flat: Vec<f64> = e.coords.iter().flatten().copied().collect();
    let x = matrix_out(py, flat, n, opts.dims)?;
    PyTuple::new(py, [x, e.raw_stress.into_pyobject(py)?.into_any()])
}

/// Labels of any Python values, as text.
fn text_labels(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<String>> {
    obj.try_iter()
        .map_err(|_| PyValueError::new_err(format!("{name}: expected a sequence of labels")))?
        .map(|x| Ok(x?.str()?.to_string()))
        .collect()
}

/// scores(true_labels, labels) -> dict: how well the clusters ``labels`` recover the classes
/// ``true_labels`` (both length n, any hashable values): clusters are matched to classes by the
/// Hungarian method, then "sensitivity" and "specificity" (eq. 15, of the mean one-vs-rest
/// confusion matrix), "accuracy" (share of items in their class's cluster) and "ari" (adjusted
/// Rand index, no matching needed).
#[pyfunction]
pub fn scores<'py>(
    py: Python<'py>,
    true_labels: &Bound<'py, PyAny>,
    labels: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let t = text_labels(true_labels, "true_labels")?;
    let p = text_labels(labels, "labels")?;
    if t.len() != p.len() {
        return Err(PyValueError::new_err(format!(
            "labels: {} labels for {} true labels",
            p.len(),
            t.len()
        )));
    }
    let (classes, cnames) = encode_labels(&t);
    let (clusters, knames) = encode_labels(&p);
    let bad = |e: qcshape::eval::EvalError| PyValueError::new_err(e.to_string());
    let (_, cm) = matched_confusion(&clusters, knames.len(), &classes, cnames.len()).map_err(bad)?;
    let ovr = one_vs_rest(&cm).map_err(bad)?;
    let ari = adjusted_rand_index(&classes, &clusters).map_err(bad)?;
    let d = PyDict::new(py);
    d.set_item("sensitivity", ovr.sensitivity)?;
    d.set_item("specificity", ovr.specificity)?;
    d.set_item("accuracy", cm.accuracy())?;
    d.set_item("ari", ari)?;
    Ok(d)
}
