"""DQDWA: tabular Q-learning over a hand-discretised state, the paper's baseline [10237217].

The baseline's discretisation is not public; this one reads the 12-d observation of
docs/design/observation.md#observation and keeps four features, each in a few bins (defaults of ``Discretisation``):

=================  ====  ==========================================================
feature            bins  definition
=================  ====  ==========================================================
goal bearing       5     theta_g in [-180, -60), [-60, -15), [-15, 15), [15, 60),
                         [60, 180] deg: right, front-right, ahead, front-left, left
nearest distance   3     min over sectors of l_k * d_max: [0, 0.5), [0.5, 1.2),
                         [1.2, inf) m: near, mid, far (a sector with no return is far)
nearest direction  3     side of the sector holding that minimum: right, front
                         (sector centre within +-30 deg of forward), left; ties
                         prefer front, then right
congestion         3     number of sectors closer than 1.0 m: 0-1, 2-4, 5-8:
                         open, some, crowded
=================  ====  ==========================================================

State index = ravel_multi_index((bearing, distance, direction, congestion), (5, 3, 3, 3)):
135 states x 25 weights-only actions = 3,375 table entries. Goal distance and velocities
are left out on purpose: they mostly scale the value, not which weights are best, and
every extra feature multiplies the table.

Rewards are the unscaled baseline magnitudes (``RewardParams()``, scale 1).

Two options of the learner, both inside tabular Q-learning and off by default (the defaults are
the one-step update with a constant step size):

- ``n_step: n > 1`` learns from the D3QN's n-step targets (agents/n_step.py, per env):
  ``r_t + ... + gamma^(k-1) r_{t+k-1} + gamma^k max_a Q[s_{t+k}, a]``, k <= n, no bootstrap past
  a goal or collision. With n at least the episode's length in decisions the target is the
  discounted return still to come, so no value has to travel back one state at a time through a
  table whose states alias many places.
- ``alpha_schedule: visits`` steps each entry by ``max(1 / N[s, a], alpha)``, N the updates it
  has had: the first update sets the entry to its target (no pull towards ``initial_q``), later
  ones average, and ``alpha`` is the floor that keeps tracking a changing policy.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.agents.d3qn import exponential_epsilon
from d3dwa_bullet.learning.agents.n_step import N_STEP_RULE, NStepWindows, is_n_step
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.params import ObservationParams
from d3dwa_bullet.planning.actions import ACTIONS_WEIGHTS_ONLY, ActionSet
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT

DIRECTIONS = ("right", "front", "left")
ALPHA_SCHEDULES = ("constant", "visits")


def _increasing(values: tuple[float, ...], name: str) -> tuple[float, ...]:
    out = tuple(float(v) for v in values)
    if not out or any(b <= a for a, b in zip(out, out[1:], strict=False)):
        raise ConfigError(
            f"Discretisation.{name} must be non-empty and strictly increasing, got {out!r}"
        )
    return out


@dataclass(frozen=True)
class Discretisation:
    """Bin edges of the DQDWA state (module docstring). A value v falls in bin
    ``#{edges <= v}``, i.e. bins are [e_i, e_{i+1})."""

    bearing_edges: tuple[float, ...] = tuple(math.radians(d) for d in (-60.0, -15.0, 15.0, 60.0))
    """Goal-bearing bin edges, rad (body frame, positive = left)."""
    distance_edges: tuple[float, ...] = (0.5, 1.2)
    """Nearest-obstacle distance bin edges, m."""
    front_half_angle: float = math.radians(30.0)
    """A sector whose centre lies within this angle of forward counts as 'front', rad."""
    congestion_range: float = 1.0
    """A sector reading closer than this counts towards congestion, m."""
    congestion_edges: tuple[float, ...] = (2.0, 5.0)
    """Congestion bin edges, number of sectors."""
    observation: ObservationParams = field(default_factory=ObservationParams)
    """The observation layout the state is read from."""

    def __post_init__(self) -> None:
        for name in ("bearing_edges", "distance_edges", "congestion_edges"):
            object.__setattr__(self, name, _increasing(getattr(self, name), name))
        if self.front_half_angle <= 0 or self.congestion_range <= 0:
            raise ConfigError(
                f"Discretisation: front_half_angle and congestion_range must be > 0, got "
                f"{self.front_half_angle!r}, {self.congestion_range!r}"
            )
        p = self.observation
        centres = -0.5 * p.fov + (np.arange(p.sectors) + 0.5) * (p.fov / p.sectors)
        front = np.abs(centres) < self.front_half_angle
        if not front.any():
            raise ConfigError(
                f"Discretisation.front_half_angle={self.front_half_angle!r} rad covers no sector centre"
            )
        # 0 right, 1 front, 2 left, per sector
        side = np.where(front, 1, np.where(centres < 0, 0, 2))
        object.__setattr__(self, "_sector_side", side)

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """Bins per feature: (bearing, distance, direction, congestion)."""
        return (
            len(self.bearing_edges) + 1,
            len(self.distance_edges) + 1,
            len(DIRECTIONS),
            len(self.congestion_edges) + 1,
        )

    @property
    def n_states(self) -> int:
        return int(np.prod(self.shape))

    def bins(self, obs: np.ndarray) -> tuple[int, int, int, int]:
        """The four bin indices of one observation (4 + K,), see module docstring."""
        p = self.observation
        obs = np.asarray(obs, dtype=np.float64)
        if obs.shape != (p.dim,) or not np.all(np.isfinite(obs)):
            raise ValueError(
                f"DQDWA: observation must be finite with shape ({p.dim},), got {obs!r}"
            )
        bearing = obs[1] * math.pi
        ranges = obs[4:] * p.d_max
        nearest = float(ranges.min())
        hit = self._sector_side[ranges == nearest]  # type: ignore[attr-defined]
        direction = 1 if (hit == 1).any() else (0 if (hit == 0).any() else 2)
        crowd = int(np.count_nonzero(ranges < self.congestion_range))
        return (
            int(np.searchsorted(self.bearing_edges, bearing, side="right")),
            int(np.searchsorted(self.distance_edges, nearest, side="right")),
            direction,
            int(np.searchsorted(self.congestion_edges, crowd, side="right")),
        )

    def state_index(self, obs: np.ndarray) -> int:
        """Row of the Q-table for one observation, in [0, n_states)."""
        return int(np.ravel_multi_index(self.bins(obs), self.shape))

    def describe(self, index: int) -> str:
        """Readable label of a state index, e.g. 'bearing 2/5, distance 0/3, front, congestion 1/3'."""
        b, d, s, c = np.unravel_index(int(index), self.shape)
        nb, nd, _, nc = self.shape
        return f"bearing {b}/{nb}, distance {d}/{nd}, {DIRECTIONS[s]}, congestion {c}/{nc}"

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        for name in ("bearing_edges", "distance_edges", "congestion_edges"):
            out[name] = list(out[name])
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Discretisation:
        kwargs = dict(data)
        try:
            if "observation" in kwargs:
                kwargs["observation"] = ObservationParams(**kwargs["observation"])
            for name in ("bearing_edges", "distance_edges", "congestion_edges"):
                if name in kwargs:
                    kwargs[name] = tuple(kwargs[name])
            return cls(**kwargs)
        except TypeError as err:
            raise ConfigError(f"Discretisation: bad fields in {sorted(data)}: {err}") from err


@dataclass(frozen=True)
class DQDWAConfig:
    """Hyper-parameters of the tabular baseline; saved beside every checkpoint."""

    alpha: float = 0.1
    """Step size of the Q update (with ``alpha_schedule: visits``, its floor)."""
    alpha_schedule: str = "constant"
    """'constant' (alpha every update) or 'visits' (max(1 / N[s, a], alpha), module docstring)."""
    n_step: int = 1
    """Rewards summed before the bootstrap (1: the one-step Q-learning target)."""
    gamma: float = 0.99
    """Discount factor per control step (0.1 s), the same as the D3QN's."""
    eps_start: float = 1.0
    """Exploration rate before any update."""
    eps_end: float = 0.05
    """Asymptotic exploration rate."""
    eps_decay: float = 20_000.0
    """Time constant of the exponential epsilon decay, in Q updates."""
    initial_q: float = 0.0
    """Initial value of every table entry."""
    seed: int = 0
    """Seeds exploration."""
    discretisation: Discretisation = field(default_factory=Discretisation)
    """How an observation maps to a table row."""

    def __post_init__(self) -> None:
        checks = [
            ("alpha", 0.0 < self.alpha <= 1.0, "in (0, 1]"),
            ("gamma", 0.0 < self.gamma < 1.0, "in (0, 1)"),
            ("eps_start", 0.0 <= self.eps_start <= 1.0, "in [0, 1]"),
            (
                "eps_end",
                0.0 <= self.eps_end <= self.eps_start,
                f"in [0, eps_start ({self.eps_start})]",
            ),
            ("eps_decay", self.eps_decay > 0, "> 0"),
            ("initial_q", math.isfinite(self.initial_q), "finite"),
            ("alpha_schedule", self.alpha_schedule in ALPHA_SCHEDULES, f"one of {ALPHA_SCHEDULES}"),
            ("n_step", is_n_step(self.n_step), N_STEP_RULE),
        ]
        for name, ok, rule in checks:
            if not ok:
                raise ConfigError(f"DQDWAConfig.{name} must be {rule}, got {getattr(self, name)!r}")

    def to_dict(self) -> dict[str, Any]:
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["discretisation"] = self.discretisation.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> DQDWAConfig:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(f"DQDWAConfig: unknown field(s) {unknown}")
        kwargs = dict(data)
        if "discretisation" in kwargs:
            kwargs["discretisation"] = Discretisation.from_dict(kwargs["discretisation"])
        return cls(**kwargs)


class DQDWAAgent:
    """Epsilon-greedy tabular Q-learning: Q[s, a] += alpha (r + gamma (1 - d) max Q[s'] - Q[s, a]).

    ``table`` is (n_states, n_actions) float64. Greedy ties go to the lowest action index.
    """

    method_family = "dqdwa"

    def __init__(
        self, actions: ActionSet = ACTIONS_WEIGHTS_ONLY, config: DQDWAConfig = DQDWAConfig()
    ) -> None:
        self.actions = actions
        self.config = config
        self.discretisation = config.discretisation
        sectors = config.discretisation.observation.sectors
        self.obs_layout = OBSERVATION_LAYOUT[:4] + tuple(f"sector_{k}" for k in range(sectors))
        self.obs_dim = len(self.obs_layout)
        self.n_actions = actions.size
        self.table = np.full(
            (self.discretisation.n_states, self.n_actions), config.initial_q, dtype=np.float64
        )
        self.visits = np.zeros(self.table.shape, dtype=np.int64)
        """Updates each entry has had (the step size of ``alpha_schedule: visits``)."""
        self.n_step_windows = NStepWindows(config.n_step, config.gamma)
        self._rng = np.random.default_rng(config.seed)
        self.train_steps = 0
        """Q updates made (advances epsilon)."""
        self.env_steps = 0
        """Transitions learned from (equal to train_steps unless ``update`` is called directly)."""

    def state_index(self, obs: np.ndarray) -> int:
        """Table row of one observation (4 + K,)."""
        return self.discretisation.state_index(obs)

    def epsilon(self, step: int | None = None) -> float:
        """Exploration rate after ``step`` updates (default: the agent's own count)."""
        c = self.config
        return exponential_epsilon(
            self.train_steps if step is None else step, c.eps_start, c.eps_end, c.eps_decay
        )

    def act(self, obs: np.ndarray, greedy: bool = False) -> int:
        """Action index for one observation: epsilon-greedy unless ``greedy``."""
        if not greedy and self._rng.random() < self.epsilon():
            return int(self._rng.integers(self.n_actions))
        return int(np.argmax(self.table[self.state_index(obs)]))

    def update(
        self, s: int, a: int, r: float, s2: int, terminated: bool, discount: float | None = None
    ) -> float:
        """One Q-learning update on table indices; returns the TD error before the update.

        Truncation by the time limit must be passed as ``terminated=False`` (it bootstraps).
        ``discount`` is the bootstrap's (gamma^k for a k-step target; default gamma).
        """
        n_s, n_a = self.table.shape
        if not (0 <= s < n_s and 0 <= s2 < n_s and 0 <= a < n_a):
            raise ValueError(
                f"DQDWA.update: index out of range (s={s}, a={a}, s2={s2}; table {n_s}x{n_a})"
            )
        c = self.config
        bootstrap = c.gamma if discount is None else float(discount)
        target = r + (0.0 if terminated else bootstrap * float(self.table[s2].max()))
        td = target - float(self.table[s, a])
        self.visits[s, a] += 1
        step = c.alpha if c.alpha_schedule == "constant" else max(1.0 / self.visits[s, a], c.alpha)
        self.table[s, a] += step * td
        self.train_steps += 1
        return td

    def act_batch(self, obs: np.ndarray) -> np.ndarray:
        """``act`` for each row of a batch (n, obs_dim), in order: (n,) int64."""
        return np.array([self.act(o) for o in obs], dtype=np.int64)

    def learn(self, transition: Transition, env: int = 0) -> dict[str, float]:
        """Discretise env ``env``'s transition and update: the one call a training loop makes
        per step. With ``n_step`` > 1 the transition waits in the env's window and the n-step
        targets it completes are learned (none until the window is full; all at an episode
        end); the logs carry the mean TD error of those updates."""
        tds = []
        for t, discount in self.n_step_windows.push(transition, env):
            s, s2 = self.state_index(t.obs), self.state_index(t.next_obs)
            tds.append(
                self.update(s, int(t.action), float(t.reward), s2, bool(t.terminated), discount)
            )
        self.env_steps += 1
        logs = {"charts/epsilon": self.epsilon()}
        if tds:
            logs["losses/td_error"] = float(np.mean(tds))
        return logs
