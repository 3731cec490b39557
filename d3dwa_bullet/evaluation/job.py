"""One episode to run: :class:`Job` (world, method, training seed, seed, noise) and the name of
its log file. Its own module so that both :mod:`~d3dwa_bullet.evaluation.jobs` (which runs jobs)
and :mod:`~d3dwa_bullet.evaluation.reuse` (which takes them from another directory) import it,
and neither imports the other for it."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from d3dwa_bullet.evaluation.repeats import Key
from d3dwa_bullet.evaluation.results import policy_seed_cell
from d3dwa_bullet.evaluation.scores import score_cells
from d3dwa_bullet.io import file_stem
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.routes import official_length, reference_length

if TYPE_CHECKING:  # annotations only: the episode module brings the simulator
    from d3dwa_bullet.episode import EpisodeResult

_UNSAFE = re.compile(r"[^A-Za-z0-9._=+-]")


@dataclass(frozen=True)
class Job:
    """One episode to run."""

    world: World
    method: str
    seed: int
    noise: str = "none"
    """A profile name (none, paper, real, harsh, a YAML path), or the label of noise_config."""
    policy: str | None = None
    noise_config: str | None = None
    """JSON of ``NoiseConfig.to_dict()``: this exact noise instead of sampling a profile
    (the episode then gets ``NoiseModel(config, seed)``). A string keeps Job hashable."""
    columns: tuple[tuple[str, str | float | int], ...] = ()
    """Extra CSV columns of this job's row, e.g. (("axis", "slip"), ("level", 0.1))."""
    policy_seed: int | None = None
    """The training seed of ``policy`` (its ``seed-<k>`` folder), None if it has none."""

    @property
    def key(self) -> Key:
        return (self.world.name, self.method, self.policy_seed, self.seed, self.noise)

    @property
    def log_name(self) -> str:
        return log_name(self.key)

    def row(self, result: EpisodeResult, v_max: float) -> dict[str, Any]:
        """The CSV row of this job's result, scored (docs/design/score.md#score) with the world's
        reference length and v_max, the robot's top speed (m/s)."""
        summary = result.summary()
        return (
            summary
            | {"policy_seed": policy_seed_cell(self.policy_seed)}
            | score_cells(
                summary["outcome"],
                summary["time_s"],
                reference_length(self.world),
                v_max,
                official_length(self.world),
            )  # fmt: skip
            | dict(self.columns)
        )


def log_name(key: Key) -> str:
    """The file name, in a results directory's logs/, of the episode with this key (a key
    too long for a file name is cut and hashed: :func:`~d3dwa_bullet.io.file_stem`)."""
    world, method, policy_seed, seed, noise = key
    trained = "" if policy_seed is None else f"__p{policy_seed}"
    return file_stem(_UNSAFE.sub("_", f"{world}__{method}{trained}__{noise}__s{seed}")) + ".npz"
