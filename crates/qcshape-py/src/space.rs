//! `qcshape.ShapeSpace` and `qcshape.Geodesic`: the library's [`ShapeSpace`] for numpy arrays.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use qcshape::cluster::KarcherOptions;
use qcshape::geodesic::{Geodesic, InterpolationOptions, Normalization};
use qcshape::mesh::Topology;
use qcshape::settings;
use qcshape::similarity::Stage;
use qcshape::space::{ShapeSpace, SpaceError};
use qcshape::transport::Transport;

use crate::convert::{
    faces, matrix_out, opt_count, opt_setting, points, points_out, sequence, sequence_out, AnyInt,
};
use crate::errors;
use crate::options::{transport, MetricKw, SolverKw};
use crate::run::{detached, detached_with, Progress, Watch};

/// A discrete geodesic (eq. 12) between two shapes.
///
/// Attributes: ``path`` (steps + 1, nV, 3) float64 poses in the input's units (ends bit-exact),
/// ``length`` = dis(A, B) and ``energy`` (eq. 12) in the metric's units (dimensionless on the
/// default invariant scale; the solver's coordinates are the input's times ``scale``), ``initial_energy`` (the straight line's), ``geometric_energy`` and
/// ``regularizer_energy`` (the energy's split into the metric's own term and the L2
/// regularizer; they sum to ``energy``), ``regularizer_share`` (the regularizer's part, in
/// [0, 1]: above 0.5 the distance measures L2 displacement more than the metric's geometry),
/// ``segment_lengths`` (steps,),
/// ``iterations``, ``converged``, ``stop`` (why the solver stopped), ``gradient_norm``,
/// ``scale``, ``seconds``.
#[pyclass(name = "Geodesic", module = "qcshape", frozen)]
pub struct PyGeodesic {
    g: Geodesic,
}

/// The `#[pymethods]` block of [`PyGeodesic`]: one getter per `name: Type = |g| value;` line
/// (its doc comment is the attribute's docstring), then the methods written out.
macro_rules! geodesic_methods {
    ($($(#[$doc:meta])* $name:ident: $ty:ty = |$g:ident| $value:expr;)* @methods $($methods:tt)*) => {
        #[pymethods]
        impl PyGeodesic {
            $(
                $(#[$doc])*
                #[getter]
                fn $name(&self) -> $ty {
                    let $g = &self.g;
                    $value
                }
            )*
            $($methods)*
        }
    };
}

geodesic_methods! {
    /// dis(A, B): the path's length (the metric's units).
    length: f64 = |g| g.length;
    /// Path energy (eq. 12) at the solution (the metric's units).
    energy: f64 = |g| g.energy;
    /// Path energy of the straight line (the start).
    initial_energy: f64 = |g| g.initial_energy;
    /// The part of ``energy`` carried by the metric's geometric term (the metric's units).
    geometric_energy: f64 = |g| g.geometric_energy;
    /// The part of ``energy`` carried by the L2 regularizer (0 without one).
    regularizer_energy: f64 = |g| g.regularizer_energy;
    /// regularizer_energy / (geometric_energy + regularizer_energy), in [0, 1] (0 for a path
    /// of zero energy).
    regularizer_share: f64 = |g| g.regularizer_share();
    /// The part of ``geometric_energy`` carried by the bending term (``bending`` times the
    /// change of the dihedral angles along the path; 0 without one).
    bending_energy: f64 = |g| g.bending_energy;
    /// bending_energy / energy, in [0, 1] (0 without a bending term).
    bending_share: f64 = |g| g.bending_share();
    /// Length of each segment, (steps,) list.
    segment_lengths: Vec<f64> = |g| g.segment_lengths.clone();
    /// Solver iterations.
    iterations: usize = |g| g.iterations;
    /// Whether the solver converged.
    converged: bool = |g| g.converged;
    /// Why the solver stopped (e.g. "GradientTolerance").
    stop: String = |g| format!("{:?}", g.stop);
    /// Norm of the energy gradient at the solution.
    gradient_norm: f64 = |g| g.gradient_norm;
    /// The factor coordinates were multiplied by before solving.
    scale: f64 = |g| g.scale;
    /// Wall-clock seconds in the solver.
    seconds: f64 = |g| g.seconds;
    @methods
    /// The poses P_0 .. P_N, (steps + 1, nV, 3) float64, input units.
    #[getter]
    fn path<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        sequence_out(py, &self.g.poses)
    }
    /// Pickle support (Dask, multiprocessing): every field, rebuilt bit for bit by
    /// ``qcshape._pickle.geodesic``.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let g = &self.g;
        let state = PyDict::new(py);
        state.set_item("path", sequence_out(py, &g.poses)?)?;
        state.set_item("energy", g.energy)?;
        state.set_item("initial_energy", g.initial_energy)?;
        state.set_item("geometric_energy", g.geometric_energy)?;
        state.set_item("regularizer_energy", g.regularizer_energy)?;
        state.set_item("bending_energy", g.bending_energy)?;
        state.set_item("length", g.length)?;
        state.set_item("segment_lengths", g.segment_lengths.clone())?;
        state.set_item("iterations", g.iterations)?;
        state.set_item("converged", g.converged)?;
        let (stop, message) = match &g.stop {
            qcshape::geodesic::StopReason::Other(m) => ("Other".to_string(), Some(m.clone())),
            s => (format!("{s:?}"), None),
        };
        state.set_item("stop", stop)?;
        state.set_item("stop_message", message)?;
        state.set_item("gradient_norm", g.gradient_norm)?;
        state.set_item("scale", g.scale)?;
        state.set_item("seconds", g.seconds)?;
        let rebuild = py.import("qcshape._pickle")?.getattr("geodesic")?;
        PyTuple::new(py, [rebuild, PyTuple::new(py, [state])?.into_any()])
    }

    /// The inverse of ``__reduce__`` (called by ``qcshape._pickle.geodesic``).
    #[staticmethod]
    fn _from_state<'py>(state: &Bound<'py, PyDict>) -> PyResult<Self> {
        use qcshape::geodesic::StopReason as S;
        let get = |k: &str| -> PyResult<Bound<'py, PyAny>> {
            state
                .get_item(k)?
                .ok_or_else(|| PyValueError::new_err(format!("Geodesic state: missing {k}")))
        };
        let stop: String = get("stop")?.extract()?;
        let stop = match stop.as_str() {
            "NothingToOptimize" => S::NothingToOptimize,
            "GradientTolerance" => S::GradientTolerance,
            "EnergyTolerance" => S::EnergyTolerance,
            "LengthTolerance" => S::LengthTolerance,
            "TargetEnergy" => S::TargetEnergy,
            "MaxIterations" => S::MaxIterations,
            "NoProgress" => S::NoProgress,
            _ => S::Other(get("stop_message")?.extract::<Option<String>>()?.unwrap_or(stop)),
        };
        Ok(PyGeodesic {
            g: Geodesic {
                poses: sequence(&get("path")?, "path", None, 1)?,
                energy: get("energy")?.extract()?,
                initial_energy: get("initial_energy")?.extract()?,
                geometric_energy: get("geometric_energy")?.extract()?,
                regularizer_energy: get("regularizer_energy")?.extract()?,
                bending_energy: get("bending_energy")?.extract()?,
                length: get("length")?.extract()?,
                segment_lengths: get("segment_lengths")?.extract()?,
                iterations: get("iterations")?.extract()?,
                converged: get("converged")?.extract()?,
                stop,
                gradient_norm: get("gradient_norm")?.extract()?,
                scale: get("scale")?.extract()?,
                seconds: get("seconds")?.extract()?,
            },
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "Geodesic(steps={}, length={}, energy={}, iterations={}, converged={})",
            self.g.poses.len() - 1,
            qcshape::numfmt::significant(self.g.length, 7),
            qcshape::numfmt::significant(self.g.energy, 7),
            self.g.iterations,
            // Python's spelling of the bool, as the attribute prints.
            if self.g.converged { "True" } else { "False" }
        )
    }
}

/// The shape space of one triangle connectivity with one metric (paper section 2).
///
/// ``ShapeSpace(F, metric="isometric", lam=0.01)``: F is the (nF, 3) integer face array
/// shared by every shape; shapes are (nV, 3) float64 arrays, tangent vectors (nV, 3)
/// displacements. Keywords (None keeps the library default, the CLI's): ``metric`` one of
/// ``qcshape.METRICS`` (default isometric); ``form`` quadratic | paper; ``weights``
/// endpoints | segment; ``lam`` L2 weight lambda (eq. 11, default 0.01); ``metric_scale``
/// invariant (default: every term a relative rate weighted by its face's area share,
/// scale-invariant, G_{sM}(sX) = G_M(X), so geodesics do not shrink the shape;
/// docs/method.md) | calibrated (every term over its own resolution-consistent scale,
/// docs/geometry.md: the 2026-12-04 releases') | raw (the paper's sums in mean-edge units,
/// the releases before, with ``lam=0.1``); ``stretch`` weight of the conformal and
/// quasi-conformal metrics' stretch term on the invariant scale (the relative rate of change of
/// each face's area; 0.1, 0 = none); ``qc_weights`` rms (default) | raw, ``qc_floor`` (0.5),
/// ``qc_smooth`` (0): the quasi-conformal weights; ``l2_areas`` frozen | pose;
/// ``steps`` N segments of every geodesic (8); ``solver`` preconditioned | hessian-kronecker |
/// pose-kronecker; ``gauge`` linear (the interior poses keep the linear interpolation's rigid
/// placement; the default) | free; ``tolerance`` (1e-6) and
/// ``energy_tolerance`` (1e-12); ``length_tolerance`` (1e-8: distances, i.e.
/// ``pairwise_distances`` and ``similarity``, stop once the length has settled; 0 = off);
/// ``n_vertices`` (default: a mesh object's vertex count, else the reference's, else the
/// largest face index + 1). ``faces`` may be a trimesh, pyvista or meshio mesh.
///
/// Coordinates are normalized before solving, as ``qcshape geodesic`` does: divided by the mean
/// edge length of the call's reference shapes (both ends for ``geodesic``, ``dist`` and
/// ``log``, so ``dist(a, b) == dist(b, a)``; the first shape or the base otherwise), and the
/// metric is calibrated on them; ``reference=V0`` fixes both to V0's for every call,
/// ``scale=f`` multiplies by f. Lengths and energies are in the metric's units, poses and
/// vectors in the input's units.
///
/// Methods release the GIL and stop at Ctrl-C; the object is immutable and may be shared
/// between threads.
#[pyclass(name = "ShapeSpace", module = "qcshape", frozen)]
pub struct PyShapeSpace {
    space: ShapeSpace,
    /// The constructor's arguments (faces first, then the keywords given), for pickling.
    init: Py<PyTuple>,
}

impl PyShapeSpace {
    fn nv(&self) -> usize {
        self.space.topology().n_vertices()
    }

    /// Whether the vertex count came from the faces alone (no n_vertices, mesh or reference).
    fn inferred_nv(&self, py: Python<'_>) -> bool {
        let kwargs = self.init.bind(py).get_item(1);
        !kwargs.is_ok_and(|k| {
            k.contains("n_vertices").unwrap_or(false) || k.contains("reference").unwrap_or(false)
        })
    }

    /// Positions with `rows` vertices for argument `name`: fewer than a vertex count inferred
    /// from faces that leave vertices unused is a face index past the positions (named), any
    /// other mismatch a shape error.
    fn check_rows(&self, py: Python<'_>, name: &str, rows: usize, poses: Option<usize>) -> PyResult<()> {
        let nv = self.nv();
        if rows == nv {
            return Ok(());
        }
        // Faces that skip vertex numbers (an index past the mesh, 1-based faces) are to blame, not
        // positions that are merely short.
        if rows < nv && self.inferred_nv(py) && !self.space.topology().isolated_vertices().is_empty() {
            return Err(crate::meshes::index_error(
                self.space.topology().faces(),
                rows,
                name,
            ));
        }
        // More rows than a vertex count taken from the faces: the extra vertices are in no face.
        let hint = if rows > nv && self.inferred_nv(py) {
            format!(
                " (the space took its {nv} vertices from the faces' largest index, {}; vertices \
                 {nv}..{} of {name} are in no face: give ShapeSpace(F, n_vertices={rows}), or pass \
                 the mesh itself, to keep them)",
                nv - 1,
                rows - 1
            )
        } else {
            String::new()
        };
        Err(PyValueError::new_err(match poses {
            None => format!("{name}: expected an array of shape ({nv}, 3), got ({rows}, 3){hint}"),
            Some(k) => {
                format!(
                    "{name}: expected an array of shape (K, {nv}, 3) with K >= 1, got ({k}, {rows}, 3){hint}"
                )
            }
        }))
    }

    /// `obj` as a shape of this space (nV, 3).
    /// A mesh object's faces are checked against the space's connectivity first
    /// ([`crate::connectivity::on_connectivity`]).
    fn points(&self, obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<[f64; 3]>> {
        let obj = &crate::connectivity::on_connectivity(obj, self.space.topology(), name, false)?;
        let p = points(obj, name, None)?;
        self.check_rows(obj.py(), name, p.len(), None)?;
        Ok(p)
    }

    /// `obj` as poses of this space (K, nV, 3), K >= 1.
    fn poses(&self, obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Vec<[f64; 3]>>> {
        let obj = &crate::connectivity::on_connectivity(obj, self.space.topology(), name, true)?;
        let p = sequence(obj, name, None, 1)?;
        self.check_rows(obj.py(), name, p[0].len(), Some(p.len()))?;
        Ok(p)
    }

    /// `call(space)` with the GIL released (Ctrl-C stops the wait) and a library error raised as
    /// Python's: the body of every method that runs one [`ShapeSpace`] call.
    fn call<T: Send>(
        py: Python<'_>,
        space: &ShapeSpace,
        call: impl FnOnce(&ShapeSpace) -> Result<T, SpaceError> + Send,
    ) -> PyResult<T> {
        detached(py, None, |_| call(space).map_err(errors::space))
    }

    /// This space with N = `steps` segments (the `steps=` keyword of a method; None keeps the
    /// space's).
    fn stepped(&self, steps: Option<AnyInt>) -> PyResult<ShapeSpace> {
        self.with_steps(opt_setting(&settings::STEPS, steps)?)
    }

    /// The progress display of one geodesic solve in `space` (its iterations out of the
    /// iteration limit on this mesh).
    fn one_solve(
        &self,
        py: Python<'_>,
        space: &ShapeSpace,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Progress> {
        let limit = space.geodesic_options().iteration_limit(self.nv());
        Progress::solving(py, progress, limit, 0)
    }

    fn with_steps(&self, steps: Option<usize>) -> PyResult<ShapeSpace> {
        match steps {
            None => Ok(self.space.clone()),
            Some(s) => {
                let g = SolverKw {
                    steps: Some(s),
                    ..Default::default()
                }
                .options()?;
                let g = qcshape::geodesic::GeodesicOptions {
                    steps: g.steps,
                    ..self.space.geodesic_options().clone()
                };
                self.space.clone().with_geodesic(g).map_err(errors::space)
            }
        }
    }
}

/// Sets `d[name] = v` when `v` is given (the keywords a ShapeSpace was made with).
fn put<'py, T: IntoPyObject<'py>>(d: &Bound<'py, PyDict>, name: &str, v: Option<T>) -> PyResult<()> {
    match v {
        Some(v) => d.set_item(name, v),
        None => Ok(()),
    }
}

#[pymethods]
impl PyShapeSpace {
    #[new]
    #[pyo3(signature = (faces, metric=None, *, form=None, weights=None, lam=None, l2_areas=None,
        metric_scale=None, stretch=None, bending=None, qc_weights=None, qc_floor=None, qc_smooth=None,
        steps=None, solver=None, gauge=None, tolerance=None, energy_tolerance=None,
        length_tolerance=None, reference=None, scale=None, n_vertices=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        faces: &Bound<'_, PyAny>,
        metric: Option<String>,
        form: Option<String>,
        weights: Option<String>,
        lam: Option<f64>,
        l2_areas: Option<String>,
        metric_scale: Option<String>,
        stretch: Option<f64>,
        bending: Option<f64>,
        qc_weights: Option<String>,
        qc_floor: Option<f64>,
        qc_smooth: Option<AnyInt>,
        steps: Option<AnyInt>,
        solver: Option<String>,
        gauge: Option<String>,
        tolerance: Option<f64>,
        energy_tolerance: Option<f64>,
        length_tolerance: Option<f64>,
        reference: Option<&Bound<'_, PyAny>>,
        scale: Option<f64>,
        n_vertices: Option<AnyInt>,
    ) -> PyResult<Self> {
        // A mesh object (trimesh, pyvista, meshio) gives its faces and its vertex count.
        let (faces, mesh_nv) = crate::meshes::faces_arg(faces)?;
        let faces = &faces;
        let n_vertices = n_vertices.or(mesh_nv.map(|n| AnyInt::new(n as i128)));
        let reference = reference.map(crate::meshes::points_arg).transpose()?;
        let reference = reference.as_ref();
        let qc_smooth = opt_setting(&settings::QC_SMOOTH, qc_smooth)?;
        let steps = opt_setting(&settings::STEPS, steps)?;
        let n_vertices = opt_count("n_vertices", n_vertices, 1, qcshape::limits::MAX_VERTICES)?;
        let py = faces.py();
        let kwargs = PyDict::new(py);
        // The keywords given, under their own names (the table's Python keywords).
        macro_rules! put_all {
            ($($name:ident),*) => { $(put(&kwargs, stringify!($name), $name.clone())?;)* };
        }
        put_all!(
            metric,
            form,
            weights,
            lam,
            l2_areas,
            metric_scale,
            stretch,
            bending,
            qc_weights,
            qc_floor,
            qc_smooth,
            steps,
            solver,
            gauge,
            tolerance,
            energy_tolerance,
            length_tolerance
        );
        put(&kwargs, "reference", reference)?;
        put(&kwargs, "scale", scale)?;
        put(&kwargs, "n_vertices", n_vertices)?;
        let init = PyTuple::new(py, [faces.clone(), kwargs.into_any()])?.unbind();
        let f = crate::convert::faces(faces, "faces")?;
        let max = f.iter().flatten().copied().max().unwrap_or(0) as usize;
        // The vertex count: given, the mesh object's, the reference's, else inferred from the faces.
        let ref_nv = reference
            .map(|r| points(r, "reference", None).map(|p| p.len()))
            .transpose()?;
        let nv = n_vertices.or(ref_nv).unwrap_or(max + 1);
        let topo = crate::meshes::topology(nv, f, "faces")?;
        let spec = MetricKw {
            metric,
            form,
            weights,
            lam,
            l2_areas,
            metric_scale,
            stretch,
            bending,
            qc_weights,
            qc_floor,
            qc_smooth,
        }
        .spec()?;
        let geo = SolverKw {
            steps,
            solver,
            gauge,
            tolerance,
            energy_tolerance,
            length_tolerance,
        }
        .options()?;
        let mut space = ShapeSpace::new(topo, spec, geo).map_err(errors::space)?;
        match (reference, scale) {
            (Some(_), Some(_)) => {
                return Err(PyValueError::new_err("give either reference or scale, not both"))
            }
            (Some(r), None) => {
                let r = points(r, "reference", Some(nv))?;
                space = space.normalized_to(&r).map_err(errors::space)?;
            }
            (None, Some(s)) => {
                if !(s > 0.0 && s.is_finite()) {
                    return Err(PyValueError::new_err(format!("scale: must be positive, got {s}")));
                }
                space = space.with_normalization(Normalization::Factor(s));
            }
            (None, None) => {}
        }
        Ok(PyShapeSpace { space, init })
    }

    /// Pickle support (e.g. ``client.map(space.dist, ...)`` on Dask): rebuilt from the
    /// constructor's arguments by ``qcshape._pickle.rebuild``.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let rebuild = py.import("qcshape._pickle")?.getattr("rebuild")?;
        let init = slf.get().init.bind(py);
        let args = PyTuple::new(
            py,
            [slf.get_type().into_any(), init.get_item(0)?, init.get_item(1)?],
        )?;
        PyTuple::new(py, [rebuild, args.into_any()])
    }

    /// Number of vertices nV of every shape.
    #[getter]
    fn n_vertices(&self) -> usize {
        self.nv()
    }

    /// The faces, (nF, 3) int64.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::faces_out(py, self.space.topology().faces())
    }

    /// The metric with its settings by option name, e.g. "isometric (bending 0.0001, lambda 0.01, l2-areas frozen,
    /// scale invariant)" ([`qcshape::metric::MetricSpec::label`]).
    #[getter]
    fn metric(&self) -> String {
        self.space.metric_label()
    }

    /// Segments N of every geodesic.
    #[getter]
    fn steps(&self) -> usize {
        self.space.geodesic_options().steps
    }

    fn __repr__(&self) -> String {
        format!(
            "ShapeSpace(n_vertices={}, n_faces={}, metric={:?}, steps={})",
            self.nv(),
            self.space.topology().n_faces(),
            self.space.metric_label(),
            self.steps()
        )
    }

    /// squared_norm(base, v) -> float: G_M(X) = <<X, X>>_M of the tangent vector v (nV, 3) at
    /// base = M (nV, 3), the first term of eq. 12 for the segment M -> M + X (the metric's
    /// units squared).
    fn squared_norm(&self, py: Python<'_>, base: &Bound<'_, PyAny>, v: &Bound<'_, PyAny>) -> PyResult<f64> {
        let (b, x) = (self.points(base, "base")?, self.points(v, "v")?);
        Self::call(py, &self.space, |s| s.squared_norm(&b, &x))
    }

    /// inner(base, u, v, ends=None) -> float: <<u, v>>_M at base = M (each (nV, 3)), the
    /// polarization of the metric's quadratic form, with the weights frozen by the curve
    /// ends = (start, end) (default: the constant curve at base). inner(M, v, v, (M, M + v))
    /// equals squared_norm(M, v) for the quadratic forms.
    #[pyo3(signature = (base, u, v, ends=None))]
    fn inner(
        &self,
        py: Python<'_>,
        base: &Bound<'_, PyAny>,
        u: &Bound<'_, PyAny>,
        v: &Bound<'_, PyAny>,
        ends: Option<(Bound<'_, PyAny>, Bound<'_, PyAny>)>,
    ) -> PyResult<f64> {
        let (b, x, y) = (
            self.points(base, "base")?,
            self.points(u, "u")?,
            self.points(v, "v")?,
        );
        let ends = match ends {
            None => None,
            Some((s, e)) => Some((self.points(&s, "ends[0]")?, self.points(&e, "ends[1]")?)),
        };
        let e = ends.as_ref().map(|(s, e)| (s.as_slice(), e.as_slice()));
        Self::call(py, &self.space, |s| s.inner(&b, &x, &y, e))
    }

    /// geodesic(a, b, steps=None, progress=None) -> Geodesic: the discrete geodesic (eq. 12)
    /// from shape a to shape b (each (nV, 3)) with N = steps segments (default the space's).
    /// ``g.path`` is (steps + 1, nV, 3). ``progress`` (as for similarity_matrix) shows the
    /// solver's iterations (stage "iterations", out of its iteration limit); Ctrl-C stops the
    /// solver between two iterations.
    #[pyo3(signature = (a, b, steps=None, progress=None))]
    fn geodesic(
        &self,
        py: Python<'_>,
        a: &Bound<'_, PyAny>,
        b: &Bound<'_, PyAny>,
        steps: Option<AnyInt>,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyGeodesic> {
        let (pa, pb) = (self.points(a, "a")?, self.points(b, "b")?);
        let space = self.stepped(steps)?;
        crate::warn::sizes(py, &space, &pa, &pb)?;
        let bar = self.one_solve(py, &space, progress)?;
        let g = solve(py, &space, None, Some(&bar), |s, _| s.geodesic(&pa, &pb))?;
        crate::warn::geodesic(py, &g, &space)?;
        Ok(PyGeodesic { g })
    }

    /// dist(a, b, steps=None, progress=None) -> float: dis(a, b), the length of the discrete
    /// geodesic (the metric's units); exactly 0 for identical shapes. ``progress`` as for
    /// ``geodesic``.
    #[pyo3(signature = (a, b, steps=None, progress=None))]
    fn dist(
        &self,
        py: Python<'_>,
        a: &Bound<'_, PyAny>,
        b: &Bound<'_, PyAny>,
        steps: Option<AnyInt>,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<f64> {
        let (pa, pb) = (self.points(a, "a")?, self.points(b, "b")?);
        let space = self.stepped(steps)?;
        crate::warn::sizes(py, &space, &pa, &pb)?;
        let bar = self.one_solve(py, &space, progress)?;
        // ShapeSpace::dist's solve, keeping the path for the warnings.
        let g = detached_with(py, None, Some(&bar), |w| {
            crate::warn::dist_path(&watched(&space, w)?, &pa, &pb)
        })?;
        if let Some(g) = &g {
            crate::warn::geodesic(py, g, &space)?;
        }
        Ok(g.map_or(0.0, |g| g.length))
    }

    /// log(base, p, steps=None) -> (ndarray (nV, 3), float): the discrete log map
    /// log_M(P) = N (P_1 - M) (input units), P_1 the first interior pose of the geodesic from
    /// base = M to p, and dis(M, P).
    #[pyo3(signature = (base, p, steps=None))]
    fn log<'py>(
        &self,
        py: Python<'py>,
        base: &Bound<'py, PyAny>,
        p: &Bound<'py, PyAny>,
        steps: Option<AnyInt>,
    ) -> PyResult<(Bound<'py, PyAny>, f64)> {
        let (m, q) = (self.points(base, "base")?, self.points(p, "p")?);
        let space = self.stepped(steps)?;
        let (log, d) = solve(py, &space, None, None, |s, _| s.log(&m, &q))?;
        Ok((points_out(py, &log)?, d))
    }

    /// transport(curve, v, method="parallel") -> ndarray (nV, 3): carries the tangent vector v
    /// (nV, 3) at curve[0] along the samples of curve (J + 1, nV, 3), e.g. a geodesic's path,
    /// to its last sample: "parallel" (the paper's discrete parallel transport, section
    /// 2.2.2), "schild" (Schild's ladder) or "euclidean" (v unchanged).
    #[pyo3(signature = (curve, v, method=None))]
    fn transport<'py>(
        &self,
        py: Python<'py>,
        curve: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        method: Option<&str>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let c = self.poses(curve, "curve")?;
        let x = self.points(v, "v")?;
        // Carrying a vector along a curve: parallel transport unless told otherwise.
        let m = transport(method, Transport::Parallel)?;
        let out = solve(py, &self.space, None, None, |s, _| s.transport(&c, &x, m))?;
        points_out(py, &out)
    }

    /// karcher_mean(poses, init=None, max_iterations=None, tolerance=None) -> ndarray (nV, 3):
    /// the intrinsic (Karcher) mean of poses (K, nV, 3), iterating mu <- mu + mean_k log_mu(P_k)
    /// from init (default poses[0]); a step that does not lower sum_k dis(mu, P_k)^2 is taken
    /// back and halved.
    #[pyo3(signature = (poses, init=None, max_iterations=None, tolerance=None))]
    fn karcher_mean<'py>(
        &self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        init: Option<&Bound<'py, PyAny>>,
        max_iterations: Option<AnyInt>,
        tolerance: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let p = self.poses(poses, "poses")?;
        let i = init.map(|x| self.points(x, "init")).transpose()?;
        let d = KarcherOptions::default();
        let opts = KarcherOptions {
            max_iterations: opt_count(
                "max_iterations",
                max_iterations,
                0,
                qcshape::limits::MAX_ITERATIONS,
            )?
            .unwrap_or(d.max_iterations),
            tolerance: tolerance.unwrap_or(d.tolerance),
            ..d
        };
        let m = solve(py, &self.space, None, None, |s, _| {
            s.karcher_mean(&p, i.as_deref(), &opts)
        })?;
        points_out(py, &m.mean)
    }

    /// interpolate(poses, insert=3, levels=1, progress=None) -> ndarray (K*(insert+1)+1, nV,
    /// 3): temporal interpolation (section 2.2.1) of the key poses (K + 1, nV, 3): ``insert``
    /// poses between each consecutive pair (key poses kept bit for bit), on ``levels`` spatial
    /// levels (1 = none); defaults as ``qcshape interpolate``. ``progress`` (as for
    /// similarity_matrix) shows the solver iterations (stage "iterations") and the pairs of key
    /// poses done ("pairs").
    #[pyo3(signature = (poses, insert=None, levels=None, progress=None))]
    fn interpolate<'py>(
        &self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        insert: Option<AnyInt>,
        levels: Option<AnyInt>,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let p = self.poses(poses, "poses")?;
        let d = InterpolationOptions::default();
        let levels = opt_setting(&settings::LEVELS, levels)?.unwrap_or(d.levels);
        if levels == 0 {
            return Err(PyValueError::new_err("levels: must be at least 1"));
        }
        let insert = opt_setting(&settings::INSERT, insert)?.unwrap_or(d.insert);
        let bar = Progress::solving(py, progress, 0, p.len().saturating_sub(1))?;
        let r = solve(py, &self.space, None, Some(&bar), |s, _| {
            s.interpolate(&p, insert, levels, &|| bar.tick(Stage::Similarity))
        })?;
        crate::warn::sequence(py, &r, &self.space)?;
        sequence_out(py, &r.poses)
    }

    /// transfer(poses, base, method="euclidean", progress=None) -> ndarray (K + 1, nV, 3):
    /// deformation transfer (section 2.2.2) of the deformation poses = M_0 .. M_K (K + 1, nV, 3)
    /// to the new base N_0 (nV, 3), returning N_0 .. N_K; method "euclidean" (N_k = N_0 + M_k -
    /// M_0, the default of every command, `qcshape::defaults::TRANSPORT`), "parallel" (the
    /// paper's) or "schild". ``progress`` shows the solver iterations of the geodesics
    /// "parallel" and "schild" solve (stage "iterations").
    #[pyo3(signature = (poses, base, method=None, progress=None))]
    fn transfer<'py>(
        &self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        base: &Bound<'py, PyAny>,
        method: Option<&str>,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let p = self.poses(poses, "poses")?;
        let b = self.points(base, "base")?;
        let m = transport(method, qcshape::defaults::TRANSPORT)?;
        let bar = Progress::solving(py, progress, 0, 0)?;
        let r = solve(py, &self.space, None, Some(&bar), |s, _| s.transfer(&p, &b, m))?;
        sequence_out(py, &r.poses)
    }

    /// pairwise_distances(poses, threads=None, progress=None) -> ndarray (n, n): dis(P_i, P_j)
    /// between the shapes poses (n, nV, 3), pairs in parallel, all normalized by the first
    /// shape; symmetric with a zero diagonal. Warns (QcshapeWarning) as similarity_matrix does.
    #[pyo3(signature = (poses, threads=None, progress=None))]
    fn pairwise_distances<'py>(
        &self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        threads: Option<AnyInt>,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let p = self.poses(poses, "poses")?;
        let singles: Vec<Vec<Vec<[f64; 3]>>> = p.into_iter().map(|x| vec![x]).collect();
        self.matrix(py, &singles, threads, progress)
    }

    /// similarity(deformations, threads=None, progress=None) -> ndarray (n, n): eq. 13,
    /// similarity(M, N) = sum_k dis(M_k, N_k), of deformations (n, K, nV, 3) already at one
    /// common base (e.g. from transfer), pairs in parallel. For raw deformations use
    /// qcshape.similarity_matrix, which interpolates and transfers first. Warns (QcshapeWarning)
    /// as similarity_matrix does.
    #[pyo3(signature = (deformations, threads=None, progress=None))]
    fn similarity<'py>(
        &self,
        py: Python<'py>,
        deformations: &Bound<'py, PyAny>,
        threads: Option<AnyInt>,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let list: Vec<Bound<'py, PyAny>> = deformations.try_iter()?.collect::<PyResult<_>>()?;
        let defs: Vec<Vec<Vec<[f64; 3]>>> = list
            .iter()
            .enumerate()
            .map(|(i, d)| self.poses(d, &format!("deformations[{i}]")))
            .collect::<PyResult<_>>()?;
        self.matrix(py, &defs, threads, progress)
    }
}

impl PyShapeSpace {
    /// The matrix of `pairwise_distances` and `similarity`: pairs in parallel with progress and
    /// Ctrl-C, then the warnings of `qcshape similarity` (regularizer share, unconverged pairs)
    /// from the pairs' details.
    fn matrix<'py>(
        &self,
        py: Python<'py>,
        defs: &[Vec<Vec<[f64; 3]>>],
        threads: Option<AnyInt>,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = defs.len();
        let bar = Progress::pairs(py, progress, n * n.saturating_sub(1) / 2)?;
        let threads = opt_count("threads", threads, 1, qcshape::limits::MAX_THREADS)?;
        let pairs = std::sync::Mutex::new(Vec::new());
        let d = solve(py, &self.space, threads, Some(&bar), |s, w| {
            s.similarity(defs, Some(w.flag()), &|p| {
                bar.tick(Stage::Similarity);
                if let Ok(mut v) = pairs.lock() {
                    v.push(p.clone());
                }
            })
        })?;
        let pairs = pairs.into_inner().unwrap_or_default();
        crate::warn::pairs(
            py,
            &pairs,
            true,
            self.space.spec(),
            self.space.geodesic_options().solver,
        )?;
        matrix_out(py, d, n, n)
    }
}

/// `space` with the monitor of `watch` on its geodesic options: every solver of the call
/// stops between two iterations on Ctrl-C and counts its iterations for the progress display.
pub fn watched(space: &ShapeSpace, watch: &crate::run::Watch) -> PyResult<ShapeSpace> {
    space
        .clone()
        .with_geodesic(watch.geodesic(space.geodesic_options()))
        .map_err(errors::space)
}

/// `call(space, watch)` on `space` [`watched`], on `threads` worker threads (None: all cores),
/// with the GIL released, `progress` shown and a library error raised as Python's: the body of
/// every method that solves geodesics (`watch` gives the stop flag of the pair loops).
pub fn solve<T: Send>(
    py: Python<'_>,
    space: &ShapeSpace,
    threads: Option<usize>,
    progress: Option<&Progress>,
    call: impl FnOnce(&ShapeSpace, &Watch) -> Result<T, SpaceError> + Send,
) -> PyResult<T> {
    detached_with(py, threads, progress, |w| {
        call(&watched(space, w)?, w).map_err(errors::space)
    })
}

/// Faces from an array argument (for the other modules).
pub fn topology_from(obj: &Bound<'_, PyAny>, name: &str, nv: usize) -> PyResult<std::sync::Arc<Topology>> {
    let f = faces(obj, name)?;
    crate::meshes::topology(nv, f, name)
}
