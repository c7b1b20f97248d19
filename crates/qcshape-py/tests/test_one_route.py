"""One engine, one answer: a journaled Python run killed with SIGKILL resumes to the same bits;
the CLI's `similarity` and `run` and Python give the same matrix."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import qcshape as qs
from conftest import FAST
from test_similarity import cli, read_matrix_csv

CHILD = """
import sys
import qcshape as qs
ds = qs.Dataset.synthetic(level=1)
qs.similarity_matrix(ds, journal=sys.argv[1], threads=1, progress=False, metric="isometric", steps=2)
"""


def pair_lines(path):
    try:
        return sum(1 for line in open(path) if line.startswith("pair,"))
    except FileNotFoundError:
        return 0


def test_a_killed_run_resumes_to_the_same_matrix(tmp_path, synthetic, fast_matrix):
    journal = tmp_path / "D.journal"
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(journal)])
    deadline = time.monotonic() + 120
    while pair_lines(journal) < 20 and child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert child.poll() is None, "the child finished before it could be killed"
    child.send_signal(signal.SIGKILL)
    child.wait()
    done = pair_lines(journal)
    assert 20 <= done < 1128
    # The lock of the killed run is stale and taken over; only the missing pairs are computed.
    D = qs.similarity_matrix(synthetic, journal=journal, resume=True, progress=False, **FAST)
    assert np.array_equal(D, fast_matrix)  # bit for bit
    assert not journal.exists(), "the journal is removed once the matrix is returned"


def test_journal_arguments_are_checked(tmp_path, synthetic):
    with pytest.raises(ValueError, match="resume=True needs journal="):
        qs.similarity_matrix(synthetic, resume=True, progress=False, **FAST)
    data = tmp_path / "notes.csv"
    data.write_text("a,b\n1,2\n")
    with pytest.raises(OSError, match="not a qcshape similarity journal"):
        qs.similarity_matrix(synthetic, journal=data, progress=False, **FAST)
    assert data.read_text() == "a,b\n1,2\n"


def test_cli_similarity_run_and_python_give_one_matrix(tmp_path):
    exe = cli()
    syn = tmp_path / "syn"
    subprocess.run([exe, "synth", "--out", str(syn), "--level", "1"], check=True, capture_output=True)
    manifest = syn / "manifest.csv"
    opts = ["--metric", "isometric", "--steps", "2"]
    out = tmp_path / "D.csv"
    subprocess.run([exe, "similarity", str(manifest), *opts, "-o", str(out)], check=True, capture_output=True)
    run = tmp_path / "R"
    subprocess.run(
        [exe, "run", str(manifest), *opts, "--out", str(run)], check=True, capture_output=True
    )
    assert (run / "similarity.csv").read_bytes() == out.read_bytes()
    names, expected = read_matrix_csv(out)
    ds = qs.Dataset.from_manifest(manifest)
    D = qs.similarity_matrix(ds, progress=False, **FAST)
    assert names == ds.names
    assert np.array_equal(D, expected)  # the CSV holds shortest round-trip decimals


def _signature_defaults(fn):
    """{keyword: default} of a builtin's text signature."""
    import inspect

    return {n: p.default for n, p in inspect.signature(fn).parameters.items() if p.default is not p.empty}


def test_keyword_defaults_follow_the_librarys_settings_table():
    table = qs.settings()
    assert table["lam"]["flag"] == "--lambda" and table["lam"]["default"] == "0.01"
    assert table["steps"]["default"] == "8" and table["base"]["default"] is None
    for fn in (qs.similarity_matrix, qs.pair_contributions, qs.motion_maps):
        defaults = _signature_defaults(fn)
        for kw, s in table.items():
            assert kw in defaults, f"{fn.__name__} lacks {kw}"
            shown = defaults[kw]
            # None means "the library's default"; a value shown must be that default.
            same = str(shown) == s["default"] or (isinstance(shown, float) and shown == float(s["default"]))
            assert shown is None or same, (fn.__name__, kw, shown, s["default"])
    space = _signature_defaults(qs.ShapeSpace)
    for kw, s in table.items():
        if s["group"] in ("metric", "solver"):
            assert kw in space, f"ShapeSpace lacks {kw}"


def test_the_stub_lists_every_setting():
    import ast

    stub = Path(qs.__file__).with_name("__init__.pyi")
    tree = ast.parse(stub.read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "_PipelineOptions")
    keys = {n.target.id for n in cls.body if isinstance(n, ast.AnnAssign)}
    assert keys == set(qs.settings()) | {"threads", "progress"}


def test_out_of_range_values_are_named_by_their_keyword(synthetic, pair):
    V, B, F = pair
    with pytest.raises(ValueError, match="^qc_floor must be >= 0"):
        qs.ShapeSpace(F, qc_floor=-1.0)
    with pytest.raises(ValueError, match="^length_tolerance must be >= 0"):
        qs.similarity_matrix(synthetic, length_tolerance=-1.0, progress=False)
    for bad in (-1.0, float("nan"), 11.0):
        with pytest.raises(ValueError, match="^smooth_length must be >= 0"):
            qs.similarity_matrix(synthetic, smooth_length=bad, progress=False)
    with pytest.raises(ValueError, match="^smooth and smooth_length exclude each other"):
        qs.similarity_matrix(synthetic, smooth=10, smooth_length=0.2, progress=False)
    with pytest.warns(UserWarning, match="lam=0 leaves the conformal metric"):
        qs.ShapeSpace(F, metric="conformal", lam=0.0)


def test_geodesic_cli_and_python_dist_give_one_distance(tmp_path, pair):
    import json

    exe = cli()
    V, B, F = pair
    a, b = tmp_path / "A.ply", tmp_path / "B.ply"
    qs.write_mesh(a, V, F)
    qs.write_mesh(b, B, F)

    def cli_distance(x, y):
        out = subprocess.run([exe, "geodesic", str(x), str(y), "--json"], check=True, capture_output=True)
        return json.loads(out.stdout)["distance"]

    ab, ba = cli_distance(a, b), cli_distance(b, a)
    space = qs.ShapeSpace(F)
    d_ab, d_ba = space.dist(V, B), space.dist(B, V)
    assert ab > 0.05
    # B -> A is solved as its own problem: the same distance to rounding.
    for d in (ba, d_ab, d_ba):
        assert abs(d - ab) <= 1e-11 * ab, (ab, ba, d_ab, d_ba)
