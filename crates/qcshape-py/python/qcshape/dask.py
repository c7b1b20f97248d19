"""Similarity matrices on a Dask cluster (``pip install "./crates/qcshape-py[dask]"``).

    from distributed import Client, LocalCluster
    import qcshape as qs
    import qcshape.dask

    ds = qs.Dataset.from_manifest("cohort/manifest.csv")
    with Client(LocalCluster(n_workers=2, threads_per_worker=1)) as client:
        D = qcshape.dask.similarity_matrix(ds, client=client, metric="l2")

The same call runs on a batch system through ``dask-jobqueue`` (see docs/scale.md)::

    from dask_jobqueue import SLURMCluster
    cluster = SLURMCluster(cores=1, processes=1, memory="4GB", walltime="02:00:00")
    cluster.scale(jobs=100)
    D = qcshape.dask.similarity_matrix(ds, client=Client(cluster))

How it runs: the per-deformation part of the pipeline (interpolation, alignment, transfer to
the common base, scaling) runs once, here, in the calling process; the prepared poses are
scattered to every worker once; the n(n-1)/2 pairs are split into batches of ``batch_size``
pairs, one task each, so that the per-topology set-up (metric pattern, solver layout) is paid
once per batch; a batch is a square tile of the matrix, so that it uses the poses of at most
2 sqrt(batch_size) deformations, not all of them. A task that fails is retried
(``retries``), a task lost with its worker is recomputed by the scheduler; every pair is
computed by the same deterministic code, so the result equals
``qcshape.similarity_matrix(ds, **options)`` bit for bit, whatever the cluster.
"""

from __future__ import annotations

import math
import sys
import time
import uuid
from typing import Any, Optional

import numpy as np

from . import _qcshape


def _distributed():
    try:
        import distributed
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "qcshape.dask needs dask[distributed]: pip install \"./crates/qcshape-py[dask]\""
        ) from e
    return distributed


def _batch(poses: np.ndarray, faces: np.ndarray, pairs: np.ndarray, options: dict) -> tuple:
    """One task: the distances of a batch of pairs on one worker (one thread), from the poses of
    the deformations the batch uses only (they are copied and, in the straight mode, their
    angle defects computed, once per task)."""
    used, local = np.unique(pairs, return_inverse=True)
    d, converged = _qcshape.pair_distances(
        poses[used], faces, local.reshape(pairs.shape).astype(np.int64), threads=1, **options
    )
    return pairs, d, converged


def _tiled_batches(n: int, batch_size: int) -> list:
    """Every pair i < j of n items, in batches of at most batch_size pairs: square tiles of
    b = isqrt(batch_size) rows and columns of the upper triangle (each an (m, 2) int64 array),
    so that a batch uses the poses of at most 2 b deformations instead of up to n."""
    b = max(1, math.isqrt(batch_size))
    tiles = []
    for r in range(0, n, b):
        for c in range(r, n, b):
            ii, jj = np.meshgrid(np.arange(r, min(r + b, n)), np.arange(c, min(c + b, n)), indexing="ij")
            keep = ii < jj
            if keep.any():
                tiles.append(np.stack([ii[keep], jj[keep]], axis=1).astype(np.int64))
    return tiles


def similarity_matrix(
    ds: Any,
    client: Optional[Any] = None,
    batch_size: Optional[int] = None,
    retries: int = 3,
    progress: bool = True,
    **options: Any,
) -> np.ndarray:
    """The similarity matrix (eq. 13) of ``ds`` (a ``qcshape.Dataset``) computed on a Dask cluster.

    ``client``: a ``distributed.Client`` (None: the current default client, or a new local
    cluster that is closed afterwards). ``batch_size``: at most that many pairs per task (>= 1;
    None: 64 for exact geodesics, 2048 with ``approx``, whose pairs are so cheap that the
    per-task preparation of the poses a batch uses would dominate smaller tasks); a task is a
    square tile of isqrt(batch_size) rows and columns of the matrix. ``retries``: how often a
    failed task is resubmitted. ``progress``: a line on stderr at most every 10 s.
    ``options``: those of ``qcshape.similarity_matrix`` (metric, steps, transport, approx, ...;
    ``threads`` applies to the preparation here, every task uses one thread).

    Returns an (n, n) float64 array in the metric's units, equal to
    ``qcshape.similarity_matrix(ds, **options)``.
    """
    if batch_size is None:
        batch_size = 64 if options.get("approx", "exact") == "exact" else 2048
    if not isinstance(batch_size, int) or isinstance(batch_size, bool) or batch_size < 1:
        raise ValueError(f"batch_size: must be a positive integer, got {batch_size!r}")
    if not isinstance(retries, int) or retries < 0:
        raise ValueError(f"retries: must be a non-negative integer, got {retries!r}")
    distributed = _distributed()
    own = None
    if client is None:
        try:
            client = distributed.get_client()
        except ValueError:
            own = client = distributed.Client(processes=True)
    try:
        return _run(distributed, client, ds, batch_size, retries, progress, options)
    finally:
        if own is not None:
            own.close()


def _run(distributed, client, ds, batch_size, retries, progress, options) -> np.ndarray:
    prep_options = dict(options)
    prep_options["progress"] = False
    poses, faces, names, _converged = _qcshape.prepare_pairs(ds, **prep_options)
    task_options = {k: v for k, v in options.items() if k not in ("threads", "progress")}
    n = len(names)
    batches = _tiled_batches(n, batch_size)
    # Unique keys (hash=False): with content-hashed keys, a second call on the same data reuses
    # the key of the first call's data while the scheduler is still releasing it, and the
    # batches then wait for data that is gone (seen as a hang or a FutureCancelledError).
    poses_f, faces_f = client.scatter([poses, faces], broadcast=True, hash=False)
    token = uuid.uuid4().hex[:12]
    futures = [
        client.submit(
            _batch,
            poses_f,
            faces_f,
            batch,
            task_options,
            key=f"qcshape-pairs-{token}-{k}",
            retries=retries,
            pure=False,
        )
        for k, batch in enumerate(batches)
    ]
    d = np.zeros((n, n))
    done, total = 0, n * (n - 1) // 2
    t0 = last = time.monotonic()
    for _future, (batch, dist, _ok) in distributed.as_completed(futures, with_results=True):
        d[batch[:, 0], batch[:, 1]] = dist
        d[batch[:, 1], batch[:, 0]] = dist
        done += len(batch)
        now = time.monotonic()
        if progress and (now - last >= 10 or done == total):
            last = now
            elapsed = now - t0
            eta = elapsed / done * (total - done)
            print(
                f"qcshape.dask: pairs {done}/{total}, {elapsed:.0f} s elapsed, ETA {eta:.0f} s",
                file=sys.stderr,
                flush=True,
            )
    return d
