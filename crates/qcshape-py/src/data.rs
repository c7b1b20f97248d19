//! Files and data sets: `read_mesh`, `write_mesh`, `icosphere`, `qcshape.Dataset` and
//! `similarity_matrix` (the pipeline of `qcshape similarity`).

use std::path::PathBuf;
use std::sync::Arc;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList, PyTuple};
use qcshape::dataset::{Dataset, Deformation};
use qcshape::io::{self, VertexAttributes};
use qcshape::similarity::{Event, PipelineOptions, Run, Selection, Sink};
use qcshape::space::{ShapeSpace, SimilarityResult};
use qcshape::synth::{genus0_benchmark, icosphere as ico, SynthOptions};

use crate::convert::{
    count, faces_out, matrix_out, opt_count, points, points_out, sequence, sequence_out, vector, AnyInt,
};
use crate::errors;
use crate::options::PipelineKw;
use crate::run::{detached_with, Progress};
use crate::space::topology_from;

/// read_mesh(path, point_data=False) -> (V, F), or (V, F, fields) with point_data=True: a
/// mesh file (.obj, .ply, .off, .stl, .vtk, .vtp, .vtu) as V (nV, 3) float64 and F (nF, 3)
/// int64 (polygons triangulated). fields is a dict of the file's named per-vertex arrays (PLY
/// extra vertex properties, VTK POINT_DATA, VTP/VTU PointData), each float64 (nV,) for one
/// component or (nV, k) for k components (vectors: k = 3). Raises OSError if the file cannot
/// be read, ValueError (with the file name and line) if it is not a valid mesh or has no
/// faces.
#[pyfunction]
#[pyo3(signature = (path, point_data=false))]
pub fn read_mesh<'py>(py: Python<'py>, path: PathBuf, point_data: bool) -> PyResult<Bound<'py, PyTuple>> {
    let m = py.detach(|| io::read_mesh(&path)).map_err(errors::io)?;
    if m.faces.is_empty() {
        return Err(errors::io(io::IoError::Mesh {
            path,
            error: qcshape::mesh::MeshError::NoFaces,
        }));
    }
    // The reader's remarks (fan-triangulated polygons, ignored trailing data, welded STL
    // corners), as `qcshape info` lists them: not silent (issue 60).
    for w in &m.warnings {
        crate::warn::warn(py, &format!("{}: {w}", path.display()))?;
    }
    let v = points_out(py, &m.positions)?;
    let f = faces_out(py, &m.faces)?;
    if !point_data {
        return PyTuple::new(py, [v, f]);
    }
    let fields = PyDict::new(py);
    for a in m.point_data {
        let n = m.positions.len();
        let arr = numpy::PyArray1::from_vec(py, a.values);
        let arr = if a.components == 1 {
            arr.into_any()
        } else {
            numpy::PyArrayMethods::reshape(&arr, [n, a.components])?.into_any()
        };
        fields.set_item(a.name, arr)?;
    }
    PyTuple::new(py, [v, f, fields.into_any()])
}

/// write_mesh(path, V, F, point_data=None): writes V (nV, 3) and F (nF, 3) (or
/// ``write_mesh(path, mesh)``, a trimesh / pyvista / meshio object) in the format of
/// the file name's extension, atomically (complete or absent). point_data = {"name": values}
/// adds named per-vertex fields, each a scalar (nV,) or a vector (nV, 3) (.ply, .vtk, .vtp and
/// .vtu only; PLY also writes the first scalar as `quality`, VTK as `SCALARS` / `VECTORS`). A path
/// naming a folder is a ``ValueError``.
#[pyfunction]
#[pyo3(signature = (path, vertices, faces=None, point_data=None))]
pub fn write_mesh(
    py: Python<'_>,
    path: PathBuf,
    vertices: &Bound<'_, PyAny>,
    faces: Option<&Bound<'_, PyAny>>,
    point_data: Option<&Bound<'_, PyDict>>,
) -> PyResult<()> {
    // write_mesh(path, mesh): a mesh object's own faces.
    let faces = match faces {
        Some(f) => f.clone(),
        None => match crate::meshes::faces_arg(vertices)? {
            (f, Some(_)) => f,
            _ => {
                return Err(PyValueError::new_err(
                    "faces: missing (give F, or a trimesh, pyvista or meshio mesh as the only argument)",
                ))
            }
        },
    };
    let faces = &faces;
    // The one output check of the library and the CLI: here, a path naming a folder.
    qcshape::outputs::refuse_input_overlap(&[], &path, "path")
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let v = points(vertices, "vertices", None)?;
    let f = crate::convert::faces(faces, "faces")?;
    enum Values {
        Scalar(Vec<f64>),
        Vector(Vec<[f64; 3]>),
    }
    let mut fields: Vec<(String, Values)> = Vec::new();
    if let Some(d) = point_data {
        for (k, vals) in d.iter() {
            let name: String = k
                .extract()
                .map_err(|_| PyValueError::new_err("point_data: keys must be strings"))?;
            let what = format!("point_data[{name:?}]");
            let values = match vector(&vals, &what, v.len()) {
                Ok(s) => Values::Scalar(s),
                Err(scalar_err) => match points(&vals, &what, Some(v.len())) {
                    Ok(x) => Values::Vector(x),
                    Err(_) => return Err(scalar_err),
                },
            };
            fields.push((name, values));
        }
    }
    py.detach(|| {
        let refs: Vec<io::Field> = fields
            .iter()
            .map(|(n, x)| match x {
                Values::Scalar(s) => io::Field::scalar(n, s),
                Values::Vector(x) => io::Field::vector(n, x),
            })
            .collect();
        if refs.is_empty() {
            io::write_mesh(&path, &v, &f, &VertexAttributes::default())
        } else {
            io::write_mesh_fields(&path, &v, &f, &refs)
        }
    })
    .map_err(errors::io)
}

/// icosphere(level=1) -> (V, F): the unit icosphere with 10 * 4**level + 2 vertices (level 1:
/// 42), the template of the synthetic benchmark.
#[pyfunction]
#[pyo3(signature = (level=AnyInt::new(1)), text_signature = "(level=1)")]
pub fn icosphere<'py>(py: Python<'py>, level: AnyInt) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let level = count("level", level, 0, 6)? as u32;
    let s = ico(level);
    Ok((points_out(py, &s.positions)?, faces_out(py, s.topology.faces())?))
}

/// A data set of deformations: each a sequence of poses (K, nV, 3) on one shared
/// connectivity, with a name and an optional class label.
///
/// ``Dataset(poses=[(K, nV, 3) arrays], faces=F, names=None, labels=None)`` (a deformation may
/// be a list of trimesh / pyvista / meshio meshes: each is checked against ``faces``, which
/// defaults to the first mesh's, as ``ShapeSpace`` checks its arguments), or
/// ``Dataset.from_manifest(path)`` / ``Dataset.load(path)`` (a manifest CSV
/// ``deformation,label,pose,path`` or a folder of deformation folders), or
/// ``Dataset.synthetic(level=1)`` (the paper's 48 synthetic deformations, as ``qcshape synth``).
#[pyclass(name = "Dataset", module = "qcshape", frozen)]
pub struct PyDataset {
    pub defs: Arc<Vec<Deformation>>,
    /// With ``load(path, template=...)``: the fit's quality, one dict per pose (the columns of
    /// ``qcshape fit``'s quality.csv); None otherwise.
    pub fit_quality: Option<Py<PyList>>,
}

#[pymethods]
impl PyDataset {
    #[new]
    #[pyo3(signature = (poses, faces=None, names=None, labels=None))]
    fn new(
        poses: &Bound<'_, PyAny>,
        faces: Option<&Bound<'_, PyAny>>,
        names: Option<Vec<String>>,
        labels: Option<Vec<Option<String>>>,
    ) -> PyResult<Self> {
        let list: Vec<Bound<'_, PyAny>> = poses.try_iter()?.collect::<PyResult<_>>()?;
        if list.is_empty() {
            return Err(PyValueError::new_err("poses: the data set has no deformations"));
        }
        // Without faces: the first pose's, when it is a mesh object.
        let first_mesh = match faces {
            Some(_) => None,
            None => list[0]
                .try_iter()
                .ok()
                .and_then(|mut it| it.next())
                .and_then(Result::ok)
                .filter(|m| !m.is_instance_of::<numpy::PyUntypedArray>()),
        };
        let faces = match (faces, &first_mesh) {
            (Some(f), _) => f.clone(),
            (None, Some(m)) => m.clone(),
            (None, None) => {
                return Err(PyValueError::new_err(
                    "faces: required when the poses are arrays (only mesh objects carry their faces)",
                ))
            }
        };
        let (faces, mesh_nv) = crate::meshes::faces_arg(&faces)?;
        let first = match mesh_nv {
            // The faces' mesh gives the vertex count.
            Some(n) => vec![vec![[0.0; 3]; n]],
            None => sequence(&crate::meshes::poses_arg(&list[0])?, "poses[0]", None, 1)?,
        };
        let nv = first[0].len();
        let topo = topology_from(&faces, "faces", nv)?;
        let n = list.len();
        let names = names.unwrap_or_else(|| (0..n).map(|i| format!("d{i}")).collect());
        if names.len() != n {
            return Err(PyValueError::new_err(format!(
                "names: {} names for {n} deformations",
                names.len()
            )));
        }
        let mut seen = std::collections::HashMap::new();
        for (i, name) in names.iter().enumerate() {
            if let Some(j) = seen.insert(name.as_str(), i) {
                return Err(PyValueError::new_err(format!(
                    "names: {name:?} names deformations {j} and {i}; names must be unique"
                )));
            }
        }
        let labels = labels.unwrap_or_else(|| vec![None; n]);
        if labels.len() != n {
            return Err(PyValueError::new_err(format!(
                "labels: {} labels for {n} deformations",
                labels.len()
            )));
        }
        let mut defs = Vec::with_capacity(n);
        for (i, ((d, name), label)) in list.iter().zip(names).zip(labels).enumerate() {
            let name_i = format!("poses[{i}]");
            let d = crate::connectivity::on_connectivity(d, &topo, &name_i, true)?;
            let poses = sequence(&d, &name_i, Some(nv), 1)?;
            // The checks the mesh readers make on every pose file (zero-area faces included).
            for (k, p) in poses.iter().enumerate() {
                qcshape::mesh::Shape::new_checked(topo.clone(), p.clone(), io::DEGENERATE_REL_TOL)
                    .map_err(|e| PyValueError::new_err(format!("poses[{i}], pose {k}: {e}")))?;
            }
            defs.push(Deformation {
                name,
                label,
                topology: topo.clone(),
                poses,
                paths: Vec::new(),
                warnings: Vec::new(),
            });
        }
        Ok(PyDataset {
            defs: Arc::new(defs),
            fit_quality: None,
        })
    }

    /// Dataset.from_manifest(path, template=None): a manifest CSV (deformation,label,pose,path;
    /// paths relative to the manifest). With ``template`` see ``Dataset.load``. OSError /
    /// ValueError name the file and line.
    #[staticmethod]
    #[pyo3(signature = (path, template=None))]
    fn from_manifest(py: Python<'_>, path: PathBuf, template: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        if template.is_some() {
            return fitted(py, &path, template);
        }
        let d = py
            .detach(|| Dataset::from_manifest(&path))
            .map_err(errors::dataset)?;
        reader_warnings(py, &d)?;
        Ok(PyDataset {
            defs: Arc::new(d.deformations),
            fit_quality: None,
        })
    }

    /// Dataset.load(path, template=None): a manifest, or a folder (its manifest.csv, else one
    /// folder per deformation), as ``qcshape similarity`` reads its input. With ``template`` (a
    /// mesh file, a (vertices (nV, 3), faces (nF, 3)) pair or a trimesh / pyvista / meshio mesh)
    /// the poses may have any triangulation: each deformation's poses are fitted with the
    /// template first, tracked from pose to pose (``qcshape similarity --template``, the method
    /// and defaults of ``qs.fit``), and the data set is on the template's connectivity;
    /// ``fit_quality`` then lists each pose's fit quality (a dict with quality.csv's columns)
    /// and a poor fit issues a QcshapeWarning.
    #[staticmethod]
    #[pyo3(signature = (path, template=None))]
    fn load(py: Python<'_>, path: PathBuf, template: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        if template.is_some() {
            return fitted(py, &path, template);
        }
        let d = py.detach(|| Dataset::load(&path)).map_err(errors::dataset)?;
        reader_warnings(py, &d)?;
        Ok(PyDataset {
            defs: Arc::new(d.deformations),
            fit_quality: None,
        })
    }

    /// With ``Dataset.load(path, template=...)``: each fitted pose's quality, a list of dicts
    /// (keys: quality.csv's columns: deformation, pose, source, mean, p95, hausdorff,
    /// median_vertex (in template mean edge lengths), min_angle (degrees), flipped,
    /// strain_rms, strain_max, edge_length (target units), scale, poor); None otherwise.
    #[getter]
    fn fit_quality(&self, py: Python<'_>) -> Option<Py<PyList>> {
        self.fit_quality.as_ref().map(|q| q.clone_ref(py))
    }

    /// Dataset.synthetic(level=1, poses=None, seed=None, jitter=None): the paper's synthetic
    /// benchmark (6 shapes x 8 deformations, on icosphere level ``level``), as ``qcshape synth``
    /// makes it (defaults from the library).
    #[staticmethod]
    #[pyo3(signature = (level=AnyInt::new(1), poses=None, seed=None, jitter=None), text_signature = "(level=1, poses=None, seed=None, jitter=None)")]
    fn synthetic(
        level: AnyInt,
        poses: Option<AnyInt>,
        seed: Option<u64>,
        jitter: Option<f64>,
    ) -> PyResult<Self> {
        let level = count("level", level, 0, qcshape::limits::MAX_ICOSPHERE_LEVEL as usize)? as u32;
        let poses = opt_count("poses", poses, 0, qcshape::limits::MAX_POSES)?;
        let d = SynthOptions::default();
        let opts = SynthOptions {
            level,
            poses: poses.unwrap_or(d.poses),
            seed: seed.unwrap_or(d.seed),
            jitter: jitter.unwrap_or(d.jitter),
        };
        let defs = genus0_benchmark(&opts).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(PyDataset {
            defs: Arc::new(defs),
            fit_quality: None,
        })
    }

    fn __len__(&self) -> usize {
        self.defs.len()
    }

    /// ``ds[i]``: the poses of deformation i, (K, nV, 3) float64 (negative i counts from the
    /// end); ``ds[a:b:c]``: a Dataset of those deformations (names and labels kept).
    fn __getitem__<'py>(&self, py: Python<'py>, index: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        if let Ok(slice) = index.cast::<pyo3::types::PySlice>() {
            let ids = slice.indices(self.defs.len() as isize)?;
            let (mut i, mut picked) = (ids.start, Vec::with_capacity(ids.slicelength));
            for _ in 0..ids.slicelength {
                picked.push(self.defs[i as usize].clone());
                i += ids.step;
            }
            if picked.is_empty() {
                return Err(PyValueError::new_err("index: the slice selects no deformation"));
            }
            return Ok(Bound::new(
                py,
                PyDataset {
                    defs: Arc::new(picked),
                    fit_quality: None,
                },
            )?
            .into_any());
        }
        let i: isize = index
            .extract()
            .map_err(|_| pyo3::exceptions::PyTypeError::new_err("index: expected an integer or a slice"))?;
        let n = self.defs.len() as isize;
        let j = if i < 0 { i + n } else { i };
        if !(0..n).contains(&j) {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "deformation {i} is out of range ({n} deformations)"
            )));
        }
        sequence_out(py, &self.defs[j as usize].poses)
    }

    /// Pickle support (e.g. to send a data set to Dask workers): rebuilt from its poses, faces,
    /// names and labels.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let me = slf.get();
        let poses = me
            .defs
            .iter()
            .map(|d| sequence_out(py, &d.poses))
            .collect::<PyResult<Vec<_>>>()?;
        let args = (
            pyo3::types::PyList::new(py, poses)?,
            faces_out(py, me.defs[0].topology.faces())?,
            me.defs.iter().map(|d| d.name.clone()).collect::<Vec<_>>(),
            me.defs.iter().map(|d| d.label.clone()).collect::<Vec<_>>(),
        );
        PyTuple::new(
            py,
            [slf.get_type().into_any(), args.into_pyobject(py)?.into_any()],
        )
    }

    /// Names of the deformations, in order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.defs.iter().map(|d| d.name.clone()).collect()
    }

    /// Class labels (None where unknown).
    #[getter]
    fn labels(&self) -> Vec<Option<String>> {
        self.defs.iter().map(|d| d.label.clone()).collect()
    }

    /// Faces of the first deformation, (nF, 3) int64.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        faces_out(py, self.defs[0].topology.faces())
    }

    /// Vertices per pose.
    #[getter]
    fn n_vertices(&self) -> usize {
        self.defs[0].topology.n_vertices()
    }

    fn __repr__(&self) -> String {
        format!(
            "Dataset({} deformations, {} poses, {} vertices)",
            self.defs.len(),
            self.defs[0].poses.len(),
            self.n_vertices()
        )
    }
}

/// The mesh readers' remarks on a data set's files (fan-triangulated polygons, ...), one
/// `QcshapeWarning` each, as `qs.read_mesh` gives them.
fn reader_warnings(py: Python<'_>, d: &Dataset) -> PyResult<()> {
    for def in &d.deformations {
        for w in &def.warnings {
            crate::warn::warn(py, &format!("deformation {:?}: {w}", def.name))?;
        }
    }
    Ok(())
}

/// `opts` with the monitor of `w` on its geodesics: Ctrl-C stops a solve between two iterations.
fn watched(opts: &PipelineOptions, w: &crate::run::Watch) -> PipelineOptions {
    PipelineOptions {
        geodesic: w.geodesic(&opts.geodesic),
        ..opts.clone()
    }
}

/// The progress of a preparation (interpolation and transfer of `n` deformations) for the
/// `progress=` keyword of `kw`.
fn preparation_progress(py: Python<'_>, kw: &PipelineKw, n: usize) -> PyResult<Progress> {
    Progress::new(py, kw.progress.as_ref().map(|p| p.bind(py)), [n, n, 0])
}

/// The pipeline of `qcshape similarity` on a data set, GIL released, with progress and Ctrl-C.
pub fn run_pipeline(
    py: Python<'_>,
    ds: &PyDataset,
    kw: &PipelineKw,
    sink: Sink,
) -> PyResult<(SimilarityResult, PipelineOptions)> {
    let names: Vec<String> = ds.defs.iter().map(|d| d.name.clone()).collect();
    let n = names.len();
    if n < 2 {
        return Err(PyValueError::new_err(
            "dataset: a similarity matrix needs at least two deformations",
        ));
    }
    let opts = kw.options(&names)?;
    let base = &ds.defs[opts.base];
    let space =
        ShapeSpace::new(base.topology.clone(), opts.metric, opts.geodesic.clone()).map_err(errors::space)?;
    let bar = Progress::new(
        py,
        kw.progress.as_ref().map(|p| p.bind(py)),
        [n, n, n * (n - 1) / 2],
    )?;
    let defs = ds.defs.clone();
    let template = opts.clone();
    // One run at a time on a journal (released when the call returns).
    let _lock = match &sink {
        Sink::Journal { path, .. } => Some(
            qcshape::outputs::RunLock::acquire(path)
                .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("journal: {e}")))?,
        ),
        Sink::Memory => None,
    };
    // Ctrl-C also stops the geodesic being solved (between two iterations).
    let r = crate::space::solve(py, &space, kw.threads, Some(&bar), |s, w| {
        let events = |e: Event<'_>| bar.event(e);
        let run = Run {
            selection: Selection::All,
            sink,
            cancel: Some(w.flag()),
            events: &events,
        };
        s.similarity_matrix(&defs, template, &run)
    })?;
    Ok((r, opts))
}

/// similarity_matrix(dataset, **options) -> ndarray (n, n): the similarity matrix (eq. 13) of
/// a Dataset, computed as ``qcshape similarity`` does (interpolation, transfer to the first
/// pose of the base deformation, sum of pose distances), equal to its CSV. Options (None or
/// left out: the library's defaults): metric, form, weights, lam, metric_scale, stretch,
/// qc_weights, qc_floor, qc_smooth, l2_areas (the metric, as ``ShapeSpace``);
/// steps, solver, tolerance, energy_tolerance, length_tolerance (the geodesics; the last
/// stops each distance once its length has settled, 1e-8, 0 = off); insert (poses inserted between
/// key poses, 0), levels (1), transport ("euclidean" | "parallel" | "schild"), align ("rigid" |
/// "similarity" | "none": placement of each deformation on the base), smooth_length (the
/// smoothing length of every pose relative to its area radius sqrt(area / 4 pi), 0.18: a
/// low-pass filter that means the same at every mesh resolution; 0 = none), smooth (N Taubin
/// iterations instead, the previous default 10; 0 = the paper's pipeline), base (name or index, 0), approx ("exact" |
/// "straight": straight-path lengths, much cheaper, see docs/scale.md | "tangent": the metric
/// linearized at the common base, one feature vector per pose; quasi-conformal weighs each pair
/// by its own curvature-change weights); threads (None: all cores); progress (None: a bar on a
/// terminal or in Jupyter, tqdm's when installed, plain lines at most every 10 s in a log; True:
/// also each stage's last count in a log; False: nothing; a callable: called with (stage, done,
/// total)). Distances are in the metric's units: dimensionless on the default invariant scale,
/// in mean-edge units (coordinates divided by the base pose's mean edge length) on the calibrated
/// and raw scales.
///
/// With ``journal=PATH`` every finished pair is appended to the file PATH as it completes (the
/// journal of ``qcshape similarity``); if the call is interrupted (Ctrl-C, a killed kernel or
/// job), the same call with ``resume=True`` computes only the missing pairs and returns the same
/// matrix bit for bit. The journal is removed once the matrix is returned; an existing file that
/// is not a qcshape journal is refused, never replaced.
///
/// With ``return_details=True`` the result is ``(D, details)``, details a dict of numpy arrays
/// over the P = n (n - 1) / 2 pairs i < j in row order and the K poses: ``pairs`` (P, 2) int64
/// (i, j); ``distance`` (P, K) dis(M_k, N_k); ``geometric_energy`` and ``regularizer_energy``
/// (P, K), the energy (eq. 12) of each pose's path (the geodesic's, or the straight path's with
/// approx="straight") split into the metric's own term and the L2 regularizer (0 for identical
/// poses, NaN with approx="tangent", which measures no path); ``regularizer_share`` (P,), the
/// regularizer's part of each pair's summed energy (above 0.5: the distance measures L2
/// displacement more than the metric's geometry; lower ``lam``).
#[pyfunction]
#[pyo3(signature = (dataset, *, return_details=None, journal=None, resume=false, **options))]
#[pyo3(
    text_signature = "(dataset, *, return_details=False, journal=None, resume=False, metric='isometric', form='quadratic', weights='endpoints', lam=0.01, metric_scale='invariant', stretch=0.1, bending=0.0001, qc_weights='rms', qc_floor=0.5, qc_smooth=0, l2_areas='frozen', steps=8, solver='preconditioned', gauge='linear', tolerance=1e-6, energy_tolerance=1e-12, length_tolerance=1e-8, insert=0, levels=1, transport='euclidean', align='rigid', smooth=None, smooth_length=0.18, base=None, approx='exact', threads=None, progress=None)"
)]
#[allow(clippy::too_many_arguments)]
pub fn similarity_matrix<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, PyAny>,
    return_details: Option<&Bound<'py, PyAny>>,
    journal: Option<std::path::PathBuf>,
    resume: bool,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let ds = dataset
        .cast::<PyDataset>()
        .map_err(|_| PyValueError::new_err("dataset: expected a qcshape.Dataset"))?;
    let details = match return_details {
        Some(v) if !v.is_none() => v
            .cast::<PyBool>()
            .map_err(|_| PyValueError::new_err("return_details: expected True or False"))?
            .is_true(),
        _ => false,
    };
    let kw = PipelineKw::from_kwargs(options)?;
    let sink = match journal {
        Some(path) => Sink::Journal { path, resume },
        None if resume => {
            return Err(PyValueError::new_err(
                "resume=True needs journal= (the file an earlier call recorded its pairs in)",
            ))
        }
        None => Sink::Memory,
    };
    let (r, opts) = run_pipeline(py, ds.get(), &kw, sink)?;
    crate::warn::pairs(
        py,
        &r.pairs,
        r.prepared.converged,
        &opts.metric,
        opts.geodesic.solver,
    )?;
    let n = r.matrix.len();
    let d = matrix_out(py, r.matrix.values().to_vec(), n, n)?;
    if !details {
        return Ok(d);
    }
    let out = PyDict::new(py);
    for (key, value) in pair_details(py, &r.pairs)? {
        out.set_item(key, value)?;
    }
    Ok(PyTuple::new(py, [d, out.into_any()])?.into_any())
}

/// The arrays of ``similarity_matrix(..., return_details=True)``'s dict for `pairs` (row order,
/// every pair with the same pose count K): `pairs` (P, 2) int64, `distance`,
/// `geometric_energy`, `regularizer_energy` (P, K) and `regularizer_share` (P,) float64, NaN
/// where the energy split is unknown.
fn pair_details<'py>(
    py: Python<'py>,
    pairs: &[qcshape::similarity::PairDistance],
) -> PyResult<Vec<(&'static str, Bound<'py, PyAny>)>> {
    use numpy::PyArrayMethods;
    let p = pairs.len();
    let k = pairs.first().map_or(0, |x| x.per_pose.len());
    let ij: Vec<i64> = pairs.iter().flat_map(|x| [x.i as i64, x.j as i64]).collect();
    let part = |which: usize| -> Vec<f64> {
        pairs
            .iter()
            .flat_map(|x| match &x.per_pose_energy {
                Some(e) => e.iter().map(|v| v[which]).collect::<Vec<f64>>(),
                None => vec![f64::NAN; x.per_pose.len()],
            })
            .collect()
    };
    let distance: Vec<f64> = pairs.iter().flat_map(|x| x.per_pose.iter().copied()).collect();
    let share: Vec<f64> = pairs
        .iter()
        .map(|x| x.regularizer_share().unwrap_or(f64::NAN))
        .collect();
    Ok(vec![
        (
            "pairs",
            numpy::PyArray1::from_vec(py, ij).reshape([p, 2])?.into_any(),
        ),
        ("distance", matrix_out(py, distance, p, k)?),
        ("geometric_energy", matrix_out(py, part(0), p, k)?),
        ("regularizer_energy", matrix_out(py, part(1), p, k)?),
        (
            "regularizer_share",
            numpy::PyArray1::from_vec(py, share).into_any(),
        ),
    ])
}

/// pair_contributions(dataset, a, b, **options) -> ndarray (nV,): the per-vertex split of the
/// similarity of deformations `a` and `b` (index or name) of a Dataset, computed with the same
/// preparation (interpolation, smoothing, alignment, transfer to the base's first pose) and
/// solver as ``similarity_matrix`` with the same options: entry `v` is vertex v's share of
/// sum_k dis(M_k, N_k) (faces' and edges' terms shared equally among their vertices, each
/// segment's length in proportion to its energy split; docs/maps.md), so the array sums to the
/// matrix entry (a, b). Normalized length units. Options: those of ``similarity_matrix``.
#[pyfunction]
#[pyo3(signature = (dataset, a, b, **options))]
#[pyo3(
    text_signature = "(dataset, a, b, *, metric='isometric', form='quadratic', weights='endpoints', lam=0.01, metric_scale='invariant', stretch=0.1, bending=0.0001, qc_weights='rms', qc_floor=0.5, qc_smooth=0, l2_areas='frozen', steps=8, solver='preconditioned', gauge='linear', tolerance=1e-6, energy_tolerance=1e-12, length_tolerance=1e-8, insert=0, levels=1, transport='euclidean', align='rigid', smooth=None, smooth_length=0.18, base=None, approx='exact', threads=None, progress=None)"
)]
pub fn pair_contributions<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, PyAny>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let ds = dataset
        .cast::<PyDataset>()
        .map_err(|_| PyValueError::new_err("dataset: expected a qcshape.Dataset"))?;
    let kw = PipelineKw::from_kwargs(options)?;
    let defs = ds.get().defs.clone();
    let names: Vec<String> = defs.iter().map(|d| d.name.clone()).collect();
    if names.len() < 2 {
        return Err(PyValueError::new_err(
            "dataset: a pair needs at least two deformations",
        ));
    }
    let name_of = |x: &Bound<'py, PyAny>, which: &str| -> PyResult<String> {
        if let Ok(i) = x.extract::<usize>() {
            names.get(i).cloned().ok_or_else(|| {
                PyValueError::new_err(format!(
                    "{which}: index {i} out of range for {} deformations",
                    names.len()
                ))
            })
        } else if let Ok(s) = x.extract::<String>() {
            Ok(s)
        } else {
            Err(PyValueError::new_err(format!(
                "{which}: expected a deformation index or name"
            )))
        }
    };
    let (na, nb) = (name_of(a, "a")?, name_of(b, "b")?);
    let opts = kw.options(&names)?;
    let bar = preparation_progress(py, &kw, defs.len())?;
    let total = detached_with(py, kw.threads, Some(&bar), |w| {
        let opts = watched(&opts, w);
        let prepared = qcshape::similarity::prepare(&defs, &opts, &|e| bar.event(e))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        qcshape_studies::explain::explain(&prepared, &opts, &na, &nb)
            .map(|e| e.contributions.total)
            .map_err(|e| PyValueError::new_err(e.to_string()))
    })?;
    Ok(numpy::PyArray1::from_vec(py, total).into_any())
}

/// motion_maps(dataset, *, measure='normal', scale='absolute', **options) -> ndarray (n, nV):
/// every deformation's own amount of motion per vertex, after the same preparation as
/// ``similarity_matrix`` with the same options (smoothing, alignment, interpolation, transfer
/// to the base's first pose; coordinates scaled by the common factor). ``measure='normal'``:
/// the motion along the surface normal summed over the steps, times the vertex area on the
/// base (length^3, normalized); ``'metric'``: the metric's per-vertex length split of every
/// step (normalized length). ``scale='share'`` divides each row by its sum. Row i minus row j,
/// or a group mean minus another, is the signed map of ``qcshape localize`` (docs/maps.md).
#[pyfunction]
#[pyo3(signature = (dataset, *, measure="normal", scale="absolute", **options))]
#[pyo3(
    text_signature = "(dataset, *, measure='normal', scale='absolute', metric='isometric', form='quadratic', weights='endpoints', lam=0.01, metric_scale='invariant', stretch=0.1, bending=0.0001, qc_weights='rms', qc_floor=0.5, qc_smooth=0, l2_areas='frozen', steps=8, solver='preconditioned', gauge='linear', tolerance=1e-6, energy_tolerance=1e-12, length_tolerance=1e-8, insert=0, levels=1, transport='euclidean', align='rigid', smooth=None, smooth_length=0.18, base=None, approx='exact', threads=None, progress=None)"
)]
pub fn motion_maps<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, PyAny>,
    measure: &str,
    scale: &str,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    use qcshape_studies::localize::{MotionMeasure, MotionScale};
    let ds = dataset
        .cast::<PyDataset>()
        .map_err(|_| PyValueError::new_err("dataset: expected a qcshape.Dataset"))?;
    let bad = |what: &'static str| {
        move |e: qcshape_studies::localize::LocalizeError| PyValueError::new_err(format!("{what}: {e}"))
    };
    let scale: MotionScale = scale.parse().map_err(bad("scale"))?;
    let kw = PipelineKw::from_kwargs(options)?;
    let defs = ds.get().defs.clone();
    let names: Vec<String> = defs.iter().map(|d| d.name.clone()).collect();
    let opts = kw.options(&names)?;
    // The measure's name is checked before the pipeline runs (with an uncalibrated metric).
    let raw = opts.metric.build(&qcshape::metric::Calibration::RAW);
    MotionMeasure::parse(measure, raw.as_ref()).map_err(bad("measure"))?;
    let bar = preparation_progress(py, &kw, defs.len())?;
    let (rows, nv, values) = detached_with(py, kw.threads, Some(&bar), |w| {
        let opts = watched(&opts, w);
        let prepared = qcshape::similarity::prepare(&defs, &opts, &|e| bar.event(e))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let metric = prepared.metric(&opts.metric);
        let measure = MotionMeasure::parse(measure, metric.as_ref()).map_err(bad("measure"))?;
        let m =
            qcshape_studies::localize::motion_maps(measure, scale, &prepared.topology, &prepared.scaled())
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let nv = prepared.topology.n_vertices();
        Ok((m.len(), nv, m.concat()))
    })?;
    matrix_out(py, values, rows, nv)
}

/// The template of ``Dataset.load(path, template=...)``: a mesh file, a (vertices, faces) pair
/// or a mesh object.
fn template_shape(obj: &Bound<'_, PyAny>) -> PyResult<qcshape::mesh::Shape> {
    if let Ok(path) = obj.extract::<PathBuf>() {
        return io::load_shape(&path).map_err(|e| errors::dataset(e.into()));
    }
    let (v, f) = match obj.cast::<PyTuple>() {
        Ok(t) if t.len() == 2 => (
            crate::convert::points(&t.get_item(0)?, "template", None)?,
            crate::convert::faces(&t.get_item(1)?, "template")?,
        ),
        _ => (
            crate::convert::points(obj, "template", None)?,
            crate::convert::faces(obj, "template")?,
        ),
    };
    let topo = crate::meshes::topology(v.len(), f, "template")?;
    qcshape::mesh::Shape::new(topo, v).map_err(|e| PyValueError::new_err(format!("template: {e}")))
}

/// ``Dataset.load(path, template=...)``: the data set's files ([`Dataset::files`]) fitted with
/// the template by the library ([`qcshape::fit::data::fit_dataset`], tracked).
fn fitted(
    py: Python<'_>,
    path: &std::path::Path,
    template: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyDataset> {
    let Some(template) = template else {
        return Err(PyValueError::new_err("template: missing"));
    };
    let template = template_shape(template)?;
    let (data, fits) = py
        .detach(|| -> Result<_, String> {
            let files = Dataset::files(path).map_err(|e| e.to_string())?;
            qcshape::fit::data::fit_dataset(
                &template,
                &files,
                &qcshape::fit::FitOptions::default(),
                true,
                |_, _| {},
            )
            .map_err(|e| e.to_string())
        })
        .map_err(PyValueError::new_err)?;
    let rows = PyList::empty(py);
    let columns = qcshape::fit::data::QUALITY_COLUMNS;
    for (d, fitted) in data.deformations.iter().zip(&fits) {
        for (k, (f, src)) in fitted.iter().zip(&d.paths).enumerate() {
            let row = PyDict::new(py);
            let q = &f.quality;
            row.set_item(columns[0], &d.name)?;
            row.set_item(columns[1], k)?;
            row.set_item(columns[2], src.display().to_string())?;
            for (c, v) in [
                (columns[3], q.mean),
                (columns[4], q.p95),
                (columns[5], q.hausdorff),
                (columns[6], q.median_vertex),
                (columns[7], q.min_angle),
            ] {
                row.set_item(c, v)?;
            }
            row.set_item(columns[8], q.flipped)?;
            for (c, v) in [
                (columns[9], q.strain_rms),
                (columns[10], q.strain_max),
                (columns[11], q.edge_length),
                (columns[12], f.motion.scale),
            ] {
                row.set_item(c, v)?;
            }
            row.set_item(columns[13], q.poor)?;
            row.set_item(columns[14], q.template_min_angle)?;
            row.set_item(columns[15], q.new_slivers)?;
            row.set_item(columns[16], q.slide)?;
            if q.poor {
                crate::warn::warn(
                    py,
                    &format!(
                        "poor fit of {} (deformation {}, pose {k}): {}",
                        src.display(),
                        d.name,
                        q.problems().join(", ")
                    ),
                )?;
            }
            rows.append(row)?;
        }
    }
    Ok(PyDataset {
        defs: Arc::new(data.deformations),
        fit_quality: Some(rows.unbind()),
    })
}
