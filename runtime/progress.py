"""A progress bar on stderr for runs longer than about a second; silent when stderr is not a
terminal (pipes, files, CI logs)."""

from __future__ import annotations

import sys
import time

DELAY = 1.0  # s of wall time before the bar appears
INTERVAL = 0.1  # s between redraws
WIDTH = 30


class Progress:
    """`update(t)` with the simulated time (s); `close()` clears the bar."""

    def __init__(self, t_end: float, enabled: bool = True, stream=None):
        self.stream = sys.stderr if stream is None else stream
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = bool(enabled and isatty is not None and isatty())
        self.t_end = t_end
        self.start = time.monotonic()
        self.last = 0.0
        self.shown = False

    def update(self, t: float) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self.start < DELAY or now - self.last < INTERVAL:
            return
        self.last = now
        fraction = min(max(t / self.t_end, 0.0), 1.0)
        filled = int(round(WIDTH * fraction))
        bar = "#" * filled + "-" * (WIDTH - filled)
        self.stream.write(f"\r[{bar}] {100 * fraction:5.1f}%  t = {t:.4g} s ")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            self.stream.write("\r" + " " * (WIDTH + 40) + "\r")
            self.stream.flush()
            self.shown = False
