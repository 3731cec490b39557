"""The controller of an episode: what chooses the DWA parameters of each control step.

A controller maps an observation to (action index, PlannerAction); the planner then does the
rest. A fixed method returns a constant; a reference method draws an index uniformly from its
action set, from a generator the episode seed seeds (:meth:`Controller.reset`); a learned
method runs a greedy policy (any callable from an observation to an index). Any of them may
keep each choice for a decision period of ``hold`` control steps. A chooser from outside the
package implements the same surface (``actions``, ``hold``, ``observation``, ``reset``,
``choose``: docs/design/external-methods.md#external-methods); a velocity planner from outside replaces the DWA
itself (``velocity``).

Pure: numpy only. Building the controller of a method, its policy loaded from a checkpoint or
an ONNX file, is :func:`d3dwa_bullet.controllers.make_controller`'s job.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.planning.actions import ActionSet, PlannerAction
from d3dwa_bullet.planning.velocity_command import LocalPlanner

#: The tag that keeps a reference method's draws a stream of their own: its generator is
#: seeded by SeedSequence([episode seed, RANDOM_STREAM]), which no other draw of an episode
#: uses (noise and the env's tasks spawn from SeedSequence(episode seed)). ASCII "rand".
RANDOM_STREAM = 0x72616E64


@dataclass
class Controller:
    """Chooses (action index, PlannerAction) from an observation; index -1 for fixed methods.
    ``observation`` is the kind it reads, which the episode loop and the replay build.

    Whatever drives a controller through an episode calls :meth:`reset` with the episode
    seed before the first step (``run_episode`` does; a bag replay with its ``seed``)."""

    name: str
    fixed: PlannerAction | None = None
    policy: Callable[[np.ndarray], Any] | None = None
    actions: ActionSet | None = None
    source: str = ""
    observation: str = "paper"
    uniform: bool = False
    """Draws its index uniformly from ``actions`` every step (a reference method), ignoring
    the observation."""
    hold: int = 1
    """Control steps each chosen action is kept for: a policy trained with ``decision_steps``
    k > 1 (beyond the paper, docs/design/agent.md#decision-period) chooses every k steps."""
    scan_filter: str = "none"
    """The scan filter its policy trained behind (beyond the paper, docs/design/scan-filter.md#scan-filter):
    whatever drives it checks its own filter is this one (``check_driven_filter``)."""
    origin: str = ""
    """Where a method from outside the package came from (``module:Name (distribution
    version)``, or a file and its SHA-256), for its results rows; empty for a built-in method."""
    velocity: LocalPlanner | None = None
    """A local planner that replaces the DWA (a velocity planner from outside the package:
    ``planning.velocity_command``); None: the DWA plans with the chosen parameters."""
    _rng: np.random.Generator | None = field(default=None, init=False, repr=False)
    _held: tuple[int, int] | None = field(default=None, init=False, repr=False)

    def reset(self, episode_seed: int) -> None:
        """Start an episode. A uniform controller seeds its own generator from the episode
        seed (``RANDOM_STREAM``): the same seed gives the same actions, and no other stream of
        the episode is drawn from. The others keep no state across steps: nothing to do.
        ConfigError for a seed numpy cannot take (negative). A held action ends here."""
        self._held = None
        if not self.uniform:
            return
        if int(episode_seed) < 0:
            raise ConfigError(
                f"--seed {episode_seed}: method {self.name!r} draws its actions from the "
                "episode seed, which must be >= 0"
            )
        sequence = np.random.SeedSequence([int(episode_seed), RANDOM_STREAM])
        self._rng = np.random.default_rng(sequence)

    def __call__(self, obs: np.ndarray) -> tuple[int, PlannerAction]:
        if self.fixed is not None:
            return -1, self.fixed
        if self._held is not None and self._held[1] > 0:
            index, left = self._held
            self._held = (index, left - 1)
            return index, self.actions.decode(index)  # type: ignore[union-attr]
        if self.uniform:
            if self._rng is None:
                raise RuntimeError(
                    f"controller {self.name!r} draws from the episode seed: call "
                    "reset(episode_seed) before the episode's first step"
                )
            index = int(self._rng.integers(len(self.actions)))  # type: ignore[arg-type]
        else:
            index = int(self.policy(obs))  # type: ignore[misc]
        if self.hold > 1:
            self._held = (index, self.hold - 1)
        return index, self.actions.decode(index)  # type: ignore[union-attr]

    def choose(self, obs: np.ndarray) -> int:
        """The action index of this step (-1 for a fixed method): the chooser protocol's call
        (docs/design/external-methods.md#external-methods)."""
        return self(obs)[0]
