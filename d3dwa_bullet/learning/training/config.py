"""The configuration of one training run: ``TrainConfig``'s fields, read from YAML, and what it builds.

A ``TrainConfig`` is frozen and checked whole on construction (``config_checks``: ConfigError
names the field and the value; a file's name comes first when it is loaded); ``to_dict`` / ``from_dict`` round-trip it through JSON, so the ``config.json``
saved beside every checkpoint reloads with ``load_train_config``. ``make_env`` and
``make_agent`` build the training env and a fresh agent of a config.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent, DQDWAConfig
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.tasks import TRAIN_WORLDS
from d3dwa_bullet.learning.training.config_checks import (  # re-exported: callers import them here
    CURRICULA,
    KEEP,
    VECTOR_MODES,
    as_tuple,
    check_fields,
    check_run_limits,
    check_scalar_types,
    check_selection_rule,
    check_validation_world,
)
from d3dwa_bullet.loading import load_yaml
from d3dwa_bullet.method_specs import LEARNED, method_observation
from d3dwa_bullet.params import RewardParams, recovery_params
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import check_observation_kind, observation_layout
from d3dwa_bullet.world.barn import barn_name, barn_split_ids

#: Reward scale by agent family: the D3QN uses the baseline magnitudes / 100 (paper).
DEFAULT_REWARD_SCALE = {"d3qn": 0.01, "dqdwa": 1.0}


@dataclass(frozen=True)
class TrainConfig:
    """Everything one training run needs; saved as config.json beside every checkpoint."""

    method: str = "d3dwa"
    """Method to train: d3dwa, d3dwa-weights, d3dwa-dr (D3QN) or dqdwa (tabular)."""
    total_steps: int = 150_000
    """Environment (control) steps of the whole run, 0.1 s each."""
    worlds: tuple[str, ...] = TRAIN_WORLDS
    """Training worlds (names or files); the unseen and real groups are refused."""
    generators: tuple[str, ...] = ("R1-style", "R2-style", "R3-style")
    """Generator styles whose fresh random layouts are trained on."""
    barn_split: str = "none"
    """BARN split whose worlds are added to ``worlds`` as training material: 'none' (off, the
    default) or 'train' (250 worlds; the 50 of 'challenge' are never trained or validated on)."""
    barn_worlds: int = len(barn_split_ids("train"))
    """How many of the split's worlds are trained on, 1..250: the ``barn_ids`` property's
    fixed, seed-independent order takes k evenly spaced ones (positions floor(j * 250 / k) of
    the ascending split, j = 0..k-1), so k = 5 is nested in k = 50 and k = 250 (all)."""
    generator_prob: float = 0.3
    """Base probability that an episode uses a generated layout instead of a world."""
    noise: tuple[str, ...] = ("none",)
    """Randomisation profiles; one is drawn per episode, then sampled per episode."""
    noise_probs: tuple[float, ...] = ()
    """Weights of the noise profiles (empty: uniform)."""
    route_start_prob: float = 0.0
    """Probability that an episode on a training world starts at a random point along its
    route (``route_start``) instead of the world's start; generated layouts never do."""
    route_start_span: float = 0.8
    """Route starts are uniform over this first fraction of the route's length."""
    curriculum: str = "adaptive"
    """Task sampling: 'uniform' (base probabilities) or 'adaptive' (favour failed tasks)."""
    curriculum_window: int = 20
    """Recent episodes per task that the adaptive curriculum's failure rate counts."""
    curriculum_floor: float = 0.25
    """Weight of a task solved every time, relative to 1 + floor for one never solved."""
    reward_scale: float | None = None
    """Multiplies every reward term; None: 0.01 for the D3QN methods, 1.0 for dqdwa."""
    observation: str | None = None
    """What the agent reads, which must be the method's own: 'history' for d3dwa-history-dr
    (docs/design/observation.md#history-observation), 'paper' (the 12-d state) for the others; None: that.
    ('progress', 17-d, is an env kind no registered method reads.)"""
    stall_penalty: float = 0.0
    """Reward added (before reward_scale) to a step ending more than ``stall_after`` s after
    the robot last made progress; 0: the paper's reward (docs/design/reward.md#stall-penalty)."""
    stall_after: float = 5.0
    """Seconds without progress (ground truth, 0.5 m circle) before the stall penalty."""
    decision_steps: int = 1
    """Control steps (0.1 s) one action is held for; 1: the paper's. Beyond the paper, off by
    default (docs/design/agent.md#decision-period): with k > 1 an env step, ``total_steps``,
    ``eval_every``, ``checkpoint_every`` and the agent's gamma count decisions of k control
    steps, so a budget of N control steps is ``total_steps: N / k``."""
    recovery: str = "none"
    """Recovery layer in training and greedy evaluation: 'none' (the paper's) or 'nav2'
    (beyond the paper: evaluate such a policy with ``--recovery nav2``; design/recovery.md#recovery)."""
    scan_filter: str = "none"
    """Scan filter chain in training and greedy evaluation (``--scan-filter``'s names): "none"
    (the paper's stack) or, beyond the paper, e.g. "speckle+median" (docs/design/scan-filter.md#scan-filter).
    A policy trained with a filter is driven only with the same one (``policy_terms``)."""
    weights: tuple[float, ...] | None = None
    """Weight candidates W; None: the method's action set."""
    horizons: tuple[float, ...] | None = None
    """Horizon candidates T, s; None: the method's action set."""
    agent: D3QNConfig | DQDWAConfig | None = None
    """Agent hyper-parameters (D3QNConfig or DQDWAConfig); None: that class's defaults."""
    init_policy: str | None = None
    """A trained D3QN policy whose network this run starts from (a folder of ``seed-<k>/``:
    the run's seed; one policy folder; or a shipped method's name); None: a fresh network,
    the paper's. Beyond the paper, a two-stage noise curriculum (``warm_start``)."""
    eval_every: int = 25_000
    """Greedy evaluation every this many env steps (at the next episode end); 0: never."""
    eval_worlds: tuple[str, ...] = ("R1-style-s1", "R2-style-s1", "R3-style-s1")
    """Worlds of the periodic greedy evaluation: training material only. With ``keep:
    best`` they are the validation set that picks the shipped checkpoint, so they must also
    be disjoint from every world a results table reports: no shipped world file (TS1-TS4 are
    Table I), no unseen layout (generator seeds from 2^31 up); generated layouts below 2^31
    or the user's own files."""
    eval_seeds: tuple[int, ...] = (0,)
    """Episode seeds of each evaluation world."""
    eval_noise: str = "none"
    """Noise profile of the periodic evaluation."""
    checkpoint_every: int = 25_000
    """Save the resumable checkpoint every this many env steps (at episode end); 0: only at the end."""
    log_every: int = 1_000
    """Write loss, epsilon and curriculum scalars every this many env steps."""
    keep: str = "best"
    """Policy exported to <out>/policy: 'best' (greedy evaluation on training worlds) or 'final'."""
    seed: int = 0
    """Seeds the agent (network, exploration, replay) and the episode sequence."""
    n_envs: int = 0
    """Simulators stepped in lock-step, each in a worker process; 0: one per core of this
    machine, resolved when the config is made (config.json records the number). A run is
    deterministic for a given (seed, n_envs); the update-to-data ratio is the agent's
    ``train_freq`` whatever n_envs is."""
    vector: str = "async"
    """'async': n_envs > 1 run in worker processes; 'sync': all in this process (the same
    transitions, slower; for tests and debugging)."""

    def __post_init__(self) -> None:
        if self.method not in LEARNED:
            raise ConfigError(
                f"TrainConfig.method: {self.method!r} is not a learned method; choose one of "
                f"{', '.join(LEARNED)}"
            )
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        for name in ("worlds", "generators", "noise", "eval_worlds"):
            set_(name, as_tuple(getattr(self, name), name))
        set_("noise_probs", as_tuple(self.noise_probs, "noise_probs", float))
        set_("eval_seeds", as_tuple(self.eval_seeds, "eval_seeds", int))
        base = LEARNED[self.method]
        for name in ("weights", "horizons"):
            value = getattr(self, name)
            set_(name, getattr(base, name) if value is None else as_tuple(value, name, float))
        ActionSet(self.weights, self.horizons)  # type: ignore[arg-type]  # ConfigError if bad
        family = self.family
        agent_cls = D3QNConfig if family == "d3qn" else DQDWAConfig
        agent = self.agent if self.agent is not None else agent_cls()
        if not isinstance(agent, agent_cls):
            raise ConfigError(
                f"TrainConfig.agent: method {self.method!r} needs a {agent_cls.__name__}, "
                f"got {type(agent).__name__}"
            )
        set_("agent", replace(agent, seed=int(self.seed)))
        if self.reward_scale is None:
            set_("reward_scale", DEFAULT_REWARD_SCALE[family])
        kind = method_observation(self.method)
        if self.observation is None:
            set_("observation", kind)
        check_observation_kind(self.observation, "TrainConfig.observation")
        if self.observation != kind:
            raise ConfigError(
                f"TrainConfig.observation: method {self.method!r} reads the {kind!r} "
                f"observation, got {self.observation!r}"
            )
        _ = self.reward_params  # ConfigError naming stall_penalty / stall_after if out of range
        if type(self.n_envs) is int and self.n_envs == 0:
            set_("n_envs", os.cpu_count() or 1)
        check_fields(self)

    @property
    def family(self) -> str:
        """Agent family: 'd3qn' or 'dqdwa'."""
        return "dqdwa" if self.method == "dqdwa" else "d3qn"

    @property
    def obs_layout(self) -> tuple[str, ...]:
        """The names of the observation entries the agent reads."""
        return observation_layout(str(self.observation))

    @property
    def barn_ids(self) -> tuple[int, ...]:
        """The BARN world numbers trained on (see ``barn_worlds``); () when ``barn_split`` is
        'none'."""
        if self.barn_split == "none":
            return ()
        members = barn_split_ids(self.barn_split)
        n, k = len(members), int(self.barn_worlds)
        return tuple(members[j * n // k] for j in range(k))

    @property
    def training_worlds(self) -> tuple[str, ...]:
        """``worlds`` followed by the BARN worlds of ``barn_ids`` (names ``BARN-<i>``)."""
        return self.worlds + tuple(barn_name(i) for i in self.barn_ids)

    @property
    def reward_params(self) -> RewardParams:
        """The reward of the run (the paper's, scaled, unless a stall penalty is set)."""
        try:
            return RewardParams(
                scale=float(self.reward_scale),  # type: ignore[arg-type]
                stall_penalty=float(self.stall_penalty),
                stall_after=float(self.stall_after),
            )
        except ConfigError as err:
            raise ConfigError(f"TrainConfig.{err}") from err

    @property
    def actions(self) -> ActionSet:
        """The action set trained over."""
        return ActionSet(self.weights, self.horizons)  # type: ignore[arg-type]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict; ``from_dict`` inverts it."""
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            out[f.name] = list(value) if isinstance(value, tuple) else value
        out["agent"] = self.agent.to_dict()  # type: ignore[union-attr]
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<dict>") -> TrainConfig:
        """Build from a mapping (YAML/JSON content); ConfigError names the source and field."""
        if not isinstance(data, Mapping):
            raise ConfigError(f"{source}: expected a mapping of TrainConfig fields, got {data!r}")
        known = [f.name for f in fields(cls)]
        unknown = sorted(set(data) - set(known))
        if unknown:
            raise ConfigError(f"{source}: unknown field(s) {unknown}; known: {', '.join(known)}")
        kwargs = dict(data)
        method = kwargs.get("method", cls.method)
        agent = kwargs.get("agent")
        check_scalar_types(cls, kwargs, source)
        agent_cls = DQDWAConfig if method == "dqdwa" else D3QNConfig
        if isinstance(agent, Mapping):
            check_scalar_types(agent_cls, agent, source, "agent.")
        try:
            if isinstance(agent, Mapping):
                kwargs["agent"] = agent_cls.from_dict(agent)
            elif agent is not None and not isinstance(agent, D3QNConfig | DQDWAConfig):
                raise ConfigError(f"field 'agent' must be a mapping of fields, got {agent!r}")
            return cls(**kwargs)
        except ConfigError as err:
            raise ConfigError(f"{source}: {err}") from err
        except TypeError as err:
            raise ConfigError(f"{source}: bad field value ({err})") from err


def load_train_config(path: str | os.PathLike[str], **overrides: Any) -> TrainConfig:
    """A TrainConfig from a YAML (or JSON) file, with keyword overrides (None = keep)."""
    p = Path(path)
    data = load_yaml(p, ConfigError, "training config")
    if data is not None and not isinstance(data, Mapping):
        raise ConfigError(
            f"{p}: expected a mapping of TrainConfig fields (method: ..., total_steps: ...), "
            f"got a YAML {type(data).__name__}"
        )
    data = dict(data or {})
    for key, value in overrides.items():
        if value is not None:
            if key == "method" and "method" in data and data["method"] != value:
                raise ConfigError(
                    f"{p}: the config trains {data['method']!r} but --method says {value!r}"
                )
            data[key] = value
    return TrainConfig.from_dict(data, str(p))


def make_env(
    config: TrainConfig, worlds: Sequence[str] | None = None, allow_eval_worlds: bool = False
) -> D3DWAEnv:
    """The training env of a config (or an env over ``worlds`` only, for evaluation;
    ``allow_eval_worlds`` admits the evaluation-only groups, for diagnostics that select
    nothing, such as tools.experiments.value_check)."""
    if worlds is not None:
        return D3DWAEnv(
            worlds=tuple(worlds),
            allow_eval_worlds=allow_eval_worlds,
            decision_steps=config.decision_steps,
            actions=config.actions,
            reward_params=config.reward_params,
            observation=str(config.observation),
            recovery=recovery_params(config.recovery),
            episode_config=EpisodeConfig(scan_filter=config.scan_filter),
        )
    return D3DWAEnv(
        worlds=config.training_worlds,
        generators=config.generators,
        generator_prob=config.generator_prob if config.generators else None,
        noise=config.noise,
        noise_probs=config.noise_probs,
        actions=config.actions,
        reward_params=config.reward_params,
        route_start_prob=config.route_start_prob,
        route_start_span=config.route_start_span,
        observation=str(config.observation),
        decision_steps=config.decision_steps,
        recovery=recovery_params(config.recovery),
        episode_config=EpisodeConfig(scan_filter=config.scan_filter),
    )


def make_agent(config: TrainConfig) -> D3QNAgent | DQDWAAgent:
    """A fresh agent of the config's family, action set and hyper-parameters."""
    if config.family == "dqdwa":
        return DQDWAAgent(config.actions, config.agent)  # type: ignore[arg-type]
    return D3QNAgent(config.actions, config.agent, config.obs_layout)  # type: ignore[arg-type]


__all__ = [
    "CURRICULA",
    "DEFAULT_REWARD_SCALE",
    "KEEP",
    "VECTOR_MODES",
    "TrainConfig",
    "check_run_limits",
    "check_scalar_types",
    "check_selection_rule",
    "check_validation_world",
    "load_train_config",
    "make_agent",
    "make_env",
]
