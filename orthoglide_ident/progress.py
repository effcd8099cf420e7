"""A progress line for long work (``excite design``, ``import``, ``identify``): how far, and the
time left.

Shown on a terminal only (standard error a tty), rewritten in place at most every
REDRAW_S seconds and erased when done; nothing at all when standard error is piped or redirected,
or after ``set_quiet(True)`` (``-q``). The time left is the elapsed time per unit of work so far
times the units left (the caller may revise the total as it learns it).

Work in stages (``identify``) takes a :class:`Stages` from the command's edge: the numerical core
calls its ``progress`` argument (None: silent, the default) with the stage and how far it is,
never printing itself. A log line written meanwhile (``StageAwareHandler``) erases the progress
line first and draws it again below itself.
"""
from __future__ import annotations

import logging
import sys
import time
from typing import TextIO

REDRAW_S = 0.2  # s between redraws
_state: dict = {"quiet": False, "line": None}  # the line drawn now, if any


def set_quiet(quiet: bool) -> None:
    """No progress lines (``-q``) for the rest of the process."""
    _state["quiet"] = bool(quiet)


def shown(stream: TextIO | None = None) -> bool:
    """Whether a progress line would be drawn on ``stream`` (default stderr)."""
    stream = stream if stream is not None else sys.stderr
    try:
        return not _state["quiet"] and stream.isatty()
    except (AttributeError, ValueError):  # closed or not a file
        return False


def duration_text(seconds: float) -> str:
    """``42 s``, ``3 min 20 s``, ``1 h 05 min``."""
    s = max(0, int(round(seconds)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


def _number(x: float) -> str:
    return f"{x:.0f}" if abs(x) >= 100 else f"{x:.3g}"


class ProgressLine:
    """``what: 42 % (done/total unit), 1 min 05 s left`` on a terminal; see the module docstring.

    ``clock`` (seconds, monotonic) is for tests."""

    def __init__(self, what: str, total: float, unit: str = "", stream: TextIO | None = None,
                 clock=time.monotonic):
        self.what, self.total, self.unit = what, float(total), unit
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = shown(self.stream)
        self.clock = clock
        self.t0 = clock()
        self.done = 0.0
        self._drawn = -float("inf")
        self._width = 0

    def update(self, done: float, total: float | None = None) -> None:
        """``done`` units of work so far (of ``total``, when it is revised)."""
        self.done = float(done)
        if total is not None:
            self.total = float(total)
        now = self.clock()
        if not self.enabled or now - self._drawn < REDRAW_S:
            return
        self._drawn = now
        self._draw(self.text(now))

    def redraw(self) -> None:
        """Draw the line now (after a message printed above it)."""
        if self.enabled:
            self._drawn = self.clock()
            self._draw(self.text(self._drawn))

    def text(self, now: float | None = None) -> str:
        now = self.clock() if now is None else now
        if self.total <= 0:  # a stage with nothing to count: its name
            return f"{self.what} ..."
        frac = min(1.0, self.done / self.total) if self.total > 0 else 0.0
        left = ""
        if 0 < self.done < self.total:
            left = f", {duration_text((now - self.t0) / self.done * (self.total - self.done))} left"
        unit = f" {self.unit}" if self.unit else ""
        return (f"{self.what}: {100 * frac:.0f} % ({_number(self.done)}/{_number(self.total)}"
                f"{unit})"
                f"{left}")

    def _draw(self, text: str) -> None:
        pad = " " * max(0, self._width - len(text))
        self.stream.write("\r" + text + pad)
        self.stream.flush()
        self._width = len(text)
        _state["line"] = self

    def close(self) -> None:
        """Erase the line (the caller says the outcome on a line of its own)."""
        if self.enabled and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self.stream.flush()
            self._width = 0
        self._drawn = -float("inf")  # drawn again at the next update
        if _state["line"] is self:
            _state["line"] = None

    def __enter__(self) -> ProgressLine:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def clear_line() -> ProgressLine | None:
    """Erase the progress line drawn now, if any (before a message of its own line); that line."""
    line = _state["line"]
    if line is not None:
        line.close()
    return line


class StageAwareHandler(logging.StreamHandler):
    """A log handler that erases the progress line before its message and draws it again
    below."""

    def emit(self, record: logging.LogRecord) -> None:
        line = clear_line()
        super().emit(record)
        if line is not None:
            line.redraw()


class Stages:
    """``stages(what, done, total, unit)``: one :class:`ProgressLine` per stage of a long
    computation, the previous erased when the stage changes (``total`` 0: the stage's name
    alone); a stage taken up again (between two records' own stages) keeps its start, so its time
    left stays an estimate over all its work. Passed as ``progress`` from the command's edge;
    ``clock`` is for tests."""

    def __init__(self, stream: TextIO | None = None, clock=time.monotonic):
        self.stream, self.clock = stream, clock
        self.line: ProgressLine | None = None
        self._lines: dict[str, ProgressLine] = {}

    def __call__(self, what: str, done: float = 0.0, total: float = 0.0,
                 unit: str = "") -> None:
        if self.line is None or self.line.what != what:
            self.close()
            self.line = self._lines.get(what) or ProgressLine(what, total, unit, self.stream,
                                                              self.clock)
            self._lines[what] = self.line
        self.line.update(done, total)

    def close(self) -> None:
        if self.line is not None:
            self.line.close()
            self.line = None

    def __enter__(self) -> Stages:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
