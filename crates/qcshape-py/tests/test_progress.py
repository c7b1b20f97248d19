"""Progress (issue 50, item 4), the progress= keyword: None (auto) shows a tqdm bar on a terminal
or in Jupyter and, off a terminal, plain lines at most every 10 s (none for a short call); True
forces a final line too; False is silent; a callable receives (stage, done, total). Never a
carriage return in a log."""

import importlib.util
import os
import subprocess
import sys

import pytest

import qcshape as qs

CODE = """
import qcshape as qs
ds = qs.Dataset.synthetic(level=1)[0:4]
qs.similarity_matrix(ds, metric="isometric", steps=2{kw})
V, F = qs.icosphere(1)
qs.ShapeSpace(F).pairwise_distances([V, 1.1 * V, 1.2 * V]{kw})
"""


def stderr_of(kw, prelude=""):
    return subprocess.run(
        [sys.executable, "-c", prelude + CODE.format(kw=kw)], capture_output=True, text=True, check=True
    ).stderr


def test_no_progress_on_a_pipe_by_default():
    err = stderr_of("")
    assert "qcshape:" not in err and "\r" not in err


def test_plain_lines_on_a_pipe_for_a_long_call():
    # A call longer than the lines' interval (made 0 here) logs plain lines, no carriage return.
    err = stderr_of("", prelude="import qcshape._progress as p; p.LINE_EVERY = 0.0\n")
    assert "qcshape: pairs 6/6\n" in err and "qcshape: interpolating 4/4\n" in err
    assert "\r" not in err


def test_progress_true_gives_plain_lines_in_a_log():
    err = stderr_of(", progress=True")
    assert "qcshape: pairs 6/6\n" in err and "qcshape: pairs 3/3\n" in err
    assert "\r" not in err


def test_progress_false_is_silent():
    assert "qcshape:" not in stderr_of(", progress=False")


def test_progress_callable_sees_every_stage(synthetic, capfd):
    seen = []
    qs.similarity_matrix(synthetic[0:4], metric="isometric", steps=2,
                         progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert [s for s in seen if s[1] == s[2]] == [("interpolating", 4, 4), ("transferring", 4, 4), ("pairs", 6, 6)]
    assert all(0 < done <= total for _, done, total in seen)
    V, F = qs.icosphere(1)
    seen.clear()
    qs.ShapeSpace(F).pairwise_distances([V, 1.1 * V, 1.2 * V], progress=lambda *a: seen.append(a))
    assert seen[-1] == ("pairs", 3, 3)
    seen.clear()
    qs.motion_maps(synthetic[0:3], steps=2, progress=lambda *a: seen.append(a))
    assert [s for s in seen if s[1] == s[2]] == [("interpolating", 3, 3), ("transferring", 3, 3)]
    assert "qcshape:" not in capfd.readouterr().err


def test_progress_callable_error_stops_the_call(sphere):
    V, F = sphere

    def stop(stage, done, total):
        raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        qs.ShapeSpace(F).pairwise_distances([V, 1.1 * V, 1.2 * V, 1.3 * V], threads=1, progress=stop)


def test_progress_bad_value_names_the_keyword(sphere, synthetic):
    V, F = sphere
    with pytest.raises(ValueError, match="progress"):
        qs.ShapeSpace(F).pairwise_distances([V, 1.1 * V], progress="yes")
    with pytest.raises(ValueError, match="progress"):
        qs.similarity_matrix(synthetic[0:2], steps=2, progress=3)
    with pytest.raises(ValueError, match="progress"):
        qs.motion_maps(synthetic[0:2], steps=2, progress="no")


def on_a_terminal(prelude=""):
    """The script's stderr when it is a terminal (a pseudo-terminal)."""
    import fcntl
    import pty
    import struct
    import termios

    main, sub = pty.openpty()
    # A terminal of 100 columns (a new pseudo-terminal has 0, which tqdm draws as nothing).
    fcntl.ioctl(sub, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    try:
        subprocess.run([sys.executable, "-c", prelude + CODE.format(kw="")], stderr=sub,
                       stdout=subprocess.DEVNULL, check=True)
    finally:
        os.close(sub)
    chunks = []
    while True:
        try:
            data = os.read(main, 65536)
        except OSError:
            break
        if not data:
            break
        chunks.append(data)
    os.close(main)
    return b"".join(chunks).decode(errors="replace")


needs_pty = pytest.mark.skipif(os.name != "posix", reason="needs a pseudo-terminal")
needs_tqdm = pytest.mark.skipif(importlib.util.find_spec("tqdm") is None, reason="tqdm is not installed")


@needs_pty
@needs_tqdm
def test_tqdm_bar_on_a_terminal():
    err = on_a_terminal()
    assert "qcshape: pairs" in err and "100%" in err and "6/6" in err


@needs_pty
def test_line_on_a_terminal_without_tqdm():
    err = on_a_terminal(prelude="import sys; sys.modules['tqdm'] = None\n")
    assert "\rqcshape: pairs 6/6" in err and "%" not in err


@needs_tqdm
def test_bar_in_jupyter():
    # A kernel (ipykernel imported) gets the bar although its stderr is no terminal.
    err = stderr_of("", prelude="import sys, types; sys.modules['ipykernel'] = types.ModuleType('ipykernel')\n")
    assert "qcshape: pairs" in err and "100%" in err


# Issue 60, item 3: single geodesics, interpolation and transfer report solver iterations.
SINGLE = """
import numpy as np
import qcshape as qs
V, F = qs.icosphere({level})
B = V * np.array([1.0, 1.3, 0.8]) + 0.2 * V[:, [1, 2, 0]] ** 2
qs.ShapeSpace(F, metric="conformal").geodesic(V, B{kw})
"""


def test_a_single_geodesic_logs_iteration_lines():
    # The lines' interval made 0 (it is 10 s): every count the poller sees becomes a line. The
    # poller looks every 50 ms, so the solve must last a few of those: 2,562 vertices (at 642
    # the conformal geodesic takes about 50 ms since its fused kernel).
    err = subprocess.run(
        [sys.executable, "-c", "import qcshape._progress as p; p.LINE_EVERY = 0.0\n" + SINGLE.format(level=4, kw="")],
        capture_output=True, text=True, check=True,
    ).stderr
    lines = [line for line in err.splitlines() if line.startswith("qcshape: iterations")]
    assert len(lines) >= 3, err
    # Count, limit and rate; the last line the count and the time.
    assert " of at most " in lines[0] and ("/s" in lines[0] or "/min" in lines[0]), lines
    assert lines[-1].startswith("qcshape: iterations ") and " in " in lines[-1] and " of at most " not in lines[-1], lines
    assert "\r" not in err


def test_a_short_single_geodesic_is_silent_in_a_log():
    err = subprocess.run([sys.executable, "-c", SINGLE.format(level=3, kw="")], capture_output=True, text=True, check=True).stderr
    assert "qcshape:" not in err


def test_progress_callable_sees_solver_iterations(pair):
    VA, VB, F = pair
    space = qs.ShapeSpace(F, metric="conformal")
    seen = []
    g = space.geodesic(VA, VB, progress=lambda *a: seen.append(a))
    assert seen and all(stage == "iterations" for stage, _, _ in seen)
    counts = [done for _, done, _ in seen]
    assert counts == sorted(counts) and counts[-1] == g.iterations
    assert all(total >= g.iterations for _, _, total in seen)
    seen.clear()
    space.dist(VA, VB, progress=lambda *a: seen.append(a))
    assert seen and seen[-1][0] == "iterations"
    seen.clear()
    space.interpolate([VA, VB, VA], insert=1, progress=lambda *a: seen.append(a))
    assert ("pairs", 2, 2) in seen and any(s[0] == "iterations" and s[2] == 0 for s in seen)


def test_eta_of_plain_lines_is_the_average_rate():
    from qcshape import _progress

    assert _progress._duration(42) == "42 s" and _progress._duration(185) == "3 min 05 s"
    import io

    out = io.StringIO()
    r = _progress._Plain(out, final=False)
    r.start -= 100.0
    r.stage_mark = r.start
    r.last = r.start
    # 2 of 6 pairs in 100 s: 4 left at 50 s each.
    r.update("pairs", 2, 6)
    assert out.getvalue() == "qcshape: pairs 2/6, 1.2/min, ETA 3 min 20 s\n"
