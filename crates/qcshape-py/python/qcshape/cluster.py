"""Clustering estimators with scikit-learn's conventions, over the Rust core's k-medoids and
k-means (kernel k-means on a distance matrix, eq. 14's intrinsic k-means on a Dataset).

Both follow the estimator API (``get_params`` / ``set_params``, so ``sklearn.base.clone``,
``Pipeline`` and grid searches work; ``fit`` returns ``self``; fitted attributes end in ``_``),
take ``random_state`` as None, an int, a ``numpy.random.RandomState`` or a ``numpy.random.Generator``,
and default to ``n_clusters=8`` as scikit-learn's ``KMeans`` does. Input is a precomputed
(n, n) distance matrix (``metric="precomputed"`` is the only metric); ``predict`` takes the
(m, n) distances of new items to the fitted ones.
"""

import inspect

import numpy as _np

from . import _qcshape

__all__ = ["KMeans", "KMedoids"]

# The library's default seed, used for random_state=None so that results are reproducible
# (every random choice of qcshape takes a seed).
_DEFAULT_SEED = 0


def _seed(random_state):
    """A 64-bit seed from None, an int, a RandomState or a Generator (scikit-learn's kinds)."""
    if random_state is None:
        return _DEFAULT_SEED
    if isinstance(random_state, (bool, _np.bool_)):
        raise ValueError(f"random_state: expected None, an int or a numpy random generator, got {random_state!r}")
    if isinstance(random_state, (int, _np.integer)):
        if random_state < 0:
            raise ValueError(f"random_state: must be >= 0, got {random_state}")
        return int(random_state) % 2**64
    if isinstance(random_state, _np.random.RandomState):
        return int(random_state.randint(0, 2**31 - 1))
    if isinstance(random_state, _np.random.Generator):
        return int(random_state.integers(0, 2**63 - 1))
    raise ValueError(f"random_state: expected None, an int or a numpy random generator, got {type(random_state).__name__}")


def _positive_int(value, name, minimum=1):
    if isinstance(value, (bool, _np.bool_)) or not isinstance(value, (int, _np.integer)):
        raise ValueError(f"{name}: expected an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name}: must be >= {minimum}, got {value}")
    return int(value)


def _distances(d, name, shape=None):
    d = _np.asarray(d, dtype=_np.float64)
    if d.ndim != 2 or (shape is not None and d.shape[1] != shape):
        want = f"(m, {shape})" if shape is not None else "(n, n)"
        raise ValueError(f"{name}: expected a {want} distance array, got shape {d.shape}")
    if not _np.all(_np.isfinite(d)) or _np.any(d < 0):
        raise ValueError(f"{name}: distances must be finite and >= 0")
    return d


class _Estimator:
    """get_params / set_params / repr from the constructor's keywords (scikit-learn's contract)."""

    @classmethod
    def _param_names(cls):
        sig = inspect.signature(cls.__init__)
        return [p.name for p in sig.parameters.values() if p.name != "self" and p.kind != p.VAR_KEYWORD]

    def get_params(self, deep=True):
        """The constructor's parameters, as a dict."""
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **params):
        """Sets constructor parameters; unknown names raise ValueError."""
        valid = self._param_names()
        for name, value in params.items():
            if name not in valid:
                raise ValueError(f"{name}: not a parameter of {type(self).__name__} (parameters: {', '.join(valid)})")
            setattr(self, name, value)
        return self

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    def _check_fitted(self):
        if not hasattr(self, "labels_"):
            raise ValueError(f"this {type(self).__name__} is not fitted yet: call fit first")

    def _core_args(self):
        if self.metric != "precomputed":
            raise ValueError(f"metric: only 'precomputed' distance matrices are supported, got {self.metric!r}")
        return (
            _positive_int(self.n_clusters, "n_clusters"),
            _positive_int(self.n_init, "n_init"),
            _seed(self.random_state),
            _positive_int(self.max_iter, "max_iter"),
        )

    def fit_predict(self, X, y=None, **options):
        """fit(X) then labels_ (n,) int64."""
        return self.fit(X, y, **options).labels_


class KMedoids(_Estimator):
    """PAM k-medoids on a precomputed (n, n) distance matrix, the best of ``n_init`` seeded runs.

    ``fit(D)`` sets ``labels_`` (n,) int64, ``medoid_indices_`` (n_clusters,), ``inertia_`` (sum of
    the distances to the medoids) and ``n_iter_``. ``predict(D_new)`` assigns items given by their
    (m, n) distances to the fitted items to the nearest medoid.
    """

    def __init__(self, n_clusters=8, *, metric="precomputed", n_init=10, random_state=None, max_iter=100):
        self.n_clusters = n_clusters
        self.metric = metric
        self.n_init = n_init
        self.random_state = random_state
        self.max_iter = max_iter

    def fit(self, X, y=None):
        """Clusters the n items of the distance matrix X (n, n); y is ignored. Returns self."""
        k, n_init, seed, max_iter = self._core_args()
        core = _qcshape.KMedoids(k, n_init, seed, max_iter).fit(X)
        self.labels_ = core.labels_
        self.medoid_indices_ = core.medoid_indices_
        self.inertia_ = core.inertia_
        self.n_iter_ = core.n_iter_
        self.n_features_in_ = len(self.labels_)
        return self

    def predict(self, X):
        """Nearest medoid of each new item: X (m, n) distances to the fitted items -> (m,) int64."""
        self._check_fitted()
        d = _distances(X, "X", self.n_features_in_)
        return _np.argmin(d[:, self.medoid_indices_], axis=1).astype(_np.int64)


class KMeans(_Estimator):
    """k-means in shape space.

    ``fit(D)`` with a precomputed (n, n) distance matrix: kernel k-means on the squared distances,
    the best of ``n_init`` seeded runs. ``fit(dataset, **options)`` with a Dataset: k-means with
    intrinsic means (eq. 14), the similarity matrix computed as by
    ``similarity_matrix(dataset, **options)``, kernel k-means on it as the start; then also
    ``kernel_labels_`` and ``distances_``. Fitted: ``labels_`` (n,) int64, ``inertia_``,
    ``n_iter_``. ``predict(D_new)`` assigns items given by their (m, n) distances to the fitted
    items to the nearest cluster in the kernel sense (mean squared distance to the members minus
    half the members' mean squared spread).
    """

    def __init__(self, n_clusters=8, *, metric="precomputed", n_init=10, random_state=None, max_iter=100):
        self.n_clusters = n_clusters
        self.metric = metric
        self.n_init = n_init
        self.random_state = random_state
        self.max_iter = max_iter

    def fit(self, X, y=None, **options):
        """X: a distance matrix (n, n) or a Dataset (options as for similarity_matrix). Returns self."""
        k, n_init, seed, max_iter = self._core_args()
        core = _qcshape.KMeans(k, n_init, seed, max_iter).fit(X, **options)
        self.labels_ = core.labels_
        self.inertia_ = core.inertia_
        self.n_iter_ = core.n_iter_
        self.kernel_labels_ = core.kernel_labels_
        self.distances_ = core.distances_
        self._train = self.distances_ if self.distances_ is not None else _distances(X, "X")
        self.n_features_in_ = len(self.labels_)
        return self

    def predict(self, X):
        """Cluster of each new item: X (m, n) distances to the fitted items -> (m,) int64."""
        self._check_fitted()
        d2 = _distances(X, "X", self.n_features_in_) ** 2
        t2 = self._train**2
        costs = []
        for c in range(int(self.n_clusters)):
            members = _np.flatnonzero(self.labels_ == c)
            if len(members) == 0:
                costs.append(_np.full(d2.shape[0], _np.inf))
                continue
            spread = t2[_np.ix_(members, members)].mean()
            costs.append(d2[:, members].mean(axis=1) - 0.5 * spread)
        return _np.argmin(_np.stack(costs, axis=1), axis=1).astype(_np.int64)
