"""Ctrl-C (issue 50, item 2): a long call interrupted 3 s or 9 s in raises KeyboardInterrupt
promptly. A subprocess runs pairwise distances on a synthetic set (well over 9 s of work), the
test sends it SIGINT and measures the time to the KeyboardInterrupt. The target is 0.3 s; the
bound asserted is 2 s so that a loaded 2-core CI does not flake, and the latency is printed
(pytest -s shows it)."""

import os
import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.skipif(os.name != "posix", reason="SIGINT to a subprocess needs POSIX")

BOUND_S = 2.0

# The child installs Python's own SIGINT handler: a parent that ignores SIGINT (a CI job started in
# the background, `nohup`) passes SIG_IGN on, and Python then never raises KeyboardInterrupt, whatever
# qcshape does. Measured: launched that way the call ran to its end (99 s) before this line existed.
CHILD = """
import signal, sys, time
signal.signal(signal.SIGINT, signal.default_int_handler)
import numpy as np
import qcshape as qs
V, F = qs.icosphere(2)
rng = np.random.default_rng(0)
# 150 smooth random deformations of the sphere: 11,175 pairs, minutes of work on one thread
# (780 pairs took under 9 s).
poses = [V * (1.0 + 0.15 * np.sin(V @ rng.normal(size=(3, 1)) * 2.0)) for _ in range(150)]
space = qs.ShapeSpace(F, metric="isometric")
print("ready", flush=True)
try:
    space.pairwise_distances(poses, threads=1, progress=False)
    print("finished", flush=True)
except KeyboardInterrupt:
    print(f"interrupted {time.time():.6f}", flush=True)
"""


@pytest.mark.parametrize("after_s", [3.0, 9.0])
def test_ctrl_c_raises_keyboard_interrupt_promptly(after_s):
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout.readline().strip() == "ready", child.stderr.read()
        time.sleep(after_s)
        assert child.poll() is None, f"the call ended before the interrupt: {child.stdout.read()}"
        sent = time.time()
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    lines = out.split()
    assert lines[:1] == ["interrupted"], f"no KeyboardInterrupt: stdout {out!r}, stderr {err!r}"
    latency = float(lines[1]) - sent
    print(f"SIGINT {after_s:.0f} s into pairwise_distances: KeyboardInterrupt after {latency:.3f} s")
    assert latency < BOUND_S, f"KeyboardInterrupt {latency:.3f} s after SIGINT (target 0.3 s)"


# Issue 60: one geodesic on a 10,242-vertex sphere (a single solve of tens of seconds, no pairs
# to stop between): Ctrl-C must reach the solver between two iterations, within 1 s.
GEODESIC_BOUND_S = 1.0

SINGLE = """
import signal, sys, time
signal.signal(signal.SIGINT, signal.default_int_handler)
import numpy as np
import qcshape as qs
V, F = qs.icosphere(5)
z = V[:, 2:3]
c, s = np.cos(1.2 * z), np.sin(1.2 * z)
B = np.column_stack([c[:, 0] * V[:, 0] - s[:, 0] * V[:, 1], s[:, 0] * V[:, 0] + c[:, 0] * V[:, 1], 1.5 * V[:, 2]])
# Without the bending term the membrane metrics take minutes at 10,242 vertices (the default
# converges in about 6 s, too soon to be interrupted 2 s after its first iterations).
space = qs.ShapeSpace(F, metric="{metric}", bending=0)
seen = []
def progress(stage, done, total):
    if stage == "iterations" and not seen:
        seen.append(done)
        print("iterating", flush=True)
try:
    space.{call}(V, B, progress=progress)
    print("finished", flush=True)
except KeyboardInterrupt:
    print(f"interrupted {{time.time():.6f}}", flush=True)
"""


@pytest.mark.parametrize("metric,call", [("isometric", "geodesic"), ("conformal", "dist")])
def test_ctrl_c_reaches_a_single_geodesic_within_1_s(metric, call):
    child = subprocess.Popen(
        [sys.executable, "-c", SINGLE.format(metric=metric, call=call)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        # The solver is iterating (its first iterations were reported), then 2 s more.
        assert child.stdout.readline().strip() == "iterating", child.stderr.read()
        time.sleep(2.0)
        assert child.poll() is None, f"the call ended before the interrupt: {child.stdout.read()}"
        sent = time.time()
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=120)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    lines = out.split()
    assert lines[:1] == ["interrupted"], f"no KeyboardInterrupt: stdout {out!r}, stderr {err!r}"
    latency = float(lines[1]) - sent
    print(f"SIGINT into {call} ({metric}, 10,242 vertices): KeyboardInterrupt after {latency:.3f} s")
    assert latency < GEODESIC_BOUND_S, f"KeyboardInterrupt {latency:.3f} s after SIGINT"
