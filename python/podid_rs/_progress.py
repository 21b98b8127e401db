"""Progress bars for long runs: tqdm on stderr, quiet off a terminal or when disabled."""

from __future__ import annotations

import sys
from typing import TextIO

from tqdm import tqdm


def progress_bar(
    total: int | None,
    *,
    enabled: bool = True,
    desc: str | None = None,
    unit: str = "it",
    stream: TextIO | None = None,
    **kwargs: object,
) -> tqdm:
    """A tqdm bar on ``stream`` (stderr at call time by default).

    Drawn only when ``enabled`` and the stream is a terminal (tqdm's
    ``disable=None``): pipes, logs and CI stay quiet.
    """
    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        file=sys.stderr if stream is None else stream,
        disable=None if enabled else True,
        dynamic_ncols=True,
        **kwargs,
    )


class Progress:
    """Named steps of a long run on a tqdm bar: call :meth:`step` as each step
    starts (its label is shown after the bar) and :meth:`close` at the end."""

    def __init__(
        self,
        total: int,
        enabled: bool = True,
        stream: TextIO | None = None,
        desc: str | None = None,
    ) -> None:
        self.total = max(int(total), 1)
        self.count = 0
        self.bar = progress_bar(self.total, enabled=enabled, desc=desc, unit="step",
                                stream=stream)

    def step(self, label: str) -> None:
        """Mark the previous step done and announce the next."""
        if self.count:
            self.bar.update(1)
        self.count += 1
        self.bar.set_postfix_str(label)

    def close(self) -> None:
        """Complete the bar and finish its line."""
        self.bar.set_postfix_str("done", refresh=False)
        self.bar.update(self.total - self.bar.n)
        self.bar.close()
