"""Running an exported ONNX policy: ``OnnxGreedyPolicy``, argmax of the Q-values of an
onnxruntime session, which refuses (CheckpointError naming the file) a runtime failure, an
output of the wrong shape or a NaN or inf Q-value at every inference: no action is ever
chosen from values that are not numbers."""

from __future__ import annotations

from typing import Any

import numpy as np

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.onnx_description import INPUT_NAME, OUTPUT_NAME
from d3dwa_bullet.learning.agents.onnx_graph import GraphCost

ONE_LINE = 300
"""Characters of a library's own message kept in ours."""


class OnnxGreedyPolicy:
    """argmax_a Q(s, a) of an onnxruntime session over an exported policy.

    ``__call__(obs)``: one observation (obs_dim,) -> the action index (int).
    ``q_values(obs)``: (B, obs_dim) -> (B, n_actions) float32 Q-values, run in batches of
    ``cost.rows_per_run()`` so that no run holds more than the graph check allows.
    Either raises CheckpointError (naming ``where``) if the runtime fails or the Q-values
    are not (B, n_actions) finite numbers.
    """

    def __init__(
        self, session: Any, obs_dim: int, n_actions: int, where: str, cost: GraphCost
    ) -> None:
        self._session = session
        self.obs_dim = int(obs_dim)
        self.n_actions = int(n_actions)
        self.where = where
        self._rows = cost.rows_per_run()
        self._input = np.empty((1, self.obs_dim), dtype=np.float32)
        self._outputs = [OUTPUT_NAME]

    def __call__(self, obs: np.ndarray) -> int:
        self._input[0] = obs  # raises on a wrong shape; casts to float32
        return int(self._run(self._input)[0].argmax())

    def q_values(self, obs: np.ndarray) -> np.ndarray:
        batch = np.ascontiguousarray(obs, dtype=np.float32)
        if batch.ndim != 2 or batch.shape[1] != self.obs_dim:
            raise ValueError(
                f"q_values: expected (B, {self.obs_dim}) observations, got {batch.shape}"
            )
        if len(batch) <= self._rows:
            return self._run(batch)
        rows = self._rows
        return np.concatenate([self._run(batch[i : i + rows]) for i in range(0, len(batch), rows)])

    def _run(self, batch: np.ndarray) -> np.ndarray:
        try:
            q = np.asarray(self._session.run(self._outputs, {INPUT_NAME: batch})[0])
        except Exception as err:  # onnxruntime raises its own types (Fail, RuntimeException)
            reason = " ".join(str(err).split())[:ONE_LINE]
            raise CheckpointError(
                f"{self.where}: the policy failed to run on {len(batch)} observation(s) "
                f"({type(err).__name__}: {reason})"
            ) from err
        if q.shape != (len(batch), self.n_actions) or q.dtype != np.float32:
            raise CheckpointError(
                f"{self.where}: the policy returned {q.dtype} {q.shape} for {len(batch)} "
                f"observation(s), not float32 ({len(batch)}, {self.n_actions}) Q-values"
            )
        finite = np.isfinite(q).all(axis=1)
        if not finite.all():
            row = int(np.flatnonzero(~finite)[0])
            shown = np.array2string(batch[row], precision=3, max_line_width=10**6)
            raise CheckpointError(
                f"{self.where}: the policy's Q-values are NaN or inf for observation {shown}; "
                "refusing to choose an action from them"
            )
        return q
