"""n-step transitions for the D3QN's replay (``D3QNConfig.n_step``; docs/design/agent.md#n-step-returns).

Beyond the paper, off by default (``n_step: 1`` stores every transition as it comes, the
paper's one-step Double DQN target). With ``n_step: n > 1`` each env's last transitions wait
in a window; once it holds ``n`` of them the first leaves as one stored transition::

    (s_t, a_t, r_t + gamma r_{t+1} + ... + gamma^(n-1) r_{t+n-1}, s_{t+n}, done_{t+n}), gamma^n

where ``gamma^n`` is the discount of the bootstrap ``Q_target(s_{t+n}, .)``. When an
episode ends the whole window is flushed, each start with the k < n rewards left and
``gamma^k``: a goal or collision stays terminal (no bootstrap), a time limit stays
non-terminal. So the target maximises over actions once per n steps of real rewards
instead of once per step. The windows are per env (transitions of several envs
interleave) and are part of the resumable training state.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from typing import Any

import numpy as np

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.replay import Transition

MAX_N_STEP = 600
"""The longest n-step target, for both learners (``D3QNConfig.n_step``,
``DQDWAConfig.n_step``): a 60 s episode at 10 Hz has at most 600 decisions, so a longer
window only ever folds whole episodes."""
N_STEP_RULE = f"an integer in [1, {MAX_N_STEP}]"
"""What both configs' ``n_step`` check says when it fails."""


def is_n_step(value: object) -> bool:
    """Whether ``value`` is an n-step length: a whole number in [1, MAX_N_STEP]."""
    return isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= MAX_N_STEP


class NStepWindows:
    """One window of pending transitions per env; ``push`` returns what is ready to store."""

    def __init__(self, n: int, gamma: float) -> None:
        self.n = int(n)
        self.gamma = float(gamma)
        self._windows: dict[int, deque[Transition]] = {}

    def push(self, transition: Transition, env: int = 0) -> list[tuple[Transition, float]]:
        """Add env ``env``'s next transition; the (n-step transition, bootstrap discount)
        pairs it completes, oldest first (none, one, or the whole window at an episode end)."""
        window = self._windows.setdefault(int(env), deque())
        window.append(transition)
        ready: list[tuple[Transition, float]] = []
        if transition.terminated or transition.truncated:
            while window:
                ready.append(self._fold(window))
                window.popleft()
        elif len(window) == self.n:
            ready.append(self._fold(window))
            window.popleft()
        return ready

    def _fold(self, window: deque[Transition]) -> tuple[Transition, float]:
        first, last = window[0], window[-1]
        ret = 0.0
        for k, t in enumerate(window):
            ret += self.gamma**k * t.reward
        folded = Transition(
            first.obs, first.action, ret, last.next_obs, last.terminated, last.truncated
        )
        return folded, self.gamma ** len(window)

    def pending(self) -> int:
        """Transitions waiting in all windows."""
        return sum(len(w) for w in self._windows.values())

    def state(self) -> dict[str, Any]:
        """JSON-ready windows (float32 observations round-trip exactly through float)."""
        return {
            str(env): [
                [
                    [float(x) for x in t.obs],
                    int(t.action),
                    float(t.reward),
                    [float(x) for x in t.next_obs],
                    bool(t.terminated),
                    bool(t.truncated),
                ]
                for t in window
            ]
            for env, window in self._windows.items()
            if window
        }

    def load_state(self, state: Mapping[str, Any], where: str) -> None:
        """Inverse of ``state``; CheckpointError naming ``where`` if it does not parse."""
        windows: dict[int, deque[Transition]] = {}
        try:
            for env, rows in state.items():
                windows[int(env)] = deque(
                    Transition(np.asarray(o, dtype=np.float32), int(a), float(r),
                               np.asarray(o2, dtype=np.float32), bool(d), bool(tr))
                    for o, a, r, o2, d, tr in rows
                )  # fmt: skip
                if len(windows[int(env)]) >= self.n:
                    raise ValueError(f"env {env} holds {len(rows)} >= n_step {self.n}")
        except (TypeError, ValueError, AttributeError) as err:
            raise CheckpointError(f"{where}: cannot restore the n-step windows ({err})") from err
        self._windows = windows
