"""Greedy policies for evaluation: observation (4 + K,) -> action index, fast and torch-free.

A D3QN's runs in numpy (:class:`~d3dwa_bullet.learning.agents.numpy_policy.DuelingGreedyPolicy`:
the shared MLP and the advantage head only). It agrees with ``D3QNAgent.act(obs, greedy=True)``
except where two Q-values tie to within float32 rounding.
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
from d3dwa_bullet.learning.agents.numpy_policy import DuelingGreedyPolicy, greedy_layers
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import observation_layout


class Policy(Protocol):
    """A greedy controller: one observation (4 + K,) float -> one action index."""

    def __call__(self, obs: np.ndarray) -> int: ...


class TabularGreedyPolicy:
    """argmax over the Q-table row of the discretised observation (a snapshot of the table)."""

    def __init__(self, agent: DQDWAAgent) -> None:
        self._discretisation = agent.discretisation
        self._greedy = np.argmax(agent.table, axis=1)  # ties -> lowest index, as DQDWAAgent.act

    def __call__(self, obs: np.ndarray) -> int:
        return int(self._greedy[self._discretisation.state_index(obs)])


def network_policy(network: DuelingQNetwork, where: str = "the policy") -> DuelingGreedyPolicy:
    """The numpy greedy policy of a dueling network: a snapshot of its weights."""
    state = {k: v.detach().cpu().numpy() for k, v in network.state_dict().items()}
    return DuelingGreedyPolicy(greedy_layers(state, network.hidden), network.obs_dim, where)


def greedy_policy(agent: Agent, where: str = "the policy") -> Policy:
    """A greedy snapshot of an in-memory agent (later training does not change it); where:
    what a message names (the checkpoint it came from)."""
    if isinstance(agent, D3QNAgent):
        return network_policy(agent.online, where)
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
