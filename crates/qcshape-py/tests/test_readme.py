"""The README's Python example, run as written after the tour's first command (`qcshape synth --out
syn --level 1`) in a fresh folder."""

import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).resolve().parents[3] / "README.md"


def python_blocks():
    text = README.read_text()
    start = text.index("## Python")
    return re.findall(r"```python\n(.*?)```", text[start:], flags=re.S)


def test_readme_has_one_python_example():
    blocks = python_blocks()
    assert len(blocks) >= 1
    assert "import qcshape as qs" in blocks[0]


def test_readme_python_example_runs_as_written(tmp_path, monkeypatch):
    qcshape = os.environ.get("QCSHAPE_BIN")
    if not qcshape or not Path(qcshape).is_file():
        pytest.skip("QCSHAPE_BIN is not set to the built qcshape binary (.ci/run sets it)")
    subprocess.run([qcshape, "synth", "--out", "syn", "--level", "1"], cwd=tmp_path, check=True,
                   capture_output=True)
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(compile(python_blocks()[0], str(README), "exec"), scope)
    g, D, details = scope["g"], scope["D"], scope["details"]
    assert D.shape == (48, 48)
    assert np.allclose(D, D.T)
    assert g.path.shape == (9, 42, 3)
    # The default metric measures its geometry, not L2 (measured share 0.2 %).
    assert g.regularizer_share == pytest.approx(g.regularizer_energy / g.energy, rel=1e-12)
    assert g.regularizer_share < 0.05
    assert scope["dense"].shape == (5, 42, 3)
    assert scope["X"].shape == (48, 2)
    assert (tmp_path / "mid.ply").is_file()
    assert details is not None
