"""Progress that tells time: one helper for every command that runs for more than a moment.

Library code reports through a :data:`Progress` callback, called with lines of text, and counts
what it can count through :func:`counter`. A plain callback (a library user's) hears a count as
text redrawn in place (a line starting with a carriage return); a :class:`Meter` (what every
``azgym`` command passes) draws it with tqdm instead: in a terminal a bar with the rate and the
time left, redrawn in place and cleared when done, so that no characters are left behind; when
its stream is not a terminal (a pipe, a CI log), a plain line at least every :data:`EVERY`
seconds and one at the end, each with done/total, the rate and the time left. Lines go to
standard output, as a command's other lines do; counts to standard error, as tqdm's bars do.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from types import TracebackType
from typing import TextIO

from tqdm import tqdm

__all__ = ["EVERY", "Count", "Meter", "Progress", "counter"]

Progress = Callable[[str], None]
"""Called with text as a run advances; text starting with a carriage return redraws the line."""

EVERY = 4.0
"""Seconds between two lines of a count when its stream is not a terminal: under 5, so that a
busy machine, waking the timer late, still shows a line at least every 5 s."""

_PLAIN = "{desc}: {n_fmt}/{total_fmt} {unit} [{elapsed}<{remaining}, {rate_fmt}]"
"""A count as one plain line: no bar characters, for a pipe or a log."""


class Count:
    """A count of ``total`` things reported through a plain :data:`Progress` callback.

    Called with the number done; a change redraws ``[####....] done/total`` in place (text
    starting with a carriage return). A context manager, as :meth:`Meter.count`'s counts are.
    """

    def __init__(self, say: Progress, label: str, total: int) -> None:
        self.say, self.label, self.total = say, label, total
        self.shown = -1

    def __call__(self, done: int) -> None:
        """Report ``done`` things finished."""
        if done != self.shown:
            self.shown = done
            filled = done * 20 // max(self.total, 1)
            self.say(f"\r  {self.label:<20} [{'#' * filled}{'.' * (20 - filled)}] "
                     f"{done}/{self.total}")

    def close(self) -> None:
        """Nothing to clear: the caller's next line follows."""

    def __enter__(self) -> Count:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.close()


def counter(progress: Progress | None, label: str, total: int, unit: str = "frames") -> Count:
    """A count of ``total`` ``unit`` for ``label``, reported through ``progress``.

    A :class:`Meter` draws it (a bar, or timed lines); any other callback hears text redrawn
    in place; None hears nothing. Use it as a context manager: leaving it ends the count.
    """
    if isinstance(progress, Meter):
        return progress.count(label, total, unit)
    return Count(progress or (lambda _text: None), label, total)


class _Drawn(Count):
    """A count a :class:`Meter` draws: a tqdm bar in a terminal, timed plain lines otherwise."""

    def __init__(self, meter: Meter, label: str, total: int, unit: str) -> None:
        super().__init__(meter, label, total)
        self.meter = meter
        self.bar = tqdm(total=total, desc=f"  {label}", unit=unit, file=meter.stream,
                        leave=False, mininterval=0.2, dynamic_ncols=True,
                        disable=not meter.terminal)
        self.unit, self.begun, self.said = unit, meter.clock(), meter.clock()
        self.done, self.closed = 0, False

    def __call__(self, done: int) -> None:
        """Move the count to ``done``: the bar follows; a plain line if one is due."""
        with self.meter.lock:
            if self.closed or done == self.done:
                return
            if self.meter.terminal:
                self.bar.update(done - self.done)
            self.done = done
        self.tick()

    def tick(self) -> None:
        """Keep time: redraw the bar (its clock moves), or write a line if one is due."""
        with self.meter.lock:
            if self.closed:
                return
            if self.meter.terminal:
                self.bar.refresh()
            elif self.meter.clock() - self.said >= EVERY:
                self._line()

    def close(self) -> None:
        """End the count: the bar is cleared; a last plain line is written when piped."""
        with self.meter.lock:
            if self.closed:
                return
            self.closed = True
            self.bar.close()
            if not self.meter.terminal:
                self._line()
        self.meter.ended(self)

    def _line(self) -> None:
        """The count as one plain line (with the lock held)."""
        self.said = self.meter.clock()
        text = tqdm.format_meter(self.done, self.total, self.said - self.begun,
                                 prefix=f"  {self.label}", unit=self.unit, bar_format=_PLAIN)
        print(text, file=self.meter.stream, flush=True)


class Meter:
    """Progress shown to a person: lines as they come, counts drawn with the time they take.

    A :data:`Progress` callback (called with a line) with :meth:`count` beside it, which
    :func:`counter` uses. While a count is open a thread keeps its time (a bar redrawn in a
    terminal, a line every :data:`EVERY` seconds otherwise) even when the count does not move.

    Args:
        stream: Where counts are drawn (default: standard error).
        lines: Where lines are written (default: standard output).
        terminal: Whether ``stream`` redraws in place (default: whether it is a terminal).
        clock: Seconds, monotonic (a fake clock in tests).
        ticking: Whether a thread keeps an open count's time (off in tests that tick).
    """

    def __init__(self, stream: TextIO | None = None, lines: TextIO | None = None, *,
                 terminal: bool | None = None, clock: Callable[[], float] = time.monotonic,
                 ticking: bool = True) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.lines = lines
        self.terminal = self.stream.isatty() if terminal is None else terminal
        self.clock, self.ticking = clock, ticking
        self.lock = threading.RLock()
        self.open: _Drawn | None = None
        self.stop = threading.Event()

    def __call__(self, text: str) -> None:
        """Write a line (a line drawn as a bar elsewhere is cleared first and redrawn after)."""
        out = self.lines if self.lines is not None else sys.stdout
        with self.lock:
            bar = self.open.bar if self.open is not None and self.terminal else None
            if bar is not None:
                bar.clear()
            print(text.lstrip("\r"), file=out, flush=True)
            if bar is not None:
                bar.refresh()

    def count(self, label: str, total: int, unit: str = "frames") -> Count:
        """Open a count of ``total`` ``unit`` (ending any still open): a context manager."""
        if self.open is not None:
            self.open.close()
        drawn = self.open = _Drawn(self, label, total, unit)
        if self.ticking:
            self.stop.clear()
            threading.Thread(target=self._keep_time, args=(drawn,), daemon=True).start()
        return drawn

    def ended(self, drawn: _Drawn) -> None:
        """A count has closed: its thread stops."""
        with self.lock:
            if self.open is drawn:
                self.open = None
                self.stop.set()

    def _keep_time(self, drawn: _Drawn) -> None:
        """The thread of an open count: a tick every half second until it closes."""
        while not self.stop.wait(0.5) and not drawn.closed:
            drawn.tick()

    def __enter__(self) -> Meter:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if self.open is not None:
            self.open.close()
