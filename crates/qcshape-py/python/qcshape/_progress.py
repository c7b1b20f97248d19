"""Progress of long calls (the ``progress=`` keyword): the extension counts finished items on its
worker threads and, from the calling thread (GIL held, every 50 ms), hands the counts to the
reporter made here.

- ``progress=None`` (the default): a bar on a terminal or in Jupyter (tqdm's, when tqdm is
  installed; otherwise one ``\\r``-updated line), and off a terminal (logs, pipes) plain lines at
  most every 10 s, none for a call shorter than that.
- ``progress=True``: as None, but off a terminal a plain line also when a stage ends.
- ``progress=False``: nothing.
- a callable ``progress(stage, done, total)``: called with the stage ("interpolating",
  "transferring", "pairs", "iterations") and its counts instead of any display; an exception it
  raises stops the call and propagates. For "iterations" (the solver iterations of
  ``ShapeSpace.geodesic``, ``dist``, ``interpolate``, ``transfer``) ``total`` is the iteration
  limit of one geodesic, or 0 when the call solves several.

Plain lines give the rate and the time left, averaged over the stage's finished items.

tqdm stays optional: it is imported only when a bar is shown. Nothing writes a carriage return
into a stream that is not a terminal (Jupyter's, which renders them, excepted).
"""

import sys
import time

# Seconds between two plain lines off a terminal (as the CLI's) and between two redraws of the
# fallback line on a terminal.
LINE_EVERY = 10.0
REDRAW_EVERY = 0.2


def _in_jupyter():
    return "ipykernel" in sys.modules


def _is_terminal(stream):
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def reporter(progress):
    """The reporter for ``progress`` (None when nothing is to be shown): an object with
    ``update(stage, done, total)`` and ``close()``."""
    if progress is False:
        return None
    if callable(progress) and not isinstance(progress, bool):
        return _Callback(progress)
    if progress is not None and progress is not True:
        raise ValueError(
            "progress: expected None (auto), True, False or a callable (stage, done, total), "
            f"got {progress!r}"
        )
    stream = sys.stderr
    if stream is None:
        return None
    if _in_jupyter() or _is_terminal(stream):
        try:
            if _in_jupyter():
                from tqdm.auto import tqdm
            else:
                from tqdm import tqdm
        except ImportError:
            return _Line(stream)
        return _Bar(tqdm, stream)
    return _Plain(stream, final=progress is True)


class _Callback:
    def __init__(self, fn):
        self.fn = fn

    def update(self, stage, done, total):
        self.fn(stage, done, total)

    def close(self):
        pass


class _Bar:
    """One tqdm bar per stage."""

    def __init__(self, tqdm, stream):
        self.tqdm = tqdm
        self.stream = stream
        self.stage = None
        self.bar = None

    def update(self, stage, done, total):
        if stage != self.stage:
            self.close()
            self.stage = stage
            # Solver iterations of several solves have no known total (0): a counter.
            self.bar = self.tqdm(total=total or None, desc=f"qcshape: {stage}", file=self.stream, leave=True)
        self.bar.update(done - self.bar.n)

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class _Line:
    """A ``\\r``-updated line on a terminal (no tqdm installed)."""

    def __init__(self, stream):
        self.stream = stream
        self.last = 0.0
        self.open = False

    def update(self, stage, done, total):
        now = time.monotonic()
        if done < total and now - self.last < REDRAW_EVERY:
            return
        self.last = now
        count = f"{done}/{total}" if total else f"{done}"
        self.stream.write(f"\rqcshape: {stage} {count}   ")
        self.open = done < total or not total
        if not self.open:
            self.stream.write("\n")
        self.stream.flush()

    def close(self):
        if self.open:
            self.stream.write("\n")
            self.stream.flush()
            self.open = False


def _duration(seconds):
    """A duration for a log line: "42 s", "3 min 05 s", "2 h 07 min"."""
    seconds = max(0, int(round(seconds)))
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"


def _rate(per_second):
    return f"{per_second:.3g}/s" if per_second >= 0.1 else f"{60 * per_second:.3g}/min"


class _Plain:
    """Plain lines for logs: at most one every LINE_EVERY seconds (the first after that long), and
    a stage's last count when a line of it was printed (or always, with ``final``). A line gives
    the rate and, for items with a known total, the time left: both averaged over everything
    the stage finished so far (done / time since the stage began), so the estimate does not
    jump while an item runs. Solver iterations (stage "iterations") have no time left (a solver
    stops when it converges, not at a count): the line gives the count, the iteration limit
    and the rate, and the display's end (a converged solve or an interrupt) the count and the time."""

    def __init__(self, stream, final):
        self.stream = stream
        self.final = final
        self.start = time.monotonic()
        self.last = self.start
        self.printed = set()
        # Per stage: when it began (the reporter's start for the first, else the time the
        # previous stage was last updated) and its last count.
        self.began = {}
        self.counts = {}
        self.stage_mark = self.start

    def _line(self, stage, done, total, now):
        began = self.began[stage]
        elapsed = now - began
        rate = done / elapsed if elapsed > 0 else 0.0
        if stage == "iterations":
            limit = f" of at most {total}" if total else ""
            return f"qcshape: iterations {done}{limit}, {_rate(rate)}"
        text = f"qcshape: {stage} {done}/{total}"
        if 0 < done < total and rate > 0:
            text += f", {_rate(rate)}, ETA {_duration((total - done) / rate)}"
        return text

    def update(self, stage, done, total):
        now = time.monotonic()
        if stage not in self.began:
            self.began[stage] = self.stage_mark if stage != "iterations" else self.start
        if stage != "iterations":
            self.stage_mark = now
        self.counts[stage] = (done, total)
        end = done == total and (self.final or stage in self.printed)
        if end:
            self.last = now
            self.printed.add(stage)
            self.stream.write(f"qcshape: {stage} {done}/{total}\n")
            self.stream.flush()
        elif now - self.last >= LINE_EVERY:
            self.last = now
            self.printed.add(stage)
            self.stream.write(self._line(stage, done, total, now) + "\n")
            self.stream.flush()

    def close(self):
        # Solver iterations end when the solver converges: their last count, if lines of them
        # were printed (or with ``final``).
        if "iterations" in self.counts and (self.final or "iterations" in self.printed):
            done, _ = self.counts["iterations"]
            took = _duration(time.monotonic() - self.began["iterations"])
            # Also after Ctrl-C: the count where the solver stopped, not "done".
            self.stream.write(f"qcshape: iterations {done} in {took}\n")
            self.stream.flush()
