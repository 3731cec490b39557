"""Ctrl-C during training: the first SIGINT asks the loop to stop at the next step boundary
(it then saves ``latest`` and returns "interrupted"); a second one aborts at once."""

from __future__ import annotations

import signal
from typing import Any


class StopOnInterrupt:
    """SIGINT -> a flag checked at step boundaries; a second SIGINT raises at once."""

    def __init__(self) -> None:
        self.requested = False
        self._previous: Any = None

    def __enter__(self) -> StopOnInterrupt:
        try:
            self._previous = signal.signal(signal.SIGINT, self._handle)
        except ValueError:  # not the main thread: no handler, Ctrl-C behaves as usual
            self._previous = None
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def __exit__(self, *exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
