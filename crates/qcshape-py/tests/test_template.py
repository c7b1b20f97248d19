"""Dataset.load(path, template=...) (issue 49 item 2): a data set whose poses have another
triangulation than the template (642 vertices against 162) is fitted on the way, tracked, by the
library's data-set fit (the code path of `qcshape similarity --template`), and its quality is
reported per pose."""

import os
import subprocess

import numpy as np
import pytest

import qcshape as qs

BIN = os.environ.get("QCSHAPE_BIN", "qcshape")


def synth(tmp_path, level):
    out = tmp_path / f"level{level}"
    subprocess.run([BIN, "-q", "synth", "--out", str(out), "--level", str(level)], check=True, capture_output=True)
    rows = [l for l in (out / "manifest.csv").read_text().splitlines() if l.startswith(("deformation,", "ellipsoid-bulge,", "ellipsoid-dent,"))]
    manifest = out / "sub.csv"
    manifest.write_text("\n".join(rows) + "\n")
    return manifest


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("template")
    return synth(tmp, 2), synth(tmp, 3)


def test_load_with_a_template_fits_every_pose(data):
    original, remeshed = data
    template = original.parent / "ellipsoid-bulge" / "pose000.ply"
    ds = qs.Dataset.load(remeshed, template=str(template))
    assert ds.names == ["ellipsoid-bulge", "ellipsoid-dent"]
    assert ds[0].shape == (3, 162, 3)
    q = ds.fit_quality
    assert len(q) == 2 * 3 and [r["pose"] for r in q] == [0, 1, 2, 0, 1, 2]
    assert all(not r["poor"] and r["flipped"] == 0 and r["mean"] < 0.1 for r in q)
    assert q[0]["source"].endswith("pose000.ply") and "level3" in q[0]["source"]
    # The same as the CLI: similarity --template on the same files gives the same matrix.
    D = qs.similarity_matrix(ds, progress=False, metric="isometric")
    out = remeshed.parent / "D.csv"
    subprocess.run(
        [BIN, "-q", "similarity", str(remeshed), "--template", str(template), "--metric", "isometric", "-o", str(out)],
        check=True,
        capture_output=True,
    )
    cli = np.loadtxt(out, delimiter=",", skiprows=1, usecols=(1, 2))
    assert np.allclose(D, cli, rtol=0, atol=1e-12)
    # A (vertices, faces) pair is a template too; no template, no quality.
    V, F = qs.read_mesh(template)
    again = qs.Dataset.from_manifest(remeshed, template=(V, F))
    assert np.array_equal(again[1], ds[1])
    assert qs.Dataset.load(original).fit_quality is None


def test_bad_template_is_a_clear_error(data, tmp_path):
    _, remeshed = data
    with pytest.raises(OSError, match="nothing.ply"):
        qs.Dataset.load(remeshed, template=str(tmp_path / "nothing.ply"))
    V, F = qs.icosphere(1)
    with pytest.raises(ValueError, match="template"):
        qs.Dataset.load(remeshed, template=(V, F + 1000))
