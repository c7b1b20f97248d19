"""Progress (issue 50, item 4): none when stderr is not a terminal (progress=None, the default),
plain lines with progress=True off a terminal, never a carriage return in a log."""

import subprocess
import sys

CODE = """
import qcshape as qs
ds = qs.Dataset.synthetic(level=1)[0:4]
qs.similarity_matrix(ds, metric="isometric", steps=2{kw})
V, F = qs.icosphere(1)
qs.ShapeSpace(F).pairwise_distances([V, 1.1 * V, 1.2 * V]{kw})
"""


def stderr_of(kw):
    return subprocess.run(
        [sys.executable, "-c", CODE.format(kw=kw)], capture_output=True, text=True, check=True
    ).stderr


def test_no_progress_on_a_pipe_by_default():
    err = stderr_of("")
    assert "qcshape:" not in err and "\r" not in err


def test_progress_true_gives_plain_lines_in_a_log():
    err = stderr_of(", progress=True")
    assert "qcshape: pairs 6/6\n" in err and "qcshape: pairs 3/3\n" in err
    assert "\r" not in err


def test_progress_false_is_silent():
    assert "qcshape:" not in stderr_of(", progress=False")
