"""Ctrl-C or SIGTERM (``kill PID``, a cluster's job end) during training: the first asks the
loop to stop at the next step boundary (it then saves ``latest`` and returns "interrupted");
a second one, of either kind, aborts at once.

Handlers nest: ``train --seeds`` holds one around its loop over seeds and each seed's
training holds its own. A Ctrl-C caught by the inner one is also a request to the outer
one (the command stops before the next seed), and a request the outer one caught while the
next seed was starting is the inner one's from its start, so one Ctrl-C is never lost
between the two.
"""

from __future__ import annotations

import signal
from typing import Any


class StopOnInterrupt:
    """SIGINT or SIGTERM -> a flag checked at step boundaries; a second one raises at once."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.requested = False
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopOnInterrupt:
        try:
            self._previous = {sig: signal.signal(sig, self._handle) for sig in self.SIGNALS}
        except ValueError:  # not the main thread: no handler, Ctrl-C behaves as usual
            self._previous = {}
        outer = self._outer()
        if outer is not None and outer.requested:
            self.requested = True
        return self

    def _outer(self) -> StopOnInterrupt | None:
        """The StopOnInterrupt whose handler this one replaced, if any."""
        outer = getattr(self._previous.get(signal.SIGINT), "__self__", None)
        return outer if isinstance(outer, StopOnInterrupt) else None

    def _handle(self, signum: int, frame: Any) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        outer = self._outer()
        if outer is not None:
            outer.requested = True

    def __exit__(self, *exc: object) -> None:
        for sig, previous in self._previous.items():
            if previous is not None:
                signal.signal(sig, previous)
