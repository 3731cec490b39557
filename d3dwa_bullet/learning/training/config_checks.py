"""The checks of a training config, every field at once when it is made or loaded, before
any work: types (a number where a number belongs, finite: ``lr: .inf`` is refused), ranges,
noise profiles that load (``eval_noise`` included), worlds that resolve. ConfigError names
the field and the value; :func:`~d3dwa_bullet.learning.training.config.load_train_config`
adds the file. ``check_run_limits`` and ``check_selection_rule`` are checked when a run
starts instead (a config.json written on a larger machine, or beside an older policy, stays
readable)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import fields
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ConfigError, ProfileError
from d3dwa_bullet.learning.agents.d3qn import D3QNConfig
from d3dwa_bullet.learning.agents.replay import check_replay_memory
from d3dwa_bullet.learning.tasks import resolve_world
from d3dwa_bullet.limits import (
    MAX_DECISION_STEPS,
    MAX_TOTAL_STEPS,
    check_processes,
    check_weights,
    is_decision_period,
)
from d3dwa_bullet.method_specs import barn_twin
from d3dwa_bullet.params import RECOVERY_KINDS
from d3dwa_bullet.planning.scan_filter import SCAN_FILTERS
from d3dwa_bullet.world.barn import barn_split_ids
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE
from d3dwa_bullet.world.registry import world_names
from randomization.profiles import load_profile

#: What the whole-config checks take: a ``TrainConfig`` (its fields read by name). This module
#: owns the checks and config.py owns the class, so the checks never name the class's module
#: (config.py imports this one; an arrow back would close a circle).
TrainConfigLike = Any

CURRICULA = ("uniform", "adaptive")
KEEP = ("best", "final")
#: Values of ``TrainConfig.barn_split``: off, or BARN's train split (never ``challenge``).
BARN_TRAIN_SPLITS = ("none", "train")
VECTOR_MODES = ("async", "sync")


def as_tuple(value: Any, name: str, kind: type = str) -> tuple:
    """A field given as one value or a list, as a tuple of ``kind``; ConfigError naming it."""
    if isinstance(value, str | int | float):
        value = [value]
    try:
        return tuple(kind(v) for v in value)
    except (TypeError, ValueError) as err:
        raise ConfigError(
            f"TrainConfig.{name}: expected a list of {kind.__name__}, got {value!r}"
        ) from err


def check_fields(config: TrainConfigLike) -> None:
    """ConfigError naming the first field of ``config`` that is out of range, or a profile,
    world or weight list that does not hold (its values already normalised)."""
    checks: list[tuple[str, bool, str]] = [
        ("total_steps", config.total_steps >= 1, ">= 1"),
        (
            "decision_steps",
            is_decision_period(config.decision_steps),
            f"a whole number in [1, {MAX_DECISION_STEPS.value}]",
        ),
        ("generator_prob", 0.0 <= config.generator_prob <= 1.0, "in [0, 1]"),
        ("route_start_prob", 0.0 <= config.route_start_prob <= 1.0, "in [0, 1]"),
        ("route_start_span", 0.0 < config.route_start_span < 1.0, "in (0, 1)"),
        ("curriculum", config.curriculum in CURRICULA, f"one of {CURRICULA}"),
        ("curriculum_window", config.curriculum_window >= 1, ">= 1"),
        ("curriculum_floor", config.curriculum_floor > 0, "> 0"),
        (
            "reward_scale",
            math.isfinite(float(config.reward_scale)) and float(config.reward_scale) > 0,  # type: ignore[arg-type]
            "a finite number > 0",
        ),
        ("eval_every", config.eval_every >= 0, ">= 0"),
        ("eval_seeds", bool(config.eval_seeds), "non-empty"),
        ("checkpoint_every", config.checkpoint_every >= 0, ">= 0"),
        ("log_every", config.log_every >= 1, ">= 1"),
        ("keep", config.keep in KEEP, f"one of {KEEP}"),
        ("seed", config.seed >= 0, ">= 0"),
        (
            "n_envs",
            type(config.n_envs) is int and config.n_envs >= 1,
            "a whole number >= 1 (0: one per core)",
        ),
        ("vector", config.vector in VECTOR_MODES, f"one of {VECTOR_MODES}"),
        ("recovery", config.recovery in RECOVERY_KINDS, f"one of {RECOVERY_KINDS}"),
        (
            "scan_filter",
            isinstance(config.scan_filter, str) and config.scan_filter in SCAN_FILTERS,
            f"one of {tuple(SCAN_FILTERS)}",
        ),
        ("noise", bool(config.noise), "non-empty ('none' for noise-free)"),
    ]
    for name, ok, rule in checks:
        if not ok:
            raise ConfigError(f"TrainConfig.{name} must be {rule}, got {getattr(config, name)!r}")
    if config.init_policy is not None and not (
        isinstance(config.init_policy, str) and config.init_policy.strip()
    ):
        raise ConfigError(
            f"TrainConfig.init_policy must be a policy folder or method name, "
            f"got {config.init_policy!r}"
        )
    check_barn(config)
    if not config.training_worlds and not config.generators:
        raise ConfigError("TrainConfig: give at least one training world or generator style")
    if config.noise_probs and len(config.noise_probs) != len(config.noise):
        raise ConfigError(
            f"TrainConfig.noise_probs: {len(config.noise_probs)} weights for "
            f"{len(config.noise)} noise profiles {list(config.noise)}"
        )
    if config.noise_probs:
        check_weights("TrainConfig.noise_probs", config.noise_probs)
    if config.keep == "best" and config.eval_every == 0:
        raise ConfigError("TrainConfig.keep = 'best' needs eval_every > 0")
    # each distinct world is read once: a world file takes ~10 ms to load, and a list may
    # repeat a name to weight it (100,000 repeats took minutes before)
    for w in _distinct(config.worlds):
        resolve_world(w, False, "TrainConfig.worlds")
    for w in _distinct(config.eval_worlds):
        resolve_world(w, False, "TrainConfig.eval_worlds")
    if config.eval_every and not config.eval_worlds:
        raise ConfigError("TrainConfig.eval_worlds: empty, but eval_every > 0")
    for name in _distinct(config.noise):
        _check_profile("noise", name)
    _check_profile("eval_noise", config.eval_noise)


def check_barn(config: TrainConfigLike) -> None:
    """ConfigError unless ``barn_split`` is 'none' or 'train' and ``barn_worlds`` is within
    the split's size (the challenge split is evaluation only)."""
    if config.barn_split not in BARN_TRAIN_SPLITS:
        why = " (challenge is evaluation only)" if config.barn_split == "challenge" else ""
        raise ConfigError(
            f"TrainConfig.barn_split must be one of {BARN_TRAIN_SPLITS}{why}, "
            f"got {config.barn_split!r}"
        )
    size = len(barn_split_ids("train"))
    count = config.barn_worlds
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= size:
        raise ConfigError(
            f"TrainConfig.barn_worlds must be in [1, {size}] (the train split's size), "
            f"got {config.barn_worlds!r}"
        )
    if config.barn_split == "none" and count != size:
        raise ConfigError(
            f"TrainConfig.barn_worlds: {count} BARN worlds asked for, but barn_split is 'none' "
            f"(set barn_split: train)"
        )
    if barn_twin(config.method) is not None and config.barn_split == "none":
        raise ConfigError(
            f"TrainConfig.barn_split: method {config.method!r} is trained on BARN's train split "
            f"(its name says so), so barn_split must be 'train', got 'none'"
        )


def _distinct(values: Any) -> list[Any]:
    """The values in order with repeats left out (an unhashable one is kept: its check names
    it)."""
    seen: set[Any] = set()
    out = []
    for v in values:
        try:
            if v in seen:
                continue
            seen.add(v)
        except TypeError:
            pass
        out.append(v)
    return out


def _check_profile(field: str, name: str) -> None:
    """ConfigError naming the field unless ``name`` is a noise profile that loads: an
    unknown one would otherwise surface minutes in, at the first greedy evaluation."""
    try:
        load_profile(name)
    except ProfileError as err:
        raise ConfigError(f"TrainConfig.{field}: {err}") from err


def check_scalar_types(cls: type, data: Mapping[str, Any], source: str, prefix: str = "") -> None:
    """ConfigError naming the field and value when a number, a whole number or a word is
    given as something else (``lr: fast``), before any comparison can fail obscurely."""
    for f in fields(cls):
        if f.name not in data or data[f.name] is None:
            continue
        value, default = data[f.name], f.default
        if isinstance(default, bool) or not isinstance(default, int | float | str):
            continue
        if isinstance(default, str):
            ok, kind = isinstance(value, str), "a word"
        elif isinstance(default, int) and f.type in ("int", int):
            ok, kind = isinstance(value, int) and not isinstance(value, bool), "a whole number"
        else:
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            ok, kind = ok and math.isfinite(value), "a finite number"
        if not ok:
            raise ConfigError(f"{source}: field '{prefix}{f.name}' must be {kind}, got {value!r}")


def check_run_limits(config: TrainConfigLike) -> None:
    """ConfigError when this machine cannot run ``config``: more worker processes
    (``n_envs``) than :func:`d3dwa_bullet.limits.max_processes`, a replay buffer over
    the memory bound, or more than ``MAX_TOTAL_STEPS`` steps. Checked when a run starts, before any process or buffer exists, not
    when a config loads (a config.json written on a larger machine stays readable)."""
    check_processes("n_envs", config.n_envs)
    MAX_TOTAL_STEPS.check("total_steps", config.total_steps, "steps")
    if isinstance(config.agent, D3QNConfig):
        check_replay_memory(config.agent.buffer_size, len(config.obs_layout), "agent.buffer_size")


def check_selection_rule(config: TrainConfigLike) -> None:
    """ConfigError unless the config's ``keep: best`` selects on training material that
    no results table reports (see ``TrainConfig.eval_worlds``). Checked when a run starts,
    not when a config loads: the configs shipped beside earlier policies stay readable."""
    if config.keep == "best":
        for name in config.eval_worlds:
            check_validation_world(name)


def check_validation_world(name: str) -> None:
    """ConfigError unless ``name`` may select a checkpoint (``keep: best``)."""
    text = str(name)
    shipped = {n.upper() for n in world_names()}
    style, sep, seed = text.rpartition("-s")
    if text.upper() in shipped or Path(text).stem.upper() in shipped:
        why = f"{text!r} is a shipped world, which the results tables report"
    elif sep and seed.isdigit() and int(seed) >= UNSEEN_LAYOUT_SEED_BASE:
        why = f"{text!r} is an unseen layout (seed >= 2^31), which the noise sweep reports"
    else:
        return
    raise ConfigError(
        f"TrainConfig.eval_worlds: keep: best picks the shipped checkpoint by these worlds, so "
        f"they must be training material no table reports; {why}. Use generated layouts "
        "such as R1-style-s1 (seeds below 2^31), or keep: final"
    )
