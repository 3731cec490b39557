"""Can an action set steer the DWA to the goal at all? Two probes of a world.

A learned policy only picks one of the action set's (wp, wc, ws, tau) tuples per step; the
DWA does the rest. When no method reaches a goal, these probes separate "the policy has
not learned it" from "these choices cannot do it":

``fixed_action_outcome``
    one episode with the same action at every step (the fixed baselines are three of these);
``run_oracle``
    a greedy map-aware chooser: at every step it plans with *every* action, rolls each
    resulting command out as a unicycle over that action's tau from the estimated pose, and
    executes the action whose end point has the shortest route to the goal on the inflated
    map (:func:`~d3dwa_bullet.world.routes.geodesic_field`). It sees the map, which no policy
    does, so it is an optimistic probe, not a method: it never enters a results table.

Both are ordinary episodes (same simulator, planner and termination), so their outcome,
time and path are those of :class:`~d3dwa_bullet.episode.EpisodeResult`.
"""

from __future__ import annotations

import numpy as np

from d3dwa_bullet.episode import Episode, EpisodeConfig, EpisodeResult, run_episode
from d3dwa_bullet.geometry import arc_step
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.controller import Controller
from d3dwa_bullet.planning.observation import goal_in_body
from d3dwa_bullet.planning.planner import plan
from d3dwa_bullet.world.grid import Grid
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.routes import geodesic_field

ORACLE = "oracle"
"""Method name of the oracle's episodes."""


def oracle_choice(
    pose: tuple[float, float, float],
    velocity: tuple[float, float],
    points: np.ndarray,
    goal: tuple[float, float],
    actions: ActionSet,
    route: Grid,
    config: EpisodeConfig,
) -> int:
    """Index of the action whose DWA command ends closest to the goal along the map."""
    goal_body = goal_in_body(pose, goal)
    plans = [plan(velocity, points, goal_body, a, config.planner) for a in actions.actions]
    # each command held for its action's horizon: the exact unicycle arc of the odometry
    ends = [
        arc_step(*pose, p.v, p.w, a.tau)[:2] for p, a in zip(plans, actions.actions, strict=True)
    ]
    cells = route.cell_of(np.asarray(ends))
    remaining = route.values[cells[:, 0], cells[:, 1]]
    remaining[[p.fallback for p in plans]] = np.inf
    return int(np.argmin(remaining))  # the first of equals; 0 if every end is blocked


def run_oracle(
    world: World,
    actions: ActionSet,
    seed: int = 0,
    config: EpisodeConfig = EpisodeConfig(),
    route: Grid | None = None,
) -> EpisodeResult:
    """One noise-free episode driven by :func:`oracle_choice` (about 100 plans per step)."""
    route = geodesic_field(world) if route is None else route
    with Episode(world, seed, None, "none", config) as ep:
        while True:
            ep.observe()
            if ep.outcome is not None:
                break
            pose, velocity = ep.estimate
            index = oracle_choice(pose, velocity, ep.points, world.goal, actions, route, config)
            ep.act(index, actions.decode(index))
        return ep.result(ORACLE)


def fixed_action_outcome(
    world: World, actions: ActionSet, index: int, seed: int = 0,
    config: EpisodeConfig = EpisodeConfig(),
) -> EpisodeResult:  # fmt: skip
    """One noise-free episode with action ``index`` at every step."""
    action = actions.decode(index)
    return run_episode(world, Controller(f"a{index}", fixed=action), seed, config=config)
