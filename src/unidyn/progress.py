"""Progress of a long computation, the same for every job that unidyn runs (the batch
engine's calls, a bdsim run, a sweep, the paper's experiment): on a terminal a tqdm
bar; off a terminal (a log file, a pipe, a job scheduler) a plain line on stderr when
a tenth more of the work is done or :data:`EVERY` seconds have passed, whichever
comes first, each with the work done of the total, the time elapsed and an estimate
of the time left::

    unidyn batch: 1,200 of 3,000 samples (40 %), 12 s elapsed, about 18 s left

A job that ends within :data:`QUIET` seconds prints nothing; one that has printed a
line ends with one saying how much it did and how long it took."""

from __future__ import annotations

import math
import sys
import time

__all__ = ["Progress", "duration"]

#: Seconds between two lines off a terminal, at most (unless the work is done sooner).
EVERY = 5.0
#: A line off a terminal for every this fraction of the work.
STEP = 0.1
#: Seconds from the start during which nothing is printed off a terminal: a job that
#: ends sooner stays silent.
QUIET = 1.0


def duration(seconds: float) -> str:
    """``seconds`` for a reader: "under 1 s", "8 s", "3 min 20 s", "2 h 5 min"."""
    s = max(0, round(seconds))
    if seconds < 1:
        return "under 1 s"
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60} s"
    return f"{s // 3600} h {s % 3600 // 60} min"


class Progress:
    """``progress``: ``None`` (shown when ``show``: a tqdm bar when ``stream`` is a
    terminal, plain lines otherwise), ``True`` (shown), ``False`` (nothing) or a
    callable ``f(done, total)``, called at every advance. ``total`` may grow while it
    runs (:meth:`grow`); ``unit`` names what is counted ("sample", "point");
    ``initial`` is the part done before (a resumed sweep's points); ``leave`` keeps
    the bar on the terminal once closed. ``stream`` is stderr by default, ``clock``
    :func:`time.monotonic` (a test passes its own)."""

    def __init__(self, progress, total: float, show: bool = True, desc: str = "",
                 unit: str = "sample", initial: float = 0, leave: bool = False,
                 stream=None, clock=None):
        self.f, self.bar, self.lines = None, None, False
        self.done, self.total, self.unit, self.desc = initial, total, unit, desc or "unidyn"
        self.stream = sys.stderr if stream is None else stream
        self.clock = time.monotonic if clock is None else clock
        self.start = self.last = self.clock()
        self.initial, self.printed = initial, False
        self.mark = self._next_mark()
        if callable(progress) and not isinstance(progress, bool):
            self.f = progress
        elif progress is True or (progress is None and show):
            if _is_terminal(self.stream):
                from tqdm import tqdm
                self.bar = tqdm(total=total, initial=round(initial), unit=unit, desc=desc,
                                leave=leave, file=self.stream, mininterval=0.5,
                                dynamic_ncols=True)
            else:
                self.lines = True

    def advance(self, n: float):
        """``n`` more units of the work done."""
        self.done += n
        if self.f is not None:
            self.f(self.done, self.total)
        if self.bar is not None:  # whole units on the bar, whatever the fractions given
            self.bar.update(round(self.done) - self.bar.n)
        if self.lines:
            now = self.clock()
            if now - self.start >= QUIET and (now - self.last >= EVERY
                                               or self.done >= self.mark):
                self._line(now)

    def to(self, done: float):
        """Move forward to ``done`` units of the work (never back)."""
        if done > self.done:
            self.advance(done - self.done)

    def grow(self, n: float):
        """The work is ``n`` units larger than first thought."""
        self.total += n
        if self.bar is not None:
            self.bar.total = self.total
        self.mark = self._next_mark()

    def close(self, finished: bool = True):
        """The bar removed; off a terminal, once lines were printed and the work
        ``finished``, a last line with how much was done and how long it took."""
        if self.bar is not None:
            self.bar.close()
        if self.lines and self.printed and finished:
            plural = "" if round(self.done) == 1 else "s"
            self._say(f"{self.desc}: {self.done:,.0f} {self.unit}{plural} in "
                      f"{duration(self.clock() - self.start)}")

    def __enter__(self):
        return self

    def __exit__(self, kind, *exc):
        self.close(finished=kind is None)

    def _next_mark(self) -> float:
        """The next tenth of the total past what is done."""
        if self.total <= 0:
            return float("inf")
        parts = round(1 / STEP)
        return (int(self.done * parts / self.total + 1e-9) + 1) * self.total / parts

    def _line(self, now: float):
        elapsed = now - self.start
        ran = self.done - self.initial
        whole = math.floor(self.done + 1e-9)  # points wholly done, of a part-done chunk
        percent = math.floor(100 * min(self.done / self.total, 1)) if self.total > 0 else 100
        text = (f"{self.desc}: {whole:,} of {self.total:,.0f} {self.unit}s ({percent} %), "
                f"{duration(elapsed)} elapsed")
        if 0 < ran and self.done < self.total:
            left = elapsed * (self.total - self.done) / ran
            text += f", {'' if left < 1 else 'about '}{duration(left)} left"
        self._say(text)
        self.last, self.mark, self.printed = now, self._next_mark(), True

    def _say(self, text: str):
        print(text, file=self.stream, flush=True)


def _is_terminal(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # no isatty, or closed
        return False
