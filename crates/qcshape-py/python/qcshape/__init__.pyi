"""Type stubs of qcshape (the Rust extension qcshape._qcshape). Shapes in the comments:
nV vertices, nF faces, K + 1 poses, n items."""

from os import PathLike
from typing import Any, Callable, Dict, List, Literal, Optional, Sequence, Tuple, Union, overload

from typing_extensions import TypedDict, Unpack

import numpy as _np
import numpy.typing as _npt

# Wherever positions or faces go, a trimesh.Trimesh, pyvista.PolyData or meshio.Mesh may go too
# (typed Any: none of them is a dependency); a list of meshes is a pose sequence.
_Mesh = Any
_Points = Union[_npt.ArrayLike, _Mesh]  # (nV, 3) float
_Faces = Union[_npt.ArrayLike, _Mesh]  # (nF, 3) int, the flat [3, a, b, c, ...] layout, or a mesh
_Poses = Union[_npt.ArrayLike, Sequence[_Mesh]]  # (K, nV, 3) float
_Matrix = _npt.ArrayLike  # (n, n) float
_Path = Union[str, "PathLike[str]"]
_F64 = _npt.NDArray[_np.float64]
_I64 = _npt.NDArray[_np.int64]
# progress=: None (auto: a tqdm bar on a terminal or in Jupyter, plain lines at most every 10 s in
# a log), True (as None, plus each stage's last count in a log), False (nothing) or a callable
# (stage, done, total), stage "interpolating" | "transferring" | "pairs".
_Progress = Union[None, bool, Callable[[str, int, int], object]]

__version__: str

# The names of the metrics (`metric=`), in the order of the library's registry
# (qcshape::metric::METRICS, which every list of metrics reads).
METRICS: Tuple[str, ...]
# The names of the terms the metrics weight (qcshape::metric::TERMS).
TERMS: Tuple[str, ...]

class _PipelineOptions(TypedDict, total=False):
    """The keyword options of the data-set functions (`similarity_matrix`, `motion_maps`,
    `pair_contributions`; the command line's flags of the same names, `lam` for `--lambda`)."""

    # BEGIN settings: _PipelineOptions (generated from qcshape::settings: cargo run -p qcshape-cli --example gen-settings)
    metric: Optional[str]  # l2 | rigid | isometric | conformal | quasi-conformal; default isometric
    form: Optional[str]  # quadratic | paper; default quadratic
    weights: Optional[str]  # endpoints | segment; default endpoints
    lam: Optional[float]  # default 0.01
    metric_scale: Optional[str]  # invariant | calibrated | raw; default invariant
    stretch: Optional[float]  # default 0.1
    bending: Optional[float]  # default 0.0001
    qc_weights: Optional[str]  # rms | raw; default rms
    qc_floor: Optional[float]  # default 0.5
    qc_smooth: Optional[int]  # default 0
    l2_areas: Optional[str]  # frozen | pose; default frozen
    steps: Optional[int]  # default 8
    solver: Optional[str]  # preconditioned | hessian-kronecker | pose-kronecker; default preconditioned
    gauge: Optional[str]  # linear | free; default linear
    tolerance: Optional[float]  # default 0.000001
    energy_tolerance: Optional[float]  # default 0.000000000001
    length_tolerance: Optional[float]  # default 0.00000001
    insert: Optional[int]  # default 0
    levels: Optional[int]  # default 1
    transport: Optional[str]  # euclidean | parallel | schild; default euclidean
    align: Optional[str]  # rigid | similarity | none; default rigid
    smooth: Optional[int]
    smooth_length: Optional[float]  # default 0.18
    base: Optional[Union[int, str]]
    approx: Optional[str]  # exact | straight | tangent; default exact
    # END settings
    threads: Optional[int]
    progress: _Progress

class QcshapeWarning(UserWarning):
    """qcshape's warnings (regularizer share above one half, solver iteration limit, lam = 0 with a
    conformal metric, unconverged pairs), issued through the warnings module."""

@overload
def read_mesh(path: _Path, point_data: Literal[False] = False) -> Tuple[_F64, _I64]: ...
@overload
def read_mesh(path: _Path, point_data: Literal[True]) -> Tuple[_F64, _I64, Dict[str, _F64]]:
    """(V (nV, 3) float64, F (nF, 3) int64) of a .obj/.ply/.off/.stl/.vtk/.vtp/.vtu file;
    with point_data=True also a dict of its named per-vertex arrays, each (nV,) or (nV, k)
    float64. ValueError for an invalid file or one with no faces."""
@overload
def read_mesh(path: _Path, point_data: bool) -> Union[Tuple[_F64, _I64], Tuple[_F64, _I64, Dict[str, _F64]]]: ...

def write_mesh(
    path: _Path,
    vertices: _Points,
    faces: Optional[_Faces] = None,
    point_data: Optional[Dict[str, _npt.ArrayLike]] = None,
) -> None:
    """Writes V (nV, 3), F (nF, 3) and named per-vertex fields, each (nV,) or (nV, 3) (.ply, .vtk, .vtp, .vtu);
    write_mesh(path, mesh) takes a trimesh / pyvista / meshio mesh's own faces."""

def as_arrays(mesh: Any) -> Tuple[_F64, _I64]:
    """(V (nV, 3) float64, F (nF, 3) int64) of a trimesh.Trimesh, pyvista.PolyData (triangles only),
    meshio.Mesh ("triangle" cells) or (V, F) pair."""

def to_trimesh(vertices: _npt.ArrayLike, faces: _npt.ArrayLike) -> Any:
    """A trimesh.Trimesh (process=False); a list of them for poses (K, nV, 3)."""

def to_pyvista(vertices: _npt.ArrayLike, faces: _npt.ArrayLike) -> Any:
    """A pyvista.PolyData; a list of them for poses (K, nV, 3)."""

def to_meshio(vertices: _npt.ArrayLike, faces: _npt.ArrayLike) -> Any:
    """A meshio.Mesh with one "triangle" cell block; a list of them for poses (K, nV, 3)."""

def fit(
    template_vertices: _Points,
    template_faces: _Faces,
    target_vertices: _Points,
    target_faces: Optional[_Faces] = None,
    *,
    alignment: Literal["similarity", "rigid", "none"] = "similarity",
    prior: Literal["smooth", "affine", "arap", "asap"] = "smooth",
    stages: int = 6,
    max_samples: int = 1000,
    global_degree: int = 0,
) -> Tuple[_F64, _F64, Dict[str, Union[float, int, bool]]]:
    """The template (nV, 3) + (nF, 3) fitted to a target of any triangulation (or a point cloud:
    target_faces None and plain target vertices): (V (nV, 3) on the template's faces in the
    target's frame, residual (nV,) distance to the target, quality dict: mean, p95, hausdorff,
    median_vertex in template edge lengths, min_angle, flipped, strain_rms, strain_max,
    edge_length, scale, iterations, poor)."""

def icosphere(level: int = 1) -> Tuple[_F64, _I64]:
    """The unit icosphere, 10 * 4**level + 2 vertices."""

class Geodesic:
    @property
    def path(self) -> _F64:
        """(steps + 1, nV, 3) poses, input units."""
    @property
    def length(self) -> float: ...
    @property
    def energy(self) -> float: ...
    @property
    def initial_energy(self) -> float: ...
    @property
    def geometric_energy(self) -> float:
        """The part of `energy` carried by the metric's geometric term."""
    @property
    def regularizer_energy(self) -> float:
        """The part of `energy` carried by the L2 regularizer (0 without one)."""
    @property
    def bending_energy(self) -> float:
        """The part of `geometric_energy` carried by the bending term (0 without one)."""
    @property
    def bending_share(self) -> float:
        """bending_energy / energy, in [0, 1] (0 without a bending term)."""
    @property
    def regularizer_share(self) -> float:
        """regularizer_energy / energy in [0, 1]; above 0.5 the distance measures L2 more
        than the metric's geometry."""
    @property
    def segment_lengths(self) -> List[float]: ...
    @property
    def iterations(self) -> int: ...
    @property
    def converged(self) -> bool: ...
    @property
    def stop(self) -> str: ...
    @property
    def gradient_norm(self) -> float: ...
    @property
    def scale(self) -> float: ...
    @property
    def seconds(self) -> float: ...

class ShapeSpace:
    def __init__(
        self,
        faces: _Faces,
        metric: Optional[str] = None,
        *,
        # BEGIN settings: ShapeSpace (generated from qcshape::settings: cargo run -p qcshape-cli --example gen-settings)
        form: Optional[str] = None,  # quadratic | paper; default quadratic
        weights: Optional[str] = None,  # endpoints | segment; default endpoints
        lam: Optional[float] = None,  # default 0.01
        metric_scale: Optional[str] = None,  # invariant | calibrated | raw; default invariant
        stretch: Optional[float] = None,  # default 0.1
        bending: Optional[float] = None,  # default 0.0001
        qc_weights: Optional[str] = None,  # rms | raw; default rms
        qc_floor: Optional[float] = None,  # default 0.5
        qc_smooth: Optional[int] = None,  # default 0
        l2_areas: Optional[str] = None,  # frozen | pose; default frozen
        steps: Optional[int] = None,  # default 8
        solver: Optional[str] = None,  # preconditioned | hessian-kronecker | pose-kronecker; default preconditioned
        gauge: Optional[str] = None,  # linear | free; default linear
        tolerance: Optional[float] = None,  # default 0.000001
        energy_tolerance: Optional[float] = None,  # default 0.000000000001
        length_tolerance: Optional[float] = None,  # default 0.00000001
        # END settings
        reference: Optional[_Points] = None,
        scale: Optional[float] = None,
        n_vertices: Optional[int] = None,
    ) -> None: ...
    @property
    def n_vertices(self) -> int: ...
    @property
    def faces(self) -> _I64: ...
    @property
    def metric(self) -> str: ...
    @property
    def steps(self) -> int: ...
    def squared_norm(self, base: _Points, v: _Points) -> float: ...
    def inner(
        self, base: _Points, u: _Points, v: _Points, ends: Optional[Tuple[_Points, _Points]] = None
    ) -> float: ...
    def geodesic(
        self, a: _Points, b: _Points, steps: Optional[int] = None, progress: _Progress = None
    ) -> Geodesic: ...
    def dist(self, a: _Points, b: _Points, steps: Optional[int] = None, progress: _Progress = None) -> float: ...
    def log(self, base: _Points, p: _Points, steps: Optional[int] = None) -> Tuple[_F64, float]:
        """(log (nV, 3), dis(base, p))."""
    def transport(self, curve: _Poses, v: _Points, method: Optional[str] = None) -> _F64:
        """(nV, 3) vector at curve[-1]."""
    def karcher_mean(
        self,
        poses: _Poses,
        init: Optional[_Points] = None,
        max_iterations: Optional[int] = None,
        tolerance: Optional[float] = None,
    ) -> _F64: ...
    def interpolate(
        self,
        poses: _Poses,
        insert: Optional[int] = None,
        levels: Optional[int] = None,
        progress: _Progress = None,
    ) -> _F64:
        """(K * (insert + 1) + 1, nV, 3)."""
    def transfer(
        self, poses: _Poses, base: _Points, method: Optional[str] = None, progress: _Progress = None
    ) -> _F64:
        """(K + 1, nV, 3), starting at base."""
    def pairwise_distances(self, poses: _Poses, threads: Optional[int] = None, progress: _Progress = None) -> _F64:
        """(n, n) dis(P_i, P_j)."""
    def similarity(
        self, deformations: Sequence[_Poses], threads: Optional[int] = None, progress: _Progress = None
    ) -> _F64:
        """(n, n) eq. 13 of deformations at one common base."""

class Dataset:
    def __init__(
        self,
        poses: Sequence[_Poses],
        faces: Optional[_Faces] = None,
        names: Optional[Sequence[str]] = None,
        labels: Optional[Sequence[Optional[str]]] = None,
    ) -> None: ...
    @staticmethod
    def from_manifest(path: _Path, template: Optional[Any] = None) -> "Dataset": ...
    @staticmethod
    def load(path: _Path, template: Optional[Any] = None) -> "Dataset": ...
    @property
    def fit_quality(self) -> Optional[List[Dict[str, Any]]]: ...
    @staticmethod
    def synthetic(
        level: int = 1, poses: Optional[int] = None, seed: Optional[int] = None, jitter: Optional[float] = None
    ) -> "Dataset": ...
    def __len__(self) -> int: ...
    @overload
    def __getitem__(self, i: slice) -> "Dataset": ...
    @overload
    def __getitem__(self, i: int) -> _F64:
        """(K, nV, 3) poses of deformation i."""
    @property
    def names(self) -> List[str]: ...
    @property
    def labels(self) -> List[Optional[str]]: ...
    @property
    def faces(self) -> _I64: ...
    @property
    def n_vertices(self) -> int: ...

class SimilarityDetails(TypedDict):
    """The per-pair details of `similarity_matrix(..., return_details=True)`, over the
    P = n (n - 1) / 2 pairs i < j in row order and the K poses."""

    pairs: _I64  # (P, 2): (i, j)
    distance: _F64  # (P, K): dis(M_k, N_k)
    geometric_energy: _F64  # (P, K): the metric's own part of each pose path's energy
    regularizer_energy: _F64  # (P, K): the L2 regularizer's part (NaN with approx="tangent")
    regularizer_share: _F64  # (P,): regularizer / total energy of each pair, in [0, 1]

@overload
def similarity_matrix(
    dataset: Dataset,
    *,
    return_details: Literal[False] = False,
    journal: Optional[_Path] = None,
    resume: bool = False,
    **options: Unpack[_PipelineOptions],
) -> _F64:
    """(n, n) similarity matrix (eq. 13), equal to `qcshape similarity`'s CSV. journal: a file
    that records every finished pair; after an interruption the same call with resume=True
    computes only the missing pairs (the journal is removed once the matrix is returned)."""

@overload
def similarity_matrix(
    dataset: Dataset,
    *,
    return_details: Literal[True],
    journal: Optional[_Path] = None,
    resume: bool = False,
    **options: Unpack[_PipelineOptions],
) -> Tuple[_F64, SimilarityDetails]:
    """(D, details): the matrix and the per-pair, per-pose distances and energy split
    (`SimilarityDetails`)."""

def settings() -> Dict[str, Dict[str, Optional[str]]]:
    """Every setting of a similarity run from the library's table: {keyword: {"flag", "group",
    "default"}} (defaults as text, as `qcshape --help` shows them)."""

def motion_maps(
    dataset: Dataset,
    *,
    measure: str = "normal",
    scale: str = "absolute",
    **options: Unpack[_PipelineOptions],
) -> _F64:
    """(n, nV) per-vertex motion of every deformation after the similarity preparation.
    measure: "normal" (normal excursion times vertex area) or "metric" (per-vertex metric length);
    scale: "absolute" or "share" (each row divided by its sum)."""

def pair_contributions(
    dataset: Dataset,
    a: Union[int, str],
    b: Union[int, str],
    **options: Unpack[_PipelineOptions],
) -> _F64:
    """(nV,) per-vertex split of similarity(a, b) (index or name); sums to the matrix entry
    of `similarity_matrix` with the same options (normalized length units)."""

class KMedoids:
    """PAM k-medoids on a precomputed (n, n) distance matrix (scikit-learn estimator API)."""
    n_clusters: int
    metric: str
    n_init: int
    random_state: Union[None, int, _np.random.RandomState, _np.random.Generator]
    max_iter: int
    labels_: _I64
    medoid_indices_: _I64
    inertia_: float
    n_iter_: int
    def __init__(
        self,
        n_clusters: int = 8,
        *,
        metric: str = "precomputed",
        n_init: int = 10,
        random_state: Union[None, int, _np.random.RandomState, _np.random.Generator] = None,
        max_iter: int = 100,
    ) -> None: ...
    def fit(self, X: _Matrix, y: Any = None) -> "KMedoids": ...
    def fit_predict(self, X: _Matrix, y: Any = None) -> _I64: ...
    def predict(self, X: _npt.ArrayLike) -> _I64:
        """X (m, n): distances of new items to the fitted ones -> nearest medoid (m,)."""
    def get_params(self, deep: bool = True) -> Dict[str, Any]: ...
    def set_params(self, **params: Any) -> "KMedoids": ...

class KMeans:
    """Kernel k-means on a distance matrix, or intrinsic k-means (eq. 14) on a Dataset."""
    n_clusters: int
    metric: str
    n_init: int
    random_state: Union[None, int, _np.random.RandomState, _np.random.Generator]
    max_iter: int
    labels_: _I64
    inertia_: float
    n_iter_: int
    kernel_labels_: Optional[_I64]
    distances_: Optional[_F64]
    def __init__(
        self,
        n_clusters: int = 8,
        *,
        metric: str = "precomputed",
        n_init: int = 10,
        random_state: Union[None, int, _np.random.RandomState, _np.random.Generator] = None,
        max_iter: int = 100,
    ) -> None: ...
    def fit(self, X: Union[_Matrix, Dataset], y: Any = None, **options: Any) -> "KMeans": ...
    def fit_predict(self, X: Union[_Matrix, Dataset], y: Any = None, **options: Any) -> _I64: ...
    def predict(self, X: _npt.ArrayLike) -> _I64:
        """X (m, n): distances of new items to the fitted ones -> nearest cluster (m,)."""
    def get_params(self, deep: bool = True) -> Dict[str, Any]: ...
    def set_params(self, **params: Any) -> "KMeans": ...

def mds(d: _Matrix, n_components: Optional[int] = None, random_state: Optional[int] = None) -> Tuple[_F64, float]:
    """(X (n, n_components), raw stress (eq. 16))."""

# Labels: a list (e.g. Dataset.labels, None for unlabelled) or an array (e.g. an estimator's labels_).
_Labels = Union[Sequence[Any], _npt.ArrayLike]

def scores(true_labels: _Labels, labels: _Labels) -> Dict[str, float]:
    """{"sensitivity", "specificity" (eq. 15), "accuracy", "ari"}."""
