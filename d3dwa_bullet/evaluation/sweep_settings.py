"""What a sweep runs (:class:`SweepSettings`), checked when built, and how many episodes that is:
pure, so ``d3dwa sweep`` refuses a bad count or name before it imports the simulator
(:mod:`d3dwa_bullet.evaluation.sweep` re-exports these names)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

from d3dwa_bullet.errors import ConfigError, UnknownNameError
from d3dwa_bullet.evaluation.noise_axes import AXES
from d3dwa_bullet.limits import MAX_EPISODES, MAX_LAYOUTS, MAX_LEVELS, MAX_SEEDS
from d3dwa_bullet.method_specs import check_method
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE, check_unseen_seeds
from d3dwa_bullet.world.registry import world_names
from randomization import load_profile

SHIPPED_WORLDS = world_names("real")
"""The shipped worlds of group "real" (R1..R3)."""
STYLES = ("R1-style", "R2-style", "R3-style")
PROFILES = ("none", "paper", "real", "harsh")
BASELINE = "none"
"""Noise label, axis and profile of the shared noise-free episodes."""


@dataclass(frozen=True)
class SweepSettings:
    """What a sweep runs; saved in meta.json so a results directory documents itself."""

    methods: tuple[str, ...]
    """Method names (see d3dwa_bullet.method_specs)."""
    worlds: tuple[str, ...] = SHIPPED_WORLDS
    """Shipped worlds (names or files)."""
    styles: tuple[str, ...] = STYLES
    """Generator styles of the unseen layouts."""
    layouts: int = 2
    """Unseen generated layouts per style."""
    layout_seed: int = UNSEEN_LAYOUT_SEED_BASE
    """``--layout-seed``: the first unseen layout's generator seed, per style (layouts take
    ``layout_seed``, ``layout_seed + 1``, ...); 2^31 or more, and 2^31 for a meta.json from
    before the option."""
    seeds: int = 2
    """Episode seeds per (world, method, condition)."""
    first_seed: int = 0
    """The first episode seed."""
    levels: int = 4
    """Non-zero levels per axis, equally spaced from harsh/levels to harsh."""
    axes: tuple[str, ...] = tuple(AXES)
    """Noise axes to sweep."""
    profiles: tuple[str, ...] = PROFILES
    """Named randomisation profiles to run as a whole."""
    time_limit: float | None = None
    """Episode time limit override, s (default: the world's, else 60 s)."""
    policy_seeds: str = "all"
    """Training seeds of each learned method (``--policy-seeds``; see policy_runs)."""
    policy_root: str | None = None
    """``--policy-root``: the folder holding each learned method's ``<method>/seed-<k>/``,
    resolved; None for the shipped ``policies/``."""

    def __post_init__(self) -> None:
        for name in ("layouts", "seeds", "levels"):
            low = 0 if name == "layouts" else 1
            if getattr(self, name) < low:
                raise ConfigError(f"--{name} must be >= {low}, got {getattr(self, name)}")
        MAX_LAYOUTS.check("--layouts", self.layouts, "layouts")
        check_unseen_seeds(self.layout_seed, self.layouts, "--layout-seed")
        MAX_LEVELS.check("--levels", self.levels, "levels")
        MAX_SEEDS.check("--seeds", self.seeds, "seeds")
        if not self.methods:
            raise ConfigError("a sweep needs at least one method")
        MAX_EPISODES.check("sweep", episode_count(self, len(self.methods)), "episodes")
        for m in self.methods:
            check_method(m)
        for a in self.axes:
            if a not in AXES:
                raise UnknownNameError(f"unknown noise axis {a!r}: choose from {', '.join(AXES)}")
        for p in self.profiles:
            load_profile(p)  # ProfileError for an unknown name or a bad file

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SweepSettings:
        keys = {f for f in cls.__dataclass_fields__}
        values: dict[str, Any] = {
            k: tuple(v) if isinstance(v, list) else v for k, v in data.items() if k in keys
        }
        return cls(**values)


def episode_count(settings: SweepSettings, runs: int) -> int:
    """Episodes of the sweep for ``runs`` (method, training seed) pairs, counted without
    building a world or a job (:func:`sweep_jobs` builds them)."""
    worlds = len(settings.worlds) + len(settings.styles) * settings.layouts
    extra = [p for p in settings.profiles if p != BASELINE]
    n_conditions = 1 + len(settings.axes) * settings.levels + len(extra)
    return worlds * runs * n_conditions * settings.seeds
