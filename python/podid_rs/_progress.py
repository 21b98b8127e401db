"""A tiny progress line on stderr for long runs (no dependency on tqdm)."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """Step counter ``[i/N] label (elapsed)`` written to a stream (stderr by default).

    On a terminal the line is redrawn in place with a bar; elsewhere (pipes, logs,
    CI) one plain line is printed per step. ``enabled=False`` prints nothing.
    Call :meth:`step` as each step starts and :meth:`close` at the end.
    """

    def __init__(
        self, total: int, enabled: bool = True, stream: TextIO | None = None, width: int = 24
    ) -> None:
        self.total = max(int(total), 1)
        self.enabled = bool(enabled)
        self.stream = sys.stderr if stream is None else stream
        self.width = width
        self.count = 0
        self.start = time.perf_counter()
        isatty = getattr(self.stream, "isatty", None)
        self.tty = bool(isatty and isatty())

    def step(self, label: str) -> None:
        """Announce the start of the next step."""
        self.count += 1
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        head = f"[{self.count}/{self.total}]"
        if self.tty:
            done = round(self.width * (self.count - 1) / self.total)
            bar = "#" * done + "-" * (self.width - done)
            self.stream.write(f"\r\033[K{head} |{bar}| {elapsed:6.1f} s  {label}")
        else:
            self.stream.write(f"{head} {elapsed:6.1f} s  {label}\n")
        self.stream.flush()

    def close(self) -> None:
        """Finish the line (terminal) and report the total time."""
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        if self.tty:
            head, bar = f"[{self.total}/{self.total}]", "#" * self.width
            self.stream.write(f"\r\033[K{head} |{bar}| {elapsed:6.1f} s  done\n")
        else:
            self.stream.write(f"done in {elapsed:.1f} s\n")
        self.stream.flush()
