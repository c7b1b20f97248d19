"""Progress of long calls (the ``progress=`` keyword): the extension counts finished items on its
worker threads and, from the calling thread (GIL held, every 50 ms), hands the counts to the
reporter made here.

- ``progress=None`` (the default): a bar on a terminal or in Jupyter (tqdm's, when tqdm is
  installed; otherwise one ``\\r``-updated line), and off a terminal (logs, pipes) plain lines at
  most every 10 s, none for a call shorter than that.
- ``progress=True``: as None, but off a terminal a plain line also when a stage ends.
- ``progress=False``: nothing.
- a callable ``progress(stage, done, total)``: called with the stage ("interpolating",
  "transferring", "pairs") and its counts instead of any display; an exception it raises stops
  the call and propagates.

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
            self.bar = self.tqdm(total=total, desc=f"qcshape: {stage}", file=self.stream, leave=True)
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
        self.stream.write(f"\rqcshape: {stage} {done}/{total}   ")
        self.open = done < total
        if not self.open:
            self.stream.write("\n")
        self.stream.flush()

    def close(self):
        if self.open:
            self.stream.write("\n")
            self.stream.flush()
            self.open = False


class _Plain:
    """Plain lines for logs: at most one every LINE_EVERY seconds (the first after that long), and
    a stage's last count when a line of it was printed (or always, with ``final``)."""

    def __init__(self, stream, final):
        self.stream = stream
        self.final = final
        self.start = time.monotonic()
        self.last = self.start
        self.printed = set()

    def update(self, stage, done, total):
        now = time.monotonic()
        end = done == total and (self.final or stage in self.printed)
        if end or now - self.last >= LINE_EVERY:
            self.last = now
            self.printed.add(stage)
            self.stream.write(f"qcshape: {stage} {done}/{total}\n")
            self.stream.flush()

    def close(self):
        pass
