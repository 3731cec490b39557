"""Greedy policies for evaluation: observation (4 + K,) -> action index, fast and torch-free.

A D3QN's greedy action is argmax_a Q(s, a) = argmax_a A(s, a), because V(s) and the mean
advantage are the same for every action; the policy therefore evaluates only the shared
MLP and the advantage head, as float32 numpy matmuls into preallocated buffers (a single
12-d observation through torch costs several times more in call overhead than in maths).
It agrees with ``D3QNAgent.act(obs, greedy=True)`` except where two Q-values tie to within
float32 rounding.
"""

from __future__ import annotations

import os
from typing import Any, Protocol

import numpy as np

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.checkpoint import Agent, load_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent
from d3dwa_bullet.learning.agents.network import DuelingQNetwork
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import observation_layout


class Policy(Protocol):
    """A greedy controller: one observation (4 + K,) float -> one action index."""

    def __call__(self, obs: np.ndarray) -> int: ...


class DuelingGreedyPolicy:
    """argmax of the advantage stream of a DuelingQNetwork, in numpy (a snapshot of its weights).

    Like the ONNX runner, it never chooses from values that are not numbers: an advantage
    that comes out NaN or inf (a NaN in the observation, weights that overflow on it) is a
    CheckpointError naming ``where`` (the checkpoint) and the observation."""

    def __init__(self, network: DuelingQNetwork, where: str = "the policy") -> None:
        self.where = where
        linears = [m for m in network.body if hasattr(m, "weight")] + [network.advantage]
        self._layers = [
            (
                np.ascontiguousarray(m.weight.detach().cpu().numpy().T, dtype=np.float32),
                m.bias.detach().cpu().numpy().astype(np.float32),
            )
            for m in linears
        ]
        self._buffers = [np.empty(w.shape[1], dtype=np.float32) for w, _ in self._layers]
        self._input = np.empty(network.obs_dim, dtype=np.float32)
        self.obs_dim = network.obs_dim

    def __call__(self, obs: np.ndarray) -> int:
        x = self._input
        x[...] = obs  # raises on a wrong shape; casts to float32
        last = len(self._layers) - 1
        for i, ((w, b), out) in enumerate(zip(self._layers, self._buffers, strict=True)):
            np.dot(x, w, out=out)
            out += b
            if i < last:
                np.maximum(out, 0.0, out=out)
            x = out
        if not np.isfinite(x).all():
            shown = np.array2string(self._input, precision=3, max_line_width=10**6)
            raise CheckpointError(
                f"{self.where}: the policy's Q-values are NaN or inf for observation {shown}; "
                "refusing to choose an action from them"
            )
        return int(x.argmax())


class TabularGreedyPolicy:
    """argmax over the Q-table row of the discretised observation (a snapshot of the table)."""

    def __init__(self, agent: DQDWAAgent) -> None:
        self._discretisation = agent.discretisation
        self._greedy = np.argmax(agent.table, axis=1)  # ties -> lowest index, as DQDWAAgent.act

    def __call__(self, obs: np.ndarray) -> int:
        return int(self._greedy[self._discretisation.state_index(obs)])


def greedy_policy(agent: Agent, where: str = "the policy") -> Policy:
    """A greedy snapshot of an in-memory agent (later training does not change it); where:
    what a message names (the checkpoint it came from)."""
    if isinstance(agent, D3QNAgent):
        return DuelingGreedyPolicy(agent.online, where)
    if isinstance(agent, DQDWAAgent):
        return TabularGreedyPolicy(agent)
    raise TypeError(f"greedy_policy: unsupported agent type {type(agent).__name__}")


def load_policy(
    path: str | os.PathLike[str],
    *,
    expected_actions: ActionSet | None = None,
    expected_observation: tuple[str, str] = ("paper", "the caller"),
) -> tuple[Policy, ActionSet, dict[str, Any]]:
    """Greedy policy of a checkpoint directory of either agent: (policy, action set, meta).

    expected_observation: (kind, who feeds it): the observation kind the policy must read,
    and, for the message, the method that will feed it. Raises CheckpointError as
    ``load_checkpoint`` does (a policy of the other kind: one line naming both).
    """
    kind, reader = expected_observation
    agent, meta = load_checkpoint(
        path,
        expected_actions=expected_actions,
        expected_layout=observation_layout(kind),
        reader=reader,
    )
    try:
        policy = greedy_policy(agent, str(path))
    except TypeError as err:  # pragma: no cover - load_checkpoint only builds known agents
        raise CheckpointError(f"{path}: {err}") from err
    return policy, agent.actions, meta


def all_q_values(agent: Agent, obs: np.ndarray) -> np.ndarray:
    """The agent's Q(s_t, a) for every action, for a sequence of observations (T, obs_dim):
    (T, n_actions), the online network's for a D3QN, the table's rows for DQDWA."""
    if isinstance(agent, D3QNAgent):
        return agent.q_values(np.asarray(obs, dtype=np.float32)).astype(np.float64)
    if isinstance(agent, DQDWAAgent):
        states = [agent.discretisation.state_index(o) for o in obs]
        return agent.table[states].astype(np.float64)
    raise TypeError(f"all_q_values: unsupported agent type {type(agent).__name__}")


def taken_q_values(agent: Agent, obs: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """The agent's own Q(s_t, a_t) for a sequence of observations (T, obs_dim) and the
    actions taken in them (T,) (:func:`all_q_values` at the taken actions)."""
    actions = np.asarray(actions, dtype=np.int64)
    return all_q_values(agent, obs)[np.arange(len(actions)), actions]
