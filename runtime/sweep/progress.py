"""A one-line progress bar on stderr: runs done, failures, rate, ETA. Silent off a terminal."""

from __future__ import annotations

import dataclasses
import sys
import time
from typing import TextIO


@dataclasses.dataclass(frozen=True)
class StudyProgress:
    """Passed to `on_batch` after every finished batch (already checkpointed)."""

    done: int  # runs finished, including those kept from a checkpoint
    total: int
    failed: int
    elapsed: float  # seconds since this call of run_study started


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    if seconds >= 60:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds}s"


class ProgressBar:
    def __init__(self, total: int, done: int = 0, failed: int = 0, *,
                 enabled: bool | None = None, stream: TextIO | None = None, width: int = 24):
        self.stream = stream or sys.stderr
        if enabled is None:
            try:
                enabled = self.stream.isatty()
            except (AttributeError, ValueError):
                enabled = False
        self.enabled = enabled
        self.total, self.start_done, self.width = total, done, width
        self.done, self.failed = done, failed
        self.t0 = time.perf_counter()
        self._last = 0.0

    def update(self, done: int, failed: int, force: bool = False) -> None:
        self.done, self.failed = done, failed
        now = time.perf_counter()
        if not self.enabled or (not force and now - self._last < 0.1 and done < self.total):
            return
        self._last = now
        fraction = done / self.total if self.total else 1.0
        filled = int(self.width * fraction)
        bar = "#" * filled + "-" * (self.width - filled)
        elapsed = now - self.t0
        fresh = done - self.start_done
        rate = fresh / elapsed if elapsed > 0 else 0.0
        eta = f"ETA {_duration((self.total - done) / rate)}" if rate > 0 and done < self.total \
            else ("done" if done >= self.total else "ETA --")
        text = (f"\r[{bar}] {done}/{self.total} runs, {failed} failed, {rate:.1f} runs/s, "
                f"{eta}  ")
        self.stream.write(text)
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.update(self.done, self.failed, force=True)
            self.stream.write("\n")
            self.stream.flush()
