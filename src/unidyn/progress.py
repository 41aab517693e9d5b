"""Progress of a long computation in samples: a tqdm bar on a terminal, a user's
callable, or nothing (the batch engine's calls)."""

from __future__ import annotations

import sys

__all__ = ["Progress"]


class Progress:
    """``progress``: ``None`` (a tqdm bar on stderr when ``show`` and stderr is a
    terminal), ``True`` (a bar), ``False`` (nothing) or a callable ``f(done, total)``;
    ``total`` may grow while it runs (:meth:`grow`)."""

    def __init__(self, progress, total: float, show: bool = True, desc: str = ""):
        self.f, self.bar, self.done, self.total = None, None, 0, int(total)
        if callable(progress) and not isinstance(progress, bool):
            self.f = progress
        elif progress is True or (progress is None and show):
            from tqdm import tqdm
            self.bar = tqdm(total=self.total, unit="sample", desc=desc, leave=False,
                            disable=None if progress is None else False, file=sys.stderr,
                            mininterval=0.5)

    def advance(self, n: int):
        self.done += n
        if self.f is not None:
            self.f(self.done, self.total)
        if self.bar is not None:
            self.bar.update(n)

    def grow(self, n: float):
        self.total += int(n)
        if self.bar is not None:
            self.bar.total = self.total

    def close(self):
        if self.bar is not None:
            self.bar.close()
