"""What each training episode runs on: a world or a generated layout, a noise profile, a start.

A *task* is one of the training ``worlds`` (names or files) or one of the ``generators``
styles (a fresh random layout per episode). ``TaskSampler.draw`` derives everything of an
episode from its seed alone::

    task, layout, noise, start = SeedSequence(episode_seed).spawn(4)

so the same seed gives the same episode, bit for bit. Tasks are drawn with their base
probabilities (worlds share ``1 - generator_prob``, styles share ``generator_prob``) times
the weights a curriculum sets (``set_task_weights``); the noise profile is drawn from
``noise`` with ``noise_probs`` and sampled per episode with ``randomization.episode_noise``.
With ``route_start_prob`` > 0 an episode on a training world may start part-way along its
route (``world.route_start``), a training aid; generated layouts and pinned worlds never do.

Worlds of the evaluation-only groups (``unseen``: US1, H1-H3; ``real``: R1-R3) are refused
with ConfigError unless allowed: training never sees them. R-style layouts from the
generators are training material; the R1-R3 files themselves are not.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from d3dwa_bullet.errors import ConfigError, D3DWAError
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.world.barn_style import is_eval_world
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE
from d3dwa_bullet.world.layout_styles import check_style, generate_layout
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.native import EVAL_ONLY_GROUPS
from d3dwa_bullet.world.registry import load_world, world_names
from d3dwa_bullet.world.route_start import ROUTE_START_CLEARANCE, route_polyline, route_start
from randomization import episode_noise, load_profile

#: The training worlds of the paper: the shipped worlds of group "train" (TS1..TS4).
TRAIN_WORLDS = world_names("train")
#: Fresh layouts tried per episode before a generator style is given up (each is a
#: different layout seed; a style fails a seed only when no passable layout was found).
RESET_OPTIONS = ("world", "noise", "episode_seed", "task_weights")
"""The keys the env's ``reset(options=...)`` reads (``learning.env``); any other is refused."""


def check_reset_options(options: Mapping[str, Any]) -> None:
    """ConfigError naming reset option keys outside RESET_OPTIONS, and the known ones."""
    unknown = sorted(map(str, set(options) - set(RESET_OPTIONS)))
    if unknown:
        raise ConfigError(
            f"D3DWAEnv.reset: unknown option(s) {unknown}; known: {', '.join(RESET_OPTIONS)}"
        )


GENERATOR_RETRIES = 5


def check_training_world(world: World, where: str = "worlds") -> World:
    """Return ``world`` if it may be trained on, else ConfigError (evaluation-only group, or a
    BARN-style world of an evaluation seed)."""
    if is_eval_world(world):
        raise ConfigError(
            f"{where}: world {world.name!r} is a BARN-style world of an evaluation seed (>= 2^31); "
            "train on the BARN-style generator (generators: [BARN-style]) or seeds below 2^31"
        )
    if world.group in EVAL_ONLY_GROUPS:
        raise ConfigError(
            f"{where}: world {world.name!r} ({world.source}) is in the evaluation-only group "
            f"{world.group!r}; training and its evaluation use training worlds only "
            f"(e.g. {', '.join(TRAIN_WORLDS)} or generated layouts such as R2-style)"
        )
    return world


def resolve_world(spec: str | World, allow_eval_worlds: bool, where: str = "worlds") -> World:
    """A World from a name, a file path or a World, checked for training unless allowed."""
    world = spec if isinstance(spec, World) else load_world(spec)
    return world if allow_eval_worlds else check_training_world(world, where)


def _probabilities(weights: Sequence[float], n: int, what: str) -> np.ndarray:
    if not weights:
        return np.full(n, 1.0 / n)
    p = np.asarray(weights, dtype=np.float64)
    if p.shape != (n,) or not np.all(np.isfinite(p)) or (p < 0).any() or p.sum() <= 0:
        raise ConfigError(
            f"{what} must be {n} non-negative numbers with a positive sum, got {list(weights)!r}"
        )
    return p / p.sum()


class EpisodeTask(NamedTuple):
    """One episode's draw: what ``TaskSampler.draw`` returns."""

    task: str
    """Task name: the world's name, or the generator style of a generated layout."""
    world: World
    """The world to run (a route-start copy when ``route_start``)."""
    noise_name: str
    """Randomisation profile name ('none': noise-free)."""
    noise_seed: int
    """Seed of the episode's noise draw and simulator."""
    route_start: bool
    """The episode starts part-way along the world's route."""


class TaskSampler:
    """Seeded per-episode choice of world or layout, noise profile and start (module docstring).

    worlds: world names, files or World objects sampled uniformly (within 1 - generator_prob).
    generators: generator styles ('R1-style', ...), sampled with generator_prob (default
        None: every world and every style equally likely).
    noise: randomisation profile names (or YAML paths), one drawn per episode with
        ``noise_probs`` (uniform if empty); 'none' means noise-free.
    allow_eval_worlds: permit the unseen/real worlds (evaluation only, never training).
    route_start_prob, route_start_span: probability that an episode on one of ``worlds``
        starts at a random point of the first ``route_start_span`` of its route.
    Every name is checked here (ConfigError, UnknownNameError, ProfileError), not mid-training.
    """

    def __init__(
        self,
        worlds: Sequence[str | World] = TRAIN_WORLDS,
        generators: Sequence[str] = (),
        generator_prob: float | None = None,
        noise: str | Sequence[str] = ("none",),
        noise_probs: Sequence[float] = (),
        allow_eval_worlds: bool = False,
        route_start_prob: float = 0.0,
        route_start_span: float = 0.8,
    ) -> None:
        if not 0.0 <= route_start_prob <= 1.0:
            raise ConfigError(f"route_start_prob must be in [0, 1], got {route_start_prob!r}")
        if not 0.0 < route_start_span < 1.0:
            raise ConfigError(f"route_start_span must be in (0, 1), got {route_start_span!r}")
        self.route_start_prob = float(route_start_prob)
        self.route_start_span = float(route_start_span)
        self._routes: dict[int, np.ndarray] = {}
        self.allow_eval_worlds = bool(allow_eval_worlds)
        self.worlds = tuple(resolve_world(w, self.allow_eval_worlds) for w in worlds)
        self.generators = tuple(str(g) for g in generators)
        if self.route_start_prob > 0:  # a world without a route fails now, not mid-training
            for i, world in enumerate(self.worlds):
                try:
                    self._routes[i] = route_polyline(world)
                except D3DWAError as err:
                    raise ConfigError(
                        f"route_start_prob > 0 needs a route keeping {ROUTE_START_CLEARANCE} m "
                        f"from obstacles in every world: {err}"
                    ) from err
        for style in self.generators:
            check_style(style)  # unknown style -> UnknownNameError now, not mid-training
        n_tasks = len(self.worlds) + len(self.generators)
        p_gen = (
            len(self.generators) / max(n_tasks, 1)
            if generator_prob is None
            else float(generator_prob)
        )
        if not 0.0 <= p_gen <= 1.0:
            raise ConfigError(f"generator_prob must be in [0, 1], got {generator_prob!r}")
        if not self.worlds and not self.generators:
            raise ConfigError("the env needs at least one world or generator style to sample")
        if p_gen > 0 and not self.generators:
            raise ConfigError(f"generator_prob = {p_gen} but no generator styles are given")
        if not self.worlds:
            p_gen = 1.0
        elif not self.generators:
            p_gen = 0.0
        self.generator_prob = p_gen
        self.tasks: tuple[str, ...] = tuple(w.name for w in self.worlds) + self.generators
        """Task names: one per world, then one per generator style."""
        base = [(1.0 - p_gen) / len(self.worlds)] * len(self.worlds) if self.worlds else []
        base += [p_gen / len(self.generators)] * len(self.generators) if self.generators else []
        self._task_base = np.asarray(base, dtype=np.float64)
        self._task_weights = np.ones(len(self.tasks))

        self.noise_names = (noise,) if isinstance(noise, str) else tuple(noise)
        if not self.noise_names:
            raise ConfigError("noise: give at least one profile name ('none' for noise-free)")
        self.noise_p = _probabilities(noise_probs, len(self.noise_names), "noise_probs")
        self._profiles: dict[str, Any] = {}
        for name in self.noise_names:
            self._profile(name)  # unknown profile -> ProfileError now

    @property
    def task_probabilities(self) -> np.ndarray:
        """Probability of each task in ``tasks`` for the next episode."""
        p = self._task_base * self._task_weights
        return p / p.sum()

    def set_task_weights(self, weights: Sequence[float] | Mapping[str, float]) -> None:
        """Multiply each task's base probability by a weight (a curriculum's hook).

        weights: one number per task in ``tasks`` order, or a mapping task -> weight
        (missing tasks keep weight 1). Must leave some task with a positive probability.
        """
        if isinstance(weights, Mapping):
            unknown = sorted(set(weights) - set(self.tasks))
            if unknown:
                raise ConfigError(
                    f"set_task_weights: unknown task(s) {unknown}; tasks {self.tasks}"
                )
            w = np.array([float(weights.get(t, 1.0)) for t in self.tasks])
        else:
            w = np.asarray(weights, dtype=np.float64)
        if w.shape != (len(self.tasks),) or not np.all(np.isfinite(w)) or (w < 0).any():
            raise ConfigError(
                f"set_task_weights: need {len(self.tasks)} finite weights >= 0, got {weights!r}"
            )
        if (self._task_base * w).sum() <= 0:
            raise ConfigError("set_task_weights: every task would have probability 0")
        self._task_weights = w

    def _profile(self, name: str) -> Any:
        if name == "none":
            return None
        if name not in self._profiles:
            self._profiles[name] = load_profile(name)
        return self._profiles[name]

    def noise(self, name: str, seed: int) -> NoiseModel | None:
        """The noise model of profile ``name`` sampled with ``seed`` (None for 'none')."""
        profile = self._profile(name)
        if profile is None:
            return None
        return episode_noise(profile, seed)

    def draw(self, episode_seed: int, options: Mapping[str, Any]) -> EpisodeTask:
        """The task, world, noise profile, noise seed and route start of an episode, from its
        seed alone. ``options`` may pin ``"world"`` (name, file or World; checked for training
        unless allowed) and ``"noise"``; the other draws stay what the seed gives."""
        task_seq, layout_seq, noise_seq, start_seq = np.random.SeedSequence(episode_seed).spawn(4)
        rng = np.random.default_rng(task_seq)
        # draw both choices every time so pinning one option leaves the other's draw unchanged
        task_i = int(rng.choice(len(self.tasks), p=self.task_probabilities))
        noise_i = int(rng.choice(len(self.noise_names), p=self.noise_p))
        noise_name = str(options.get("noise", self.noise_names[noise_i]))
        noise_seed = int(noise_seq.generate_state(1, np.uint32)[0])
        if "world" in options:
            world = resolve_world(options["world"], self.allow_eval_worlds, "reset(options)")
            return EpisodeTask(world.name, world, noise_name, noise_seed, False)
        task = self.tasks[task_i]
        if task_i < len(self.worlds):
            if self.route_start_prob > 0:
                start_rng = np.random.default_rng(start_seq)
                if start_rng.random() < self.route_start_prob:
                    world = self.worlds[task_i]
                    moved = route_start(
                        world, self._routes[task_i], start_rng, self.route_start_span
                    )
                    return EpisodeTask(task, moved, noise_name, noise_seed, True)
            return EpisodeTask(task, self.worlds[task_i], noise_name, noise_seed, False)
        layout_rng = np.random.default_rng(layout_seq)
        error: D3DWAError | None = None
        for _ in range(GENERATOR_RETRIES):
            try:
                layout = generate_layout(task, int(layout_rng.integers(UNSEEN_LAYOUT_SEED_BASE)))
            except ConfigError as err:  # no passable layout for that seed: draw another
                error = err
            else:
                return EpisodeTask(task, layout, noise_name, noise_seed, False)
        raise ConfigError(f"generator {task!r}: {error}") from error
