"""The Gymnasium environment ``d3dwa_bullet/D3DWA-v0``: one step = one 0.1 s D3DWA control step.

The agent picks a discrete action (the DWA weights and horizon of this step); the planner
plans with it and the robot drives one control period (``Episode.act``), then the robot
senses (``Episode.observe``). Spaces:

- observation: ``Box(12,)`` float32, the SPEC section 5 vector ``[d_g, theta_g, v, w,
  l_1..l_8]`` with bounds d_g in [0, 1], theta_g, v, w in [-1, 1], sectors in [0, 1];
- action: ``Discrete(100)`` (W = {1, 2, 3}, T = {2, 3, 4, 5} s), or ``Discrete(25)`` with
  ``weights_only=True`` (tau = 4 s), or any ``ActionSet`` passed as ``actions``.

Reward R1 + R2 + R3 (``reward.reward``) on the ground-truth goal and nearest-obstacle
distances the Episode measures, scaled by ``reward_scale`` (0.01 for the D3QN, 1 for
the tabular baseline). Goal and collision *terminate*; the time limit *truncates*.

Every episode draws its task from the env's seeded generator: a world from ``worlds``
(names or files) or, with probability ``generator_prob``, a fresh layout from one of the
``generators`` styles, and a noise profile from ``noise`` (weights ``noise_probs``),
sampled per episode with ``randomization.episode_noise``. The draw is::

    episode_seed = env.np_random.integers(2**63 - 1)
    task, layout, noise, start = SeedSequence(episode_seed).spawn(4)

With ``route_start_prob`` > 0 an episode on one of ``worlds`` may start part-way along
the world's route (``route_start``, a training aid; info["route_start"] says so). So
``reset(seed=s)`` always gives the same episode, bit for bit (DIRECT mode). Worlds of
the evaluation-only groups (``unseen``: US1, H1-H3; ``real``: R1-R3) are refused with
ConfigError unless ``allow_eval_worlds=True``: training never sees them. R-style layouts
from the generators are training material; the R1-R3 files themselves are not.

``reset(options=...)`` can pin the episode: ``{"world": name_or_World, "noise": profile,
"episode_seed": int}`` (used by the greedy evaluation during training).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from d3dwa_bullet.episode import Episode, EpisodeConfig, EpisodeResult
from d3dwa_bullet.errors import ConfigError, D3DWAError
from d3dwa_bullet.learning.reward import reward
from d3dwa_bullet.params import RewardParams
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY, ActionSet
from d3dwa_bullet.world.model import World, load_world

#: World groups that are for evaluation only and never trained on.
EVAL_ONLY_GROUPS = ("unseen", "real")
#: The training worlds of the paper.
TRAIN_WORLDS = ("TS1", "TS2", "TS3", "TS4")
#: Fresh layouts tried per episode before a generator style is given up (each is a
#: different layout seed; a style fails a seed only when no passable layout was found).
GENERATOR_RETRIES = 5


def check_training_world(world: World, where: str = "worlds") -> World:
    """Return ``world`` if it may be trained on, else ConfigError (evaluation-only group)."""
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


def observation_space(dim: int = 12) -> spaces.Box:
    """Box bounds of the observation: d_g [0, 1], theta_g, v, w [-1, 1], sectors [0, 1]."""
    low = np.zeros(dim, dtype=np.float32)
    low[1:4] = -1.0
    high = np.ones(dim, dtype=np.float32)
    return spaces.Box(low, high, dtype=np.float32)


def _probabilities(weights: Sequence[float], n: int, what: str) -> np.ndarray:
    if not weights:
        return np.full(n, 1.0 / n)
    p = np.asarray(weights, dtype=np.float64)
    if p.shape != (n,) or not np.all(np.isfinite(p)) or (p < 0).any() or p.sum() <= 0:
        raise ConfigError(
            f"{what} must be {n} non-negative numbers with a positive sum, got {list(weights)!r}"
        )
    return p / p.sum()


class D3DWAEnv(gym.Env):
    """D3DWA control steps on sampled worlds as a Gymnasium env (see module docstring).

    worlds: world names, files or World objects sampled uniformly (within 1 - generator_prob).
    generators: R-style generator styles ('R1-style', ...), sampled with generator_prob
        (default None: every world and every style equally likely).
    noise: randomisation profile names (or YAML paths), one drawn per episode with
        ``noise_probs`` (uniform if empty); 'none' means noise-free.
    weights_only: the 25-action set with tau = 4 s (ignored when ``actions`` is given).
    reward_scale: multiplies every reward term (RewardParams.scale).
    allow_eval_worlds: permit the unseen/real worlds (evaluation only, never training).
    route_start_prob: probability that an episode on one of ``worlds`` starts at a random
        point of the first ``route_start_span`` of its route instead of its own start
        (``route_start``; never for generated layouts or a world pinned by reset options).
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        worlds: Sequence[str | World] = TRAIN_WORLDS,
        generators: Sequence[str] = (),
        generator_prob: float | None = None,
        noise: str | Sequence[str] = ("none",),
        noise_probs: Sequence[float] = (),
        weights_only: bool = False,
        actions: ActionSet | None = None,
        reward_scale: float = 0.01,
        reward_params: RewardParams | None = None,
        episode_config: EpisodeConfig = EpisodeConfig(),
        allow_eval_worlds: bool = False,
        route_start_prob: float = 0.0,
        route_start_span: float = 0.8,
    ) -> None:
        super().__init__()
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
            from d3dwa_bullet.world.route_start import ROUTE_START_CLEARANCE, route_polyline

            for i, world in enumerate(self.worlds):
                try:
                    self._routes[i] = route_polyline(world)
                except D3DWAError as err:
                    raise ConfigError(
                        f"route_start_prob > 0 needs a route keeping {ROUTE_START_CLEARANCE} m "
                        f"from obstacles in every world: {err}"
                    ) from err
        if self.generators:
            from d3dwa_bullet.world.generator import load_generator

            for style in self.generators:
                load_generator(style)  # unknown style -> UnknownNameError now, not mid-training
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

        if actions is None:
            actions = ACTIONS_WEIGHTS_ONLY if weights_only else ACTIONS_FULL
        self.actions = actions
        self.reward_params = reward_params or RewardParams(scale=float(reward_scale))
        if not (math.isfinite(self.reward_params.scale) and self.reward_params.scale > 0):
            raise ConfigError(f"reward_scale must be > 0, got {self.reward_params.scale!r}")
        self.episode_config = episode_config
        self.observation_space = observation_space(episode_config.observation.dim)
        self.action_space = spaces.Discrete(actions.size)

        self.episode: Episode | None = None
        self.world: World | None = None
        self.task: str | None = None
        self.noise_name = "none"
        self.episode_seed = 0
        self.route_started = False
        """True when the current episode starts part-way along its world's route."""
        self._obs = np.zeros(self.observation_space.shape, dtype=np.float32)

    # --- sampling -------------------------------------------------------------------------

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
            from randomization import load_profile

            self._profiles[name] = load_profile(name)
        return self._profiles[name]

    def _noise(self, name: str, seed: int) -> Any:
        profile = self._profile(name)
        if profile is None:
            return None
        from randomization import episode_noise

        return episode_noise(profile, seed)

    def _draw(
        self, episode_seed: int, options: Mapping[str, Any]
    ) -> tuple[str, World, str, int, bool]:
        """(task, world, noise profile, noise seed, route start) of an episode, from its seed
        alone. The world is a route-start copy (last item True) with probability
        ``route_start_prob`` when it is one of ``worlds``."""
        task_seq, layout_seq, noise_seq, start_seq = np.random.SeedSequence(episode_seed).spawn(4)
        rng = np.random.default_rng(task_seq)
        # draw both choices every time so pinning one option leaves the other's draw unchanged
        task_i = int(rng.choice(len(self.tasks), p=self.task_probabilities))
        noise_i = int(rng.choice(len(self.noise_names), p=self.noise_p))
        noise_name = str(options.get("noise", self.noise_names[noise_i]))
        noise_seed = int(noise_seq.generate_state(1, np.uint32)[0])
        if "world" in options:
            world = resolve_world(options["world"], self.allow_eval_worlds, "reset(options)")
            return world.name, world, noise_name, noise_seed, False
        task = self.tasks[task_i]
        if task_i < len(self.worlds):
            if self.route_start_prob > 0:
                start_rng = np.random.default_rng(start_seq)
                if start_rng.random() < self.route_start_prob:
                    return task, self._route_start(task_i, start_rng), noise_name, noise_seed, True
            return task, self.worlds[task_i], noise_name, noise_seed, False
        from d3dwa_bullet.world.generator import generate_world

        layout_rng = np.random.default_rng(layout_seq)
        error: D3DWAError | None = None
        for _ in range(GENERATOR_RETRIES):
            try:
                return (
                    task,
                    generate_world(task, int(layout_rng.integers(2**31))),
                    noise_name,
                    noise_seed,
                    False,
                )
            except ConfigError as err:  # no passable layout for that seed: draw another
                error = err
        raise ConfigError(f"generator {task!r}: {error}") from error

    # --- gymnasium API --------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self._close_episode()
        options = dict(options or {})
        if "episode_seed" in options:
            episode_seed = int(options["episode_seed"])
        else:
            episode_seed = int(self.np_random.integers(2**63 - 1))
        task, world, noise_name, noise_seed, route_started = self._draw(episode_seed, options)
        self.episode_seed, self.task, self.world, self.noise_name, self.route_started = (
            episode_seed, task, world, noise_name, route_started,
        )  # fmt: skip
        self.episode = Episode(
            world,
            seed=noise_seed,
            noise=self._noise(noise_name, noise_seed),
            noise_name=noise_name,
            config=self.episode_config,
        )
        obs = self._observation(self.episode.observe())
        if self.episode.outcome is not None:
            outcome = self.episode.outcome
            self._close_episode()
            raise ConfigError(
                f"world {world.name!r}: the episode is over before it starts ({outcome}); "
                "check its start pose and goal"
            )
        return obs, self._info(None)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        ep = self.episode
        if ep is None or ep.outcome is not None:
            raise RuntimeError("D3DWAEnv.step: call reset() first (the episode is over)")
        index = int(action)
        if not self.action_space.contains(index):
            raise ConfigError(
                f"D3DWAEnv.step: action {action!r} not in Discrete({self.actions.size})"
            )
        planner_action = self.actions.decode(index)
        d_goal, d_obs = ep.goal_distance, ep.obstacle_distance
        plan = ep.act(index, planner_action)
        obs = self._observation(ep.observe())
        outcome = ep.outcome
        r = reward(
            outcome, d_goal, ep.goal_distance, d_obs, ep.obstacle_distance, self.reward_params
        )  # type: ignore[arg-type]
        terminated = outcome in ("goal", "collision")
        truncated = outcome == "timeout"
        info = self._info(outcome)
        info.update(
            action=index,
            tau=planner_action.tau,
            weights=(planner_action.wp, planner_action.wc, planner_action.ws),
            fallback=bool(plan.fallback),
        )
        return obs, r, terminated, truncated, info

    def close(self) -> None:
        self._close_episode()
        super().close()

    # --- helpers --------------------------------------------------------------------------

    def result(self, method: str = "d3dwa") -> EpisodeResult:
        """Metrics and log of the current (or just finished) episode."""
        if self.episode is None:
            raise RuntimeError("D3DWAEnv.result: no episode (call reset() first)")
        return self.episode.result(method)

    def _observation(self, obs: np.ndarray) -> np.ndarray:
        space = self.observation_space
        np.clip(obs, space.low, space.high, out=self._obs, casting="unsafe")
        return self._obs.copy()

    def _info(self, outcome: str | None) -> dict[str, Any]:
        ep = self.episode
        assert ep is not None and self.world is not None
        return {
            "outcome": outcome,
            "is_success": outcome == "goal",
            "world": self.world.name,
            "task": self.task,
            "noise": self.noise_name,
            "episode_seed": self.episode_seed,
            "route_start": self.route_started,
            "goal_distance": ep.goal_distance,
            "obstacle_distance": ep.obstacle_distance,
        }

    def _route_start(self, world_index: int, rng: np.random.Generator) -> World:
        from d3dwa_bullet.world.route_start import route_start

        world = self.worlds[world_index]
        return route_start(world, self._routes[world_index], rng, self.route_start_span)

    def _close_episode(self) -> None:
        if self.episode is not None:
            self.episode.close()
            self.episode = None
