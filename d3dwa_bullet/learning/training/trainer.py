"""Train a learned method (d3dwa, d3dwa-weights, d3dwa-dr, dqdwa) in the D3DWA env.

``train(config, out_dir)`` runs one training from a ``TrainConfig`` (usually a YAML file in
``configs/``) and writes a run directory::

    <out>/config.json          the TrainConfig (reload it with load_train_config)
    <out>/run.json             run name, package version, start time
    <out>/episodes.csv         one row per training episode
    <out>/metrics.jsonl        TensorBoard-style records {"step", "tag", "value"} (charts/...,
                               losses/..., eval/..., curriculum/...) and the per-episode
                               horizon histogram {"step", "tag": "planner/tau", "histogram"}
    <out>/learning_curve.png   return and success rate vs environment steps
    <out>/summary.json         status, counters, wall time, throughput, evaluations
    <out>/checkpoints/latest/  resumable: policy + config.json + training state
    <out>/checkpoints/best/    policy with the best greedy evaluation (training worlds)
    <out>/checkpoints/final/   policy at the end of the budget
    <out>/policy/              the policy to ship (``keep``: best or final) + config.json
                               + learning_curve.png, no replay buffer

(and ``<out>/tb/`` if ``torch.utils.tensorboard`` is importable.)

Loop: epsilon-greedy action -> env step -> ``agent.learn`` (store + one update when due).
Every ``eval_every`` steps (at the next episode end) the greedy policy runs once per
evaluation world and seed; every ``checkpoint_every`` steps ``latest`` is saved.

Resumption is exact: the training state holds the replay buffer, Adam moments, target
network, every RNG and counter, the curriculum and the log sizes, plus the episode in
progress as (its env RNG state, the actions taken so far). ``train(..., resume=True)``
truncates the logs to the checkpoint, rebuilds that episode by replaying its actions
(the simulator is deterministic in DIRECT mode) and goes on as if never stopped.

Failure safety: checkpoints are swapped in atomically; an exception in the loop saves
nothing (the last good ``latest`` stays); non-finite weights are never saved; Ctrl-C
(SIGINT) stops at the next step boundary, saves ``latest`` and returns with status
"interrupted" (a second Ctrl-C aborts at once, saving nothing).

Curriculum ("adaptive"): each task (a training world or a generator style) is drawn with
its base probability times ``curriculum_floor + failure rate`` over its last
``curriculum_window`` episodes, so tasks the agent already solves are drawn less often.
"""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import sys
import time
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import ConfigError, TrainingError
from d3dwa_bullet.learning.agents.checkpoint import CONFIG_FILE, CURVE_FILE, load_checkpoint, save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent, DQDWAConfig
from d3dwa_bullet.learning.agents.policy import greedy_policy
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.learning.agents.training_state import restore_training_state, training_state_files
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.tasks import TRAIN_WORLDS, resolve_world
from d3dwa_bullet.methods import LEARNED
from d3dwa_bullet.planning.actions import ActionSet

D3QN_METHODS = ("d3dwa", "d3dwa-weights", "d3dwa-dr")
#: Reward scale by agent family: the D3QN uses the baseline magnitudes / 100 (paper).
DEFAULT_REWARD_SCALE = {"d3qn": 0.01, "dqdwa": 1.0}
CURRICULA = ("uniform", "adaptive")
KEEP = ("best", "final")
SUCCESS_WINDOW = 50
"""Episodes in the rolling training success rate and return."""
LOG_FILES = ("episodes.csv", "metrics.jsonl")
EPISODE_FIELDS = (
    "step",
    "episode",
    "task",
    "world",
    "noise",
    "outcome",
    "return",
    "length",
    "epsilon",
    "tau_mean",
    "fallbacks",
    "wall_time",
    "route_start",
)


def _tuple(value: Any, name: str, kind: type = str) -> tuple:
    if isinstance(value, str | int | float):
        value = [value]
    try:
        return tuple(kind(v) for v in value)
    except (TypeError, ValueError) as err:
        raise ConfigError(
            f"TrainConfig.{name}: expected a list of {kind.__name__}, got {value!r}"
        ) from err


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
    weights: tuple[float, ...] | None = None
    """Weight candidates W; None: the method's action set."""
    horizons: tuple[float, ...] | None = None
    """Horizon candidates T, s; None: the method's action set."""
    agent: D3QNConfig | DQDWAConfig | None = None
    """Agent hyper-parameters (D3QNConfig or DQDWAConfig); None: that class's defaults."""
    eval_every: int = 25_000
    """Greedy evaluation every this many env steps (at the next episode end); 0: never."""
    eval_worlds: tuple[str, ...] = TRAIN_WORLDS
    """Worlds of the periodic evaluation: training worlds only (generated names allowed)."""
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

    def __post_init__(self) -> None:
        if self.method not in LEARNED:
            raise ConfigError(
                f"TrainConfig.method: {self.method!r} is not a learned method; choose one of "
                f"{', '.join(LEARNED)}"
            )
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        for name in ("worlds", "generators", "noise", "eval_worlds"):
            set_(name, _tuple(getattr(self, name), name))
        set_("noise_probs", _tuple(self.noise_probs, "noise_probs", float))
        set_("eval_seeds", _tuple(self.eval_seeds, "eval_seeds", int))
        base = LEARNED[self.method]
        for name in ("weights", "horizons"):
            value = getattr(self, name)
            set_(name, getattr(base, name) if value is None else _tuple(value, name, float))
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
        checks: list[tuple[str, bool, str]] = [
            ("total_steps", self.total_steps >= 1, ">= 1"),
            ("generator_prob", 0.0 <= self.generator_prob <= 1.0, "in [0, 1]"),
            ("route_start_prob", 0.0 <= self.route_start_prob <= 1.0, "in [0, 1]"),
            ("route_start_span", 0.0 < self.route_start_span < 1.0, "in (0, 1)"),
            ("curriculum", self.curriculum in CURRICULA, f"one of {CURRICULA}"),
            ("curriculum_window", self.curriculum_window >= 1, ">= 1"),
            ("curriculum_floor", self.curriculum_floor > 0, "> 0"),
            (
                "reward_scale",
                math.isfinite(float(self.reward_scale)) and float(self.reward_scale) > 0,  # type: ignore[arg-type]
                "a finite number > 0",
            ),
            ("eval_every", self.eval_every >= 0, ">= 0"),
            ("eval_seeds", bool(self.eval_seeds), "non-empty"),
            ("checkpoint_every", self.checkpoint_every >= 0, ">= 0"),
            ("log_every", self.log_every >= 1, ">= 1"),
            ("keep", self.keep in KEEP, f"one of {KEEP}"),
            ("seed", self.seed >= 0, ">= 0"),
            ("noise", bool(self.noise), "non-empty ('none' for noise-free)"),
        ]
        for name, ok, rule in checks:
            if not ok:
                raise ConfigError(f"TrainConfig.{name} must be {rule}, got {getattr(self, name)!r}")
        if not self.worlds and not self.generators:
            raise ConfigError("TrainConfig: give at least one training world or generator style")
        if self.noise_probs and len(self.noise_probs) != len(self.noise):
            raise ConfigError(
                f"TrainConfig.noise_probs: {len(self.noise_probs)} weights for "
                f"{len(self.noise)} noise profiles {list(self.noise)}"
            )
        if self.keep == "best" and self.eval_every == 0:
            raise ConfigError("TrainConfig.keep = 'best' needs eval_every > 0")
        for w in self.worlds:
            resolve_world(w, False, "TrainConfig.worlds")
        for w in self.eval_worlds:
            resolve_world(w, False, "TrainConfig.eval_worlds")
        if self.eval_every and not self.eval_worlds:
            raise ConfigError("TrainConfig.eval_worlds: empty, but eval_every > 0")

    @property
    def family(self) -> str:
        """Agent family: 'd3qn' or 'dqdwa'."""
        return "dqdwa" if self.method == "dqdwa" else "d3qn"

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
        try:
            if isinstance(agent, Mapping):
                agent_cls = DQDWAConfig if method == "dqdwa" else D3QNConfig
                kwargs["agent"] = agent_cls.from_dict(agent)
            return cls(**kwargs)
        except ConfigError as err:
            raise ConfigError(f"{source}: {err}") from err
        except TypeError as err:
            raise ConfigError(f"{source}: bad field value ({err})") from err


def load_train_config(path: str | os.PathLike[str], **overrides: Any) -> TrainConfig:
    """A TrainConfig from a YAML (or JSON) file, with keyword overrides (None = keep)."""
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except (OSError, yaml.YAMLError) as err:
        raise ConfigError(f"{p}: cannot read the training config: {err}") from err
    data = dict(data or {})
    for key, value in overrides.items():
        if value is not None:
            if key == "method" and "method" in data and data["method"] != value:
                raise ConfigError(
                    f"{p}: the config trains {data['method']!r} but --method says {value!r}"
                )
            data[key] = value
    return TrainConfig.from_dict(data, str(p))


def make_env(config: TrainConfig, worlds: Sequence[str] | None = None) -> D3DWAEnv:
    """The training env of a config (or an env over ``worlds`` only, for evaluation)."""
    if worlds is not None:
        return D3DWAEnv(
            worlds=tuple(worlds),
            actions=config.actions,
            reward_scale=float(config.reward_scale),  # type: ignore[arg-type]
        )
    return D3DWAEnv(
        worlds=config.worlds,
        generators=config.generators,
        generator_prob=config.generator_prob if config.generators else None,
        noise=config.noise,
        noise_probs=config.noise_probs,
        actions=config.actions,
        reward_scale=float(config.reward_scale),  # type: ignore[arg-type]
        route_start_prob=config.route_start_prob,
        route_start_span=config.route_start_span,
    )


def make_agent(config: TrainConfig) -> D3QNAgent | DQDWAAgent:
    """A fresh agent of the config's family, action set and hyper-parameters."""
    if config.family == "dqdwa":
        return DQDWAAgent(config.actions, config.agent)  # type: ignore[arg-type]
    return D3QNAgent(config.actions, config.agent)  # type: ignore[arg-type]


def env_seed(seed: int) -> int:
    """The reset seed of the first training episode, derived from the run seed."""
    return int(np.random.SeedSequence([int(seed), 1]).generate_state(1)[0])


# --- logging ---------------------------------------------------------------------------------


class MetricsLog:
    """Appends episodes.csv and metrics.jsonl (and TensorBoard events if available)."""

    def __init__(self, out: Path, tensorboard: bool = True) -> None:
        self.out = out
        path = out / "episodes.csv"
        new = not path.exists()
        fieldnames = list(EPISODE_FIELDS)
        if not new:  # resuming: keep the file's own columns (a run from an older version)
            with path.open(newline="") as fh:
                fieldnames = next(csv.reader(fh), fieldnames)
        self._episodes = path.open("a", newline="")
        self._writer = csv.DictWriter(self._episodes, fieldnames=fieldnames, extrasaction="ignore")
        if new:
            self._writer.writeheader()
        self._metrics = (out / "metrics.jsonl").open("a")
        self._tb = None
        if tensorboard:
            try:
                from torch.utils.tensorboard import SummaryWriter

                self._tb = SummaryWriter(str(out / "tb"))
            except Exception:  # optional: tensorboard not installed
                self._tb = None

    def scalar(self, step: int, tag: str, value: float) -> None:
        self._metrics.write(json.dumps({"step": step, "tag": tag, "value": float(value)}) + "\n")
        if self._tb is not None:
            self._tb.add_scalar(tag, value, step)

    def histogram(self, step: int, tag: str, counts: Mapping[str, int]) -> None:
        self._metrics.write(
            json.dumps({"step": step, "tag": tag, "histogram": dict(counts)}) + "\n"
        )
        if self._tb is not None:
            for k, n in counts.items():
                self._tb.add_scalar(f"{tag}_count/{k}", n, step)

    def episode(self, row: Mapping[str, Any]) -> None:
        self._writer.writerow(row)

    def flush(self) -> None:
        self._episodes.flush()
        self._metrics.flush()
        if self._tb is not None:
            self._tb.flush()

    def sizes(self) -> dict[str, int]:
        self.flush()
        return {name: (self.out / name).stat().st_size for name in LOG_FILES}

    def close(self) -> None:
        self.flush()
        self._episodes.close()
        self._metrics.close()
        if self._tb is not None:
            self._tb.close()


def read_episodes(out: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Rows of <out>/episodes.csv with numbers parsed."""
    path = Path(out) / "episodes.csv"
    if not path.exists():
        return []
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k in ("step", "episode", "length", "fallbacks"):
            r[k] = int(r[k])
        for k in ("return", "epsilon", "tau_mean", "wall_time"):
            r[k] = float(r[k])
        if "route_start" in r:
            r["route_start"] = r["route_start"] == "True"
    return rows


def read_metrics(out: str | os.PathLike[str], tag: str | None = None) -> list[dict[str, Any]]:
    """Records of <out>/metrics.jsonl, optionally only one tag."""
    path = Path(out) / "metrics.jsonl"
    if not path.exists():
        return []
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return [r for r in rows if tag is None or r["tag"] == tag]


def _rolling(values: np.ndarray, window: int) -> np.ndarray:
    c = np.cumsum(np.insert(values.astype(np.float64), 0, 0.0))
    n = np.minimum(np.arange(1, len(values) + 1), window)
    return (c[1:] - c[np.arange(1, len(values) + 1) - n]) / n


def learning_curve(
    out: str | os.PathLike[str], path: str | os.PathLike[str], title: str = ""
) -> Path:
    """Return and success rate vs env steps (training rolling means + greedy evaluations)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    rows = read_episodes(out)
    evals = read_metrics(out, "eval/success_rate")
    eval_returns = read_metrics(out, "eval/mean_return")
    fig = Figure(figsize=(8, 6), tight_layout=True)
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    if rows:
        steps = np.array([r["step"] for r in rows])
        returns = np.array([r["return"] for r in rows])
        success = np.array([r["outcome"] == "goal" for r in rows], dtype=float)
        ax1.plot(steps, returns, ".", ms=2, alpha=0.3, color="tab:blue", label="episode")
        ax1.plot(steps, _rolling(returns, SUCCESS_WINDOW), color="tab:blue",
                 label=f"mean of last {SUCCESS_WINDOW}")  # fmt: skip
        ax2.plot(steps, _rolling(success, SUCCESS_WINDOW), color="tab:green",
                 label=f"training (last {SUCCESS_WINDOW} episodes)")  # fmt: skip
    if eval_returns:
        ax1.plot([r["step"] for r in eval_returns], [r["value"] for r in eval_returns], "o-",
                 color="tab:red", label="greedy evaluation")  # fmt: skip
    if evals:
        ax2.plot([r["step"] for r in evals], [r["value"] for r in evals], "o-", color="tab:red",
                 label="greedy evaluation (training worlds)")  # fmt: skip
    ax1.set_ylabel("episodic return")
    ax2.set_ylabel("success rate")
    ax2.set_ylim(-0.05, 1.05)
    ax2.set_xlabel("environment steps (0.1 s each)")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="lower right", fontsize=8)
    ax1.set_title(title)
    path = Path(path)
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=90)
    os.replace(tmp, path)
    return path


# --- the training run ------------------------------------------------------------------------


@dataclass
class EpisodeProgress:
    """The episode in progress, as much as exact resumption needs."""

    reset_seed: int | None = None
    """Seed passed to reset() (first episode only), else None."""
    rng_before: dict[str, Any] | None = None
    """The env's RNG state just before this episode's reset() (later episodes)."""
    actions: list[int] = field(default_factory=list)
    """Actions taken so far (replayed on resume; env.step draws nothing from the env RNG)."""
    ret: float = 0.0
    tau_counts: list[int] = field(default_factory=list)
    fallbacks: int = 0
    finished: bool = False
    """The episode has ended (the budget ran out at its last step)."""
    obs: list[float] = field(default_factory=list)
    """The current observation (checked after the replay on resume)."""


class _Stop:
    """SIGINT -> a flag checked at step boundaries; a second SIGINT raises at once."""

    def __init__(self) -> None:
        self.requested = False
        self._previous: Any = None

    def __enter__(self) -> _Stop:
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


class Trainer:
    """One training run in ``out`` (see module docstring); ``run()`` returns the summary."""

    def __init__(
        self, config: TrainConfig | None, out: str | os.PathLike[str], resume: bool = False
    ):
        self.out = Path(out)
        self.latest = self.out / "checkpoints" / "latest"
        if resume:
            saved = self._saved_config()
            if config is None:
                config = saved
            else:
                a, b = config.to_dict(), saved.to_dict()
                a.pop("total_steps"), b.pop("total_steps")
                diff = sorted(k for k in a if a[k] != b[k])
                if diff:
                    raise ConfigError(
                        f"{self.out / CONFIG_FILE}: resuming with a config that differs in "
                        f"{diff}; only total_steps may change on resume"
                    )
            if not (self.latest / "meta.json").exists():
                raise ConfigError(f"{self.latest}: no checkpoint to resume from")
        else:
            if config is None:
                raise ConfigError("train: a TrainConfig is needed unless resuming")
            if self.out.exists() and any(
                (self.out / n).exists() for n in (CONFIG_FILE, "checkpoints", *LOG_FILES)
            ):
                raise ConfigError(
                    f"{self.out}: already holds a training run; pass --resume to continue it "
                    "or choose a new --out directory"
                )
        self.config = config
        self.resume = resume
        self.env_steps = 0
        self.episodes = 0
        self.wall_time = 0.0
        self.timing = {"act": 0.0, "env": 0.0, "learn": 0.0, "eval": 0.0, "checkpoint": 0.0}
        self.cpu_time = 0.0
        """Process CPU time of the run, s (what the wall time would be on an idle core)."""
        self.next_eval = config.eval_every or math.inf
        self.next_checkpoint = config.checkpoint_every or math.inf
        self.next_log = config.log_every
        self.history: dict[str, deque[int]] = {}
        self.recent_returns: deque[float] = deque(maxlen=SUCCESS_WINDOW)
        self.recent_success: deque[int] = deque(maxlen=SUCCESS_WINDOW)
        self.loss_acc: dict[str, list[float]] = {}
        self.best: dict[str, Any] | None = None
        self.evals: list[dict[str, Any]] = []
        self.episode = EpisodeProgress()
        self.obs = np.zeros(12, dtype=np.float32)
        self._start = time.perf_counter()
        self._wall0 = 0.0

    def _saved_config(self) -> TrainConfig:
        path = self.out / CONFIG_FILE
        if not path.exists():
            raise ConfigError(f"{path}: missing; nothing to resume in {self.out}")
        return load_train_config(path)

    # --- state -------------------------------------------------------------------------------

    def trainer_state(self, logs: MetricsLog) -> dict[str, Any]:
        ep = self.episode
        return {
            "env_steps": self.env_steps,
            "episodes": self.episodes,
            "wall_time": self.wall_time,
            "cpu_time": self.cpu_time,
            "timing": self.timing,
            "next_eval": None if math.isinf(self.next_eval) else self.next_eval,
            "next_checkpoint": None if math.isinf(self.next_checkpoint) else self.next_checkpoint,
            "next_log": self.next_log,
            "history": {k: list(v) for k, v in self.history.items()},
            "recent_returns": list(self.recent_returns),
            "recent_success": list(self.recent_success),
            "loss_acc": self.loss_acc,
            "best": self.best,
            "evals": self.evals,
            "episode": asdict(ep) | {"obs": [float(v) for v in self.obs]},
            "log_sizes": logs.sizes(),
        }

    def load_trainer_state(self, state: Mapping[str, Any]) -> None:
        self.env_steps = int(state["env_steps"])
        self.episodes = int(state["episodes"])
        self.wall_time = float(state["wall_time"])
        self.cpu_time = float(state.get("cpu_time", 0.0))
        self.timing = dict(state["timing"])
        self.next_eval = math.inf if state["next_eval"] is None else state["next_eval"]
        self.next_checkpoint = (
            math.inf if state["next_checkpoint"] is None else state["next_checkpoint"]
        )
        self.next_log = int(state["next_log"])
        w = self.config.curriculum_window
        self.history = {k: deque(v, maxlen=w) for k, v in state["history"].items()}
        self.recent_returns = deque(state["recent_returns"], maxlen=SUCCESS_WINDOW)
        self.recent_success = deque(state["recent_success"], maxlen=SUCCESS_WINDOW)
        self.loss_acc = {k: list(v) for k, v in state["loss_acc"].items()}
        self.best = state["best"]
        self.evals = list(state["evals"])
        self.episode = EpisodeProgress(**state["episode"])
        for name, size in state["log_sizes"].items():
            path = self.out / name
            if path.exists() and path.stat().st_size > size:
                with path.open("r+b") as fh:  # drop what was logged after the checkpoint
                    fh.truncate(size)

    # --- pieces ------------------------------------------------------------------------------

    def _curriculum(self, env: D3DWAEnv) -> None:
        if self.config.curriculum != "adaptive":
            return
        weights = []
        for task in env.tasks:
            h = self.history.get(task)
            failure = 1.0 - (sum(h) / len(h)) if h else 1.0
            weights.append(self.config.curriculum_floor + failure)
        env.set_task_weights(weights)

    def _reset(self, env: D3DWAEnv, first: bool) -> np.ndarray:
        self._curriculum(env)
        if first:
            seed = env_seed(self.config.seed)
            self.episode = EpisodeProgress(reset_seed=seed)
            obs, _ = env.reset(seed=seed)
        else:
            self.episode = EpisodeProgress(rng_before=env.np_random.bit_generator.state)
            obs, _ = env.reset()
        self.episode.tau_counts = [0] * len(self.config.actions.horizons)
        return obs

    def _rebuild_episode(self, env: D3DWAEnv) -> np.ndarray | None:
        """Re-run the saved episode in progress and return its current observation.

        None if that episode had already finished (the env RNG is then where the next
        reset expects it). TrainingError if the replay does not reproduce the saved
        observation (the simulator was not deterministic).
        """
        ep = self.episode
        self._curriculum(env)
        if ep.reset_seed is not None:
            obs, _ = env.reset(seed=ep.reset_seed)
        else:
            env.np_random = np.random.Generator(np.random.PCG64(0))
            env.np_random.bit_generator.state = ep.rng_before
            obs, _ = env.reset()
        if ep.finished:
            return None
        for i, a in enumerate(ep.actions):
            obs, _, terminated, truncated, _ = env.step(a)
            if (terminated or truncated) and i + 1 < len(ep.actions):
                break
        if not np.array_equal(obs, np.asarray(ep.obs, dtype=np.float32)):
            raise TrainingError(
                f"{self.latest}: replaying the episode in progress ({len(ep.actions)} steps on "
                f"{env.world.name if env.world else '?'}) did not reproduce its saved observation"
            )
        return obs

    def _check_finite(self, agent: D3QNAgent | DQDWAAgent) -> None:
        if isinstance(agent, D3QNAgent):
            ok = all(bool(v.isfinite().all()) for v in agent.online.state_dict().values())
        else:
            ok = bool(np.isfinite(agent.table).all())
        if not ok:
            raise TrainingError(
                f"{self.out}: the {agent.method_family} agent's values became NaN/inf at step "
                f"{self.env_steps}; nothing saved (the last good checkpoint is kept)"
            )

    def _metadata(self, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
        c = self.config
        return {
            "method": c.method,
            "run": self.out.name,
            "env_steps": self.env_steps,
            "episodes": self.episodes,
            "worlds": list(c.worlds),
            "generators": list(c.generators),
            "noise": list(c.noise),
            "reward_scale": c.reward_scale,
            **dict(extra or {}),
        }

    def _config_bytes(self) -> bytes:
        return (json.dumps(self.config.to_dict(), indent=2) + "\n").encode()

    def save_latest(self, agent: D3QNAgent | DQDWAAgent, logs: MetricsLog) -> None:
        t0 = time.perf_counter()
        self._check_finite(agent)
        self._curve()
        files: dict[str, Any] = dict(training_state_files(agent, self.trainer_state(logs)))
        files[CONFIG_FILE] = self._config_bytes()
        files[CURVE_FILE] = self.out / CURVE_FILE
        save_checkpoint(self.latest, agent, self._metadata(), method=self.config.method,
                        extra_files=files)  # fmt: skip
        self.timing["checkpoint"] += time.perf_counter() - t0

    def save_policy(
        self, name: str, agent: D3QNAgent | DQDWAAgent, extra: Mapping[str, Any]
    ) -> Path:
        self._check_finite(agent)
        return save_checkpoint(
            self.out / "checkpoints" / name,
            agent,
            self._metadata(extra),
            method=self.config.method,
            extra_files={CONFIG_FILE: self._config_bytes()},
        )

    def _curve(self) -> None:
        c = self.config
        learning_curve(self.out, self.out / CURVE_FILE,
                       f"{c.method}: {self.env_steps} steps, seed {c.seed}")  # fmt: skip

    def evaluate(self, agent: D3QNAgent | DQDWAAgent) -> dict[str, Any]:
        """Greedy episodes on the evaluation worlds (training worlds only)."""
        t0 = time.perf_counter()
        c = self.config
        policy = greedy_policy(agent)
        env = make_env(c, worlds=c.eval_worlds[:1])
        outcomes: dict[str, list[str]] = {}
        returns = []
        times = []
        try:
            for world in c.eval_worlds:
                for seed in c.eval_seeds:
                    obs, info = env.reset(
                        options={"world": world, "noise": c.eval_noise, "episode_seed": seed}
                    )
                    total, n = 0.0, 0
                    while True:
                        obs, r, terminated, truncated, info = env.step(policy(obs))
                        total += r
                        n += 1
                        if terminated or truncated:
                            break
                    outcomes.setdefault(info["world"], []).append(info["outcome"])
                    returns.append(total)
                    if info["outcome"] == "goal":
                        times.append(n * 0.1)
        finally:
            env.close()
        flat = [o for v in outcomes.values() for o in v]
        result = {
            "step": self.env_steps,
            "success_rate": flat.count("goal") / len(flat),
            "collision_rate": flat.count("collision") / len(flat),
            "mean_return": float(np.mean(returns)),
            "mean_time_s": float(np.mean(times)) if times else None,
            "outcomes": outcomes,
        }
        self.timing["eval"] += time.perf_counter() - t0
        return result

    def _log_eval(self, logs: MetricsLog, result: Mapping[str, Any]) -> None:
        step = self.env_steps
        logs.scalar(step, "eval/success_rate", result["success_rate"])
        logs.scalar(step, "eval/collision_rate", result["collision_rate"])
        logs.scalar(step, "eval/mean_return", result["mean_return"])
        for world, outs in result["outcomes"].items():
            logs.scalar(step, f"eval/{world}_success", outs.count("goal") / len(outs))
        logs.flush()  # the learning curve reads the file: the final evaluation must be on it

    @staticmethod
    def _score(result: Mapping[str, Any]) -> list[float]:
        return [result["success_rate"], -result["collision_rate"], result["mean_return"]]

    # --- the loop ----------------------------------------------------------------------------

    def run(self, progress: bool = True) -> dict[str, Any]:
        from tqdm import tqdm

        c = self.config
        self.out.mkdir(parents=True, exist_ok=True)
        if self.resume:
            agent, _ = load_checkpoint(self.latest, expected_actions=c.actions)
            self.load_trainer_state(restore_training_state(self.latest, agent))
            (self.out / CONFIG_FILE).write_text(self._config_bytes().decode())  # total_steps
        else:
            agent = make_agent(c)
            (self.out / CONFIG_FILE).write_text(self._config_bytes().decode())
            run = {
                "name": f"D3DWA-v0__{c.method}__{c.seed}__{int(time.time())}",
                "package_version": __version__,
                "started": datetime.now(UTC).isoformat(timespec="seconds"),
            }
            (self.out / "run.json").write_text(json.dumps(run, indent=2) + "\n")
        logs = MetricsLog(self.out)
        env = make_env(c)
        horizons = list(c.actions.horizons)
        tau_slot = {h: i for i, h in enumerate(horizons)}
        status = "done"
        start = self._start = time.perf_counter()
        wall0 = self._wall0 = self.wall_time
        cpu_start, cpu0 = time.process_time(), self.cpu_time
        bar = tqdm(total=c.total_steps, initial=min(self.env_steps, c.total_steps),
                   disable=not progress, unit="step", desc=c.method,
                   mininterval=1.0 if os.isatty(2) else 30.0)  # fmt: skip
        try:
            with _Stop() as stop:
                obs = None
                if self.resume and self.env_steps < c.total_steps:
                    obs = self._rebuild_episode(env)
                if obs is None and self.env_steps < c.total_steps:
                    obs = self._reset(env, first=not self.resume)
                self.obs = obs
                perf = time.perf_counter
                while self.env_steps < c.total_steps:
                    if stop.requested:
                        status = "interrupted"
                        break
                    t0 = perf()
                    action = agent.act(obs)
                    t1 = perf()
                    obs2, r, terminated, truncated, info = env.step(action)
                    t2 = perf()
                    logs_step = agent.learn(Transition(obs, action, r, obs2, terminated, truncated))
                    t3 = perf()
                    self.timing["act"] += t1 - t0
                    self.timing["env"] += t2 - t1
                    self.timing["learn"] += t3 - t2
                    self.env_steps += 1
                    bar.update(1)
                    ep = self.episode
                    ep.actions.append(int(action))
                    ep.ret += r
                    ep.tau_counts[tau_slot[info["tau"]]] += 1
                    ep.fallbacks += int(info["fallback"])
                    if "losses/td_error" in logs_step:  # tabular: log 0.5 td^2 as its TD loss
                        td = logs_step["losses/td_error"]
                        logs_step = {"losses/td_loss": 0.5 * td * td, "losses/td_abs": abs(td)}
                    for tag, value in logs_step.items():
                        acc = self.loss_acc.setdefault(tag, [0.0, 0])
                        acc[0] += value
                        acc[1] += 1
                    if self.env_steps >= self.next_log:
                        self._log_scalars(logs, agent, env)
                    if terminated or truncated:
                        ep.finished = True
                        self._end_episode(logs, agent, info, bar)
                        if self.env_steps >= self.next_eval:
                            self.next_eval += c.eval_every
                            self._evaluate_and_keep(logs, agent, bar)
                        # the next episode starts before the checkpoint, so a resume
                        # rebuilds it from the saved RNG with no steps to replay
                        obs = obs2
                        if self.env_steps < c.total_steps:
                            obs = self._reset(env, first=False)
                        self.obs = obs
                        if self.env_steps >= self.next_checkpoint:
                            self.next_checkpoint += c.checkpoint_every
                            self.wall_time = wall0 + perf() - start
                            self.cpu_time = cpu0 + time.process_time() - cpu_start
                            self.save_latest(agent, logs)
                    else:
                        obs = self.obs = obs2
                self.wall_time = wall0 + time.perf_counter() - start
                self.cpu_time = cpu0 + time.process_time() - cpu_start
                if (
                    status == "done"
                    and c.eval_every
                    and (not self.evals or self.evals[-1]["step"] != self.env_steps)
                ):
                    self._evaluate_and_keep(logs, agent, bar)
                self.save_latest(agent, logs)
                if status == "done":
                    final_eval = self.evals[-1] if self.evals else None
                    self.save_policy("final", agent, {"selected": "final", "eval": final_eval})
                    if c.keep == "best" and self.best is not None:
                        self._export_run_policy("best")
                    else:
                        self._export_run_policy("final")
        finally:
            bar.close()
            env.close()
            logs.close()
        summary = self.summary(agent, status)
        tmp = self.out / "summary.json.tmp"
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
        os.replace(tmp, self.out / "summary.json")
        return summary

    def _export_run_policy(self, which: str) -> None:
        export_policy(self.out, self.out / "policy", which)

    def _end_episode(self, logs: MetricsLog, agent: Any, info: Mapping[str, Any], bar: Any) -> None:
        ep = self.episode
        self.episodes += 1
        success = int(info["outcome"] == "goal")
        task = str(info["task"])
        if not info.get("route_start", False):  # the curriculum rates the tasks as evaluated
            self.history.setdefault(task, deque(maxlen=self.config.curriculum_window)).append(
                success
            )
        self.recent_success.append(success)
        self.recent_returns.append(ep.ret)
        step = self.env_steps
        n = len(ep.actions)
        horizons = self.config.actions.horizons
        tau_mean = sum(h * k for h, k in zip(horizons, ep.tau_counts, strict=True)) / max(n, 1)
        logs.episode({
            "step": step, "episode": self.episodes, "task": task, "world": info["world"],
            "noise": info["noise"], "route_start": bool(info.get("route_start", False)),
            "outcome": info["outcome"], "return": round(ep.ret, 6),
            "length": n, "epsilon": round(agent.epsilon(), 5), "tau_mean": round(tau_mean, 4),
            "fallbacks": ep.fallbacks,
            "wall_time": round(self._wall0 + time.perf_counter() - self._start, 2),
        })  # fmt: skip
        logs.scalar(step, "charts/episodic_return", ep.ret)
        logs.scalar(step, "charts/episodic_length", n)
        logs.scalar(step, "charts/success_rate", float(np.mean(self.recent_success)))
        logs.scalar(step, "charts/epsilon", agent.epsilon())
        logs.scalar(step, "planner/fallback_rate", ep.fallbacks / max(n, 1))
        logs.histogram(
            step, "planner/tau", {f"{h:g}": k for h, k in zip(horizons, ep.tau_counts, strict=True)}
        )
        bar.set_postfix_str(
            f"ep {self.episodes} {info['world']}: {info['outcome']}, "
            f"success {np.mean(self.recent_success):.2f}, eps {agent.epsilon():.3f}",
            refresh=False,
        )

    def _log_scalars(self, logs: MetricsLog, agent: Any, env: D3DWAEnv) -> None:
        step = self.env_steps
        self.next_log += self.config.log_every
        for tag, (total, count) in sorted(self.loss_acc.items()):
            if count and tag != "charts/epsilon":
                logs.scalar(step, tag, total / count)
        self.loss_acc = {}
        logs.scalar(step, "charts/epsilon", agent.epsilon())
        elapsed = self._wall0 + time.perf_counter() - self._start
        if elapsed > 0:
            logs.scalar(step, "charts/sps", step / elapsed)
        for task, p in zip(env.tasks, env.task_probabilities, strict=True):
            logs.scalar(step, f"curriculum/p_{task}", p)
        logs.flush()

    def _evaluate_and_keep(self, logs: MetricsLog, agent: Any, bar: Any) -> None:
        result = self.evaluate(agent)
        self.evals.append(result)
        self._log_eval(logs, result)
        per_world = " ".join(f"{w}:{'/'.join(o)}" for w, o in result["outcomes"].items())
        if not bar.disable:  # progress on: one line per evaluation on stderr, above the bar
            bar.write(
                f"step {self.env_steps}: greedy eval success {result['success_rate']:.2f}, "
                f"collisions {result['collision_rate']:.2f}, return {result['mean_return']:.3f} "
                f"[{per_world}]",
                file=sys.stderr,
            )
        if self.best is None or self._score(result) >= self._score(self.best):
            self.best = result
            self.save_policy("best", agent, {"selected": "best", "eval": result})

    def summary(self, agent: Any, status: str) -> dict[str, Any]:
        t = self.timing
        return {
            "status": status,
            "method": self.config.method,
            "run_dir": str(self.out),
            "env_steps": self.env_steps,
            "train_steps": agent.train_steps,
            "episodes": self.episodes,
            "wall_time_s": round(self.wall_time, 2),
            "cpu_time_s": round(self.cpu_time, 2),
            "steps_per_s": round(self.env_steps / self.wall_time, 2) if self.wall_time else None,
            "env_steps_per_s": round(self.env_steps / t["env"], 2) if t["env"] else None,
            "updates_per_s": round(agent.train_steps / t["learn"], 2) if t["learn"] else None,
            "timing_s": {k: round(v, 2) for k, v in t.items()},
            "epsilon": agent.epsilon(),
            "best_eval": self.best,
            "final_eval": self.evals[-1] if self.evals else None,
            "policy": str(self.out / "policy") if status == "done" else None,
            "resume": str(self.latest),
        }


def train(
    config: TrainConfig | None,
    out_dir: str | os.PathLike[str],
    resume: bool = False,
    progress: bool = True,
) -> dict[str, Any]:
    """Run (or with ``resume=True`` continue) a training; returns the run summary.

    config: None when resuming takes the run's own config.json; given on resume, it must
    equal the saved one except for total_steps (to extend a run). ConfigError for a bad
    config, an existing run without ``resume``, or nothing to resume. The summary's
    "status" is "done" or "interrupted" (Ctrl-C: ``latest`` was saved, resume later).
    """
    return Trainer(config, out_dir, resume).run(progress)


def export_policy(
    run_dir: str | os.PathLike[str], dest: str | os.PathLike[str], which: str = "best"
) -> Path:
    """Copy a run's policy (checkpoints/<which>) to ``dest`` with config.json and the
    learning curve, without any training state (what ``policies/<method>/`` holds)."""
    run = Path(run_dir)
    src = run / "checkpoints" / which
    agent, meta = load_checkpoint(src)
    extra: dict[str, Any] = {CONFIG_FILE: run / CONFIG_FILE}
    if (run / CURVE_FILE).exists():
        extra[CURVE_FILE] = run / CURVE_FILE
    return save_checkpoint(dest, agent, meta["metadata"], method=meta["method"], extra_files=extra)
