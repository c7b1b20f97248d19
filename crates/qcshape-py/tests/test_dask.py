"""qcshape.dask on a real distributed.LocalCluster (two worker processes, no mocks): the matrix
equals the in-process one, and a worker killed mid-run does not change it."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import qcshape as qs
from conftest import FAST

distributed = pytest.importorskip("distributed", reason="dask[distributed] is not installed")
import qcshape.dask  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_dask_matrix_equals_the_in_process_matrix(client, synthetic, fast_matrix):
    d = qcshape.dask.similarity_matrix(synthetic, client=client, batch_size=50, progress=False, **FAST)
    assert d.shape == fast_matrix.shape
    np.testing.assert_allclose(d, fast_matrix, rtol=0, atol=1e-12)
    assert np.array_equal(d, fast_matrix)  # the same code on the same bits


def test_dask_approx_and_bad_arguments(client, synthetic):
    opts = dict(metric="l2", steps=2, approx="straight")
    d = qcshape.dask.similarity_matrix(synthetic, client=client, batch_size=300, progress=False, **opts)
    np.testing.assert_allclose(d, qs.similarity_matrix(synthetic, progress=False, **opts), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="batch_size"):
        qcshape.dask.similarity_matrix(synthetic, client=client, batch_size=0)
    with pytest.raises(ValueError, match="approx"):
        qcshape.dask.similarity_matrix(synthetic, client=client, approx="fast")


def test_repeated_calls_on_the_same_data_do_not_lose_it(client, synthetic):
    # Content-hashed scatter keys let a call reuse the key of the previous call's data while
    # the scheduler released it (the batches then waited for lost data); keys are unique now.
    opts = dict(metric="l2", steps=2, approx="straight")
    want = qs.similarity_matrix(synthetic, progress=False, **opts)
    for _ in range(6):
        d = qcshape.dask.similarity_matrix(synthetic, client=client, batch_size=200, progress=False, **opts)
        assert np.array_equal(d, want)


def _finished_batches(dask_scheduler):
    return sum(
        1 for k, ts in dask_scheduler.tasks.items() if str(k).startswith("qcshape-pairs") and ts.state == "memory"
    )


def test_a_worker_killed_mid_run_does_not_change_the_result(client, synthetic):
    opts = dict(metric="quasi-conformal", steps=4)
    expected = qs.similarity_matrix(synthetic, progress=False, **opts)
    result = {}

    def work():
        result["d"] = qcshape.dask.similarity_matrix(synthetic, client=client, batch_size=20, progress=False, **opts)

    t = threading.Thread(target=work)
    t.start()
    deadline = time.monotonic() + 120
    while client.run_on_scheduler(_finished_batches) < 3:
        assert time.monotonic() < deadline, "no batch finished in 120 s"
        assert t.is_alive(), "the run finished before a worker could be killed (make it longer)"
        time.sleep(0.05)
    pids = client.run(os.getpid)
    victim = sorted(pids)[0]
    os.kill(pids[victim], signal.SIGKILL)
    killed_mid_run = t.is_alive()
    t.join(timeout=300)
    assert not t.is_alive(), "the run did not finish after the worker was killed"
    assert killed_mid_run
    np.testing.assert_allclose(result["d"], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("n,batch_size", [(2, 64), (3, 1), (10, 4), (23, 20), (120, 2048), (400, 2048)])
def test_batches_are_tiles_that_cover_every_pair_once(n, batch_size):
    batches = qcshape.dask._tiled_batches(n, batch_size)
    pairs = np.concatenate(batches)
    assert len({tuple(p) for p in pairs}) == len(pairs) == n * (n - 1) // 2
    assert np.all(pairs[:, 0] < pairs[:, 1]) and pairs.min() >= 0 and pairs.max() < n
    side = max(1, int(np.sqrt(batch_size)))
    for b in batches:
        assert 0 < len(b) <= batch_size
        # A tile touches at most 2 sqrt(batch_size) deformations (what a task copies).
        assert len(np.unique(b)) <= 2 * side
