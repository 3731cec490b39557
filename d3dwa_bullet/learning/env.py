"""The Gymnasium environment ``d3dwa_bullet/D3DWA-v0``: one step = one 0.1 s D3DWA control step.

The agent picks a discrete action (the DWA weights and horizon of this step); the planner
plans with it and the robot drives one control period (``Episode.act``), then the robot
senses (``Episode.observe``). Spaces:

- observation: ``Box(12,)`` float32, the vector of docs/design/observation.md#observation ``[d_g, theta_g, v, w,
  l_1..l_8]`` with bounds d_g in [0, 1], theta_g, v, w in [-1, 1], sectors in [0, 1]; with
  ``observation="progress"`` ``Box(17,)``, five more entries in [0, 1] (``planning.progress``);
- action: ``Discrete(100)`` (W = {1, 2, 3}, T = {2, 3, 4, 5} s), or ``Discrete(25)`` with
  ``weights_only=True`` (tau = 4 s), or any ``ActionSet`` passed as ``actions``.

Reward R1 + R2 + R3 (``reward.reward``) on the ground-truth goal and nearest-obstacle
distances the Episode measures, scaled by ``reward_scale`` (0.01 for the D3QN, 1 for
the tabular baseline), and a stall penalty if ``reward_params`` sets one. Goal and
collision *terminate*; the time limit *truncates*.

Every episode draws its task from the env's seeded generator (``tasks.TaskSampler``): a
world from ``worlds`` (names or files) or, with probability ``generator_prob``, a fresh
layout from one of the ``generators`` styles, and a noise profile from ``noise`` (weights
``noise_probs``), sampled per episode with ``randomization.episode_noise``. The draw is::

    episode_seed = env.np_random.integers(2**63 - 1)
    task, layout, noise, start = SeedSequence(episode_seed).spawn(4)

With ``route_start_prob`` > 0 an episode on one of ``worlds`` may start part-way along
the world's route (``route_start``, a training aid; info["route_start"] says so). So
``reset(seed=s)`` always gives the same episode, bit for bit (DIRECT mode). Worlds of
the evaluation-only groups (``unseen``: US1, H1-H3; ``real``: R1-R3) are refused with
ConfigError unless ``allow_eval_worlds=True``: training never sees them.

``reset(options=...)`` can pin the episode: ``{"world": name_or_World, "noise": profile,
"episode_seed": int}`` (used by the greedy evaluation during training), and set the task
weights the draw uses (``{"task_weights": [...]}``, a curriculum's hook that also works
through a vector env's reset). ``reset_rng_state`` is the env RNG's state just before the
current episode's draw; ``rebuild`` re-runs an episode from that state and its actions
(exact resumption of a training run).

Rendering (``render_mode``, checked at construction): ``"rgb_array"`` makes ``render()``
return a top-down (H, W, 3) uint8 RGB frame of the world, the robot's body and footprint at
its true pose, the current scan and the rollout the planner chose at the last step
(``learning.render``); ``"human"`` runs the episodes in the PyBullet GUI instead of DIRECT
mode and paces ``step`` to ``metadata["render_fps"]`` (the control rate, 10 Hz), so
``render()`` has nothing to return; on Linux without a display (no DISPLAY or
WAYLAND_DISPLAY) it is refused at construction. Rendering never changes an episode: the same
seed gives the same steps with or without it.

Beyond the paper (off by default), ``decision_steps=k`` holds each action for k control steps
and sums their rewards (``learning.decision_period``).

``step`` refuses (ConfigError) an action that is not an int or numpy integer in the space: a
float or a bool is not truncated; ``reset`` refuses option keys outside ``tasks.RESET_OPTIONS``.

``global_plan="scan"`` (or ``"map"``, or a ``GlobalPlanParams``) makes the agent follow a global
plan's carrot, as ``--global-plan`` does (docs/design/global-plan.md).

``recovery="nav2"`` (or a ``RecoveryParams``) puts the recovery layer around the agent, as
``--recovery`` does for ``d3dwa run`` (docs/design/recovery.md#recovery): while it recovers it drives
and the action of that step is not used; ``info["recovery"]`` names the behaviour (else None).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from d3dwa_bullet.episode import Episode, EpisodeConfig, EpisodeResult
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.decision_period import StepResult, check_decision_steps, held_step
from d3dwa_bullet.learning.rebuild import Rebuild
from d3dwa_bullet.learning.render import (
    Pacer,
    RenderParams,
    TopDownCanvas,
    check_render_mode,
    episode_frame,
)
from d3dwa_bullet.learning.reward import reward
from d3dwa_bullet.learning.tasks import TRAIN_WORLDS, TaskSampler, check_reset_options
from d3dwa_bullet.params import RecoveryParams, RewardParams, recovery_params
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY, ActionSet
from d3dwa_bullet.planning.global_plan_params import GlobalPlanParams, global_plan_params
from d3dwa_bullet.planning.observation_kinds import (
    check_observation_kind,
    observation_layout,
    observation_low,
)
from d3dwa_bullet.planning.planner import PlannerAction
from d3dwa_bullet.timing import StageClock, perf
from d3dwa_bullet.world.model import World


def observation_space(dim: int = 12, kind: str = "paper") -> spaces.Box:
    """Box bounds of an observation kind's entries: d_g [0, 1], theta_g, v, w [-1, 1], sectors
    [0, 1], at every lag of the history kind; the progress entries [0, 1]. ``dim`` must be
    the kind's (12 for the paper's)."""
    layout = observation_layout(kind)
    if dim != len(layout):
        raise ConfigError(
            f"observation_space: the {kind!r} kind has {len(layout)} entries, not {dim}"
        )
    return spaces.Box(observation_low(layout), np.ones(dim, dtype=np.float32), dtype=np.float32)


class D3DWAEnv(Rebuild, gym.Env):
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
    render_mode: None, "rgb_array" (top-down frames from ``render()``) or "human" (the
        PyBullet GUI, paced to the control rate).
    observation: the kind the agent reads, "paper" (12-d) or "progress" (17-d).
    """

    metadata: dict[str, Any] = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

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
        render_mode: str | None = None,
        recovery: str | RecoveryParams | None = None,
        observation: str = "paper",
        global_plan: str | GlobalPlanParams | None = None,
        decision_steps: int = 1,
    ) -> None:
        super().__init__()
        self.decision_steps = check_decision_steps(decision_steps)
        self.observation_kind = check_observation_kind(observation, "D3DWAEnv observation")
        if recovery is not None:
            params = recovery if isinstance(recovery, RecoveryParams) else recovery_params(recovery)
            episode_config = replace(episode_config, recovery=params)
        if global_plan is not None:
            plan = (
                global_plan
                if isinstance(global_plan, GlobalPlanParams)
                else global_plan_params(global_plan)
            )
            episode_config = replace(episode_config, global_plan=plan)
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        if episode_config.sim.control_hz != self.metadata["render_fps"]:
            self.metadata = {**self.metadata, "render_fps": episode_config.sim.control_hz}
        self.sampler = TaskSampler(
            worlds=worlds,
            generators=generators,
            generator_prob=generator_prob,
            noise=noise,
            noise_probs=noise_probs,
            allow_eval_worlds=allow_eval_worlds,
            route_start_prob=route_start_prob,
            route_start_span=route_start_span,
        )
        """Draws each episode's world, noise profile and start (``tasks.TaskSampler``)."""
        if actions is None:
            actions = ACTIONS_WEIGHTS_ONLY if weights_only else ACTIONS_FULL
        self.actions = actions
        self.reward_params = reward_params or RewardParams(scale=float(reward_scale))
        if not (math.isfinite(self.reward_params.scale) and self.reward_params.scale > 0):
            raise ConfigError(f"reward_scale must be > 0, got {self.reward_params.scale!r}")
        self.episode_config = episode_config
        self.observation_space = observation_space(
            len(observation_layout(observation)), observation
        )
        self.action_space = spaces.Discrete(actions.size)

        self.episode: Episode | None = None
        self.world: World | None = None
        self.task: str | None = None
        self.noise_name = "none"
        self.episode_seed = 0
        self.route_started = False
        """True when the current episode starts part-way along its world's route."""
        self._obs = np.zeros(self.observation_space.shape, dtype=np.float32)
        self.reset_rng_state: dict[str, Any] | None = None
        """The env RNG's state just before the current episode's draw (see ``rebuild``)."""
        self.clock = StageClock()
        """Seconds per stage over the finished episodes (``stage_seconds`` adds the current)."""
        self.last_action: PlannerAction | None = None
        """The planner parameters of the current episode's last step (None before it)."""
        self._canvas: TopDownCanvas | None = None
        self._pacer = Pacer(self.metadata["render_fps"])

    # --- sampling -------------------------------------------------------------------------

    @property
    def tasks(self) -> tuple[str, ...]:
        """Task names: one per world, then one per generator style."""
        return self.sampler.tasks

    @property
    def task_probabilities(self) -> np.ndarray:
        """Probability of each task in ``tasks`` for the next episode."""
        return self.sampler.task_probabilities

    def set_task_weights(self, weights: Sequence[float] | Mapping[str, float]) -> None:
        """Multiply each task's base probability by a weight (a curriculum's hook); see
        ``TaskSampler.set_task_weights``."""
        self.sampler.set_task_weights(weights)

    # --- gymnasium API --------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self._close_episode()
        t0 = perf()
        options = dict(options or {})
        check_reset_options(options)
        if "task_weights" in options:
            self.set_task_weights(options.pop("task_weights"))
        self.reset_rng_state = self.np_random.bit_generator.state
        if "episode_seed" in options:
            episode_seed = int(options["episode_seed"])
        else:
            episode_seed = int(self.np_random.integers(2**63 - 1))
        task, world, noise_name, noise_seed, route_started = self.sampler.draw(
            episode_seed, options
        )
        self.episode_seed, self.task, self.world, self.noise_name, self.route_started = (
            episode_seed, task, world, noise_name, route_started,
        )  # fmt: skip
        self.episode = Episode(
            world,
            seed=noise_seed,
            noise=self.sampler.noise(noise_name, noise_seed),
            noise_name=noise_name,
            config=self.episode_config,
            gui=self.render_mode == "human",
            observation=self.observation_kind,
        )
        self.last_action = None
        self.clock.charge("reset", t0)
        obs = self._observation(self.episode.observe())
        if self.episode.outcome is not None:
            outcome = self.episode.outcome
            self._close_episode()
            raise ConfigError(
                f"world {world.name!r}: the episode is over before it starts ({outcome}); "
                "check its start pose and goal"
            )
        return obs, self._info(None)

    def step(self, action: Any) -> StepResult:
        ep = self.episode
        if ep is None or ep.outcome is not None:
            raise RuntimeError("D3DWAEnv.step: call reset() first (the episode is over)")
        if isinstance(action, bool) or not self.action_space.contains(action):
            raise ConfigError(
                f"D3DWAEnv.step: action {action!r} ({type(action).__name__}) is not an integer "
                f"in Discrete({self.actions.size}), i.e. 0..{self.actions.size - 1}"
            )
        return held_step(self._control_step, int(action), self.decision_steps)

    def _control_step(self, index: int) -> StepResult:
        ep = self.episode  # one 0.1 s control step with a checked action index
        assert ep is not None
        t0 = perf()
        planner_action = self.actions.decode(index)
        d_goal, d_obs = ep.goal_distance, ep.obstacle_distance
        plan = ep.act(index, planner_action)
        self.last_action = planner_action
        obs = self._observation(ep.observe())
        outcome = ep.outcome
        r = reward(
            outcome, d_goal, ep.goal_distance, d_obs, ep.obstacle_distance, self.reward_params,
            ep.stalled_s,
        )  # type: ignore[arg-type]  # fmt: skip
        terminated = outcome in ("goal", "collision")
        truncated = outcome == "timeout"
        info = self._info(outcome)
        info.update(
            action=index,
            tau=planner_action.tau,
            weights=(planner_action.wp, planner_action.wc, planner_action.ws),
            fallback=bool(plan.fallback),
            recovery=None if ep.last_recovery is None else ep.last_recovery.behaviour,
        )
        self.clock.charge("step", t0)
        if self.render_mode == "human":
            self._pacer.wait()
        return obs, r, terminated, truncated, info

    def render(self) -> np.ndarray | None:
        """The current frame: (H, W, 3) uint8 with ``render_mode="rgb_array"``, else None.

        The frame's size is fixed per world (``learning.render.TopDownCanvas``).
        """
        if self.render_mode != "rgb_array":
            if self.render_mode is None:
                gym.logger.warn("D3DWAEnv.render: no render_mode was given; nothing to draw")
            return None
        ep = self.episode
        if ep is None or self.world is None:
            raise RuntimeError("D3DWAEnv.render: call reset() first")
        if self._canvas is None or self._canvas.world is not self.world:
            self._canvas = TopDownCanvas(
                self.world,
                RenderParams(goal_tolerance=self.episode_config.termination.goal_tolerance),
                self.episode_config.planner.footprint,
            )
        return episode_frame(self._canvas, ep, self.last_action)

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

    def stage_seconds(self) -> dict[str, float]:
        """Seconds per stage (reset, physics, lidar, noise, estimator, observation, planner)
        over every episode so far, the current one included."""
        total = StageClock()
        total.merge(self.clock.seconds)
        if self.episode is not None:
            total.merge(self.episode.sim.clock.seconds)
        return total.seconds

    def _close_episode(self) -> None:
        if self.episode is not None:
            self.clock.merge(self.episode.sim.clock.seconds)
            self.episode.close()
            self.episode = None
