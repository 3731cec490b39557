"""Randomisation profiles: named, versioned distributions over every NoiseConfig parameter.

A profile file (``randomization/profiles/<name>.yaml``)::

    name: real
    version: 1                     # must be PROFILE_VERSION
    description: one line
    params:                        # every group and every field must be listed
      slip:
        level_mean: {uniform: [0.01, 0.03]}
        level_std: 0.005           # a plain number is fixed
        step_std: {normal: [0.005, 0.002]}   # clipped to the field's valid range
      latency:
        steps: {choice: [0, 1]}    # optional weights: {choice: [0, 1], weights: [3, 1]}
      physics:
        friction_scale_range: [0.8, 1.2]     # tuple fields: a fixed list, or a choice of lists
      ...

Optional entries: ``params.lidar.dropout_sector_scale`` (K factors on dropout_prob per
sector) and ``params.lidar.dropout_sector_kinds`` (K rows of NaN / +inf / -inf / 0.0 /
out-of-range proportions) take a fixed table or ``null`` and may be left out (off). A
top-level ``sensor:`` mapping is informational (what ``d3dwa calibrate`` measured: beam
count, field of view, scan rate); it is checked to be a mapping and otherwise ignored,
because the simulated lidar's geometry is not part of a profile.

Distributions: a number (fixed), ``{uniform: [lo, hi]}``, ``{normal: [mean, std]}`` with an
optional ``clip: [lo, hi]`` (always also clipped to the field's valid domain),
``{choice: [...]}`` with optional ``weights``. Integer fields accept numbers and choices only.
Tuple fields accept a list (fixed) or a choice of lists.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ConfigError, ProfileError, did_you_mean
from d3dwa_bullet.limits import check_weights
from d3dwa_bullet.loading import load_yaml
from d3dwa_bullet.resources import profiles_dir
from d3dwa_bullet.sim.noise_config import (
    CONFIG_GROUPS,
    INT_PARAMS,
    PARAM_DOMAINS,
    TABLE_PARAMS,
    TUPLE_PARAMS,
    NoiseConfig,
    check_param,
)

PROFILE_VERSION = 1
#: Trial samples drawn at load time to catch cross-field conflicts (e.g. min > max).
TRIAL_SAMPLES = 16
#: Pairs (group, lower field, upper field) whose sampled values must stay ordered.
ORDERED_PAIRS = (("lidar", "spurious_min", "spurious_max"),)
#: Top-level keys a profile may carry for the reader only (checked to be mappings, ignored).
INFORMATIONAL_KEYS = ("sensor",)


@dataclass(frozen=True)
class Fixed:
    """A constant; draws nothing."""

    value: Any

    def sample(self, rng: np.random.Generator) -> Any:
        return self.value

    def bounds(self) -> tuple[float, float]:
        return self.value, self.value


@dataclass(frozen=True)
class Uniform:
    """Uniform on [lo, hi]."""

    lo: float
    hi: float

    def sample(self, rng: np.random.Generator) -> float:
        return float(rng.uniform(self.lo, self.hi))

    def bounds(self) -> tuple[float, float]:
        return self.lo, self.hi


@dataclass(frozen=True)
class Normal:
    """Normal(mean, std) clipped to [lo, hi]."""

    mean: float
    std: float
    lo: float
    hi: float

    def sample(self, rng: np.random.Generator) -> float:
        return float(np.clip(rng.normal(self.mean, self.std), self.lo, self.hi))

    def bounds(self) -> tuple[float, float]:
        return self.lo, self.hi


@dataclass(frozen=True)
class Choice:
    """One of ``options`` with probabilities ``weights``."""

    options: tuple[Any, ...]
    weights: tuple[float, ...]

    def sample(self, rng: np.random.Generator) -> Any:
        return self.options[int(rng.choice(len(self.options), p=self.weights))]

    def bounds(self) -> tuple[float, float]:
        return min(self.options), max(self.options)


Distribution = Fixed | Uniform | Normal | Choice


@dataclass(frozen=True)
class Profile:
    """A named, versioned set of distributions: ``params[group][field] -> Distribution``."""

    name: str
    version: int
    description: str
    params: Mapping[str, Mapping[str, Distribution]]
    source: str
    """The file it was loaded from."""

    def sample(self, rng: np.random.Generator) -> NoiseConfig:
        """Draw one episode's NoiseConfig. Draws in a fixed order (groups and fields as in
        NoiseConfig), so the same rng state always gives the same config."""
        if not isinstance(rng, np.random.Generator):
            raise ProfileError(f"Profile.sample needs a numpy.random.Generator, got {rng!r}")
        values = {
            g: {f: dist.sample(rng) for f, dist in group.items()}
            for g, group in self.params.items()
        }
        try:
            return NoiseConfig.from_dict(values)
        except ConfigError as err:
            raise ProfileError(
                f"{self.source}: profile {self.name!r} sampled an invalid config: {err}"
            ) from err


def list_profiles() -> list[str]:
    """Names of the profiles shipped with the package, sorted."""
    return sorted(p.stem for p in profiles_dir().glob("*.yaml"))


def load_profile(name_or_path: str | Path) -> Profile:
    """Load a shipped profile by name (``none``, ``paper``, ``real``, ``harsh``) or a YAML file."""
    text = str(name_or_path)
    is_path = (
        isinstance(name_or_path, Path)
        or text.endswith((".yaml", ".yml"))
        or "/" in text
        or "\\" in text
    )
    if not is_path:
        known = list_profiles()
        if text not in known:
            raise ProfileError(
                f"unknown profile {text!r}; {did_you_mean(text, known)}known profiles: {', '.join(known)}"
            )
        path = profiles_dir() / f"{text}.yaml"
    else:
        path = Path(name_or_path)
        if not path.is_file():
            raise ProfileError(f"{path}: no such profile file")
    return profile_from_dict(load_yaml(path, ProfileError, "profile YAML"), str(path))


def profile_from_dict(data: Any, source: str) -> Profile:
    """Parse and validate a profile mapping; ``source`` names it in errors."""
    if not isinstance(data, Mapping):
        raise ProfileError(f"{source}: top level must be a mapping, got {type(data).__name__}")
    expected = {"name", "version", "description", "params"}
    unknown = set(data) - expected - set(INFORMATIONAL_KEYS)
    if unknown:
        raise ProfileError(
            f"{source}: unknown key(s) {sorted(unknown)}; expected {sorted(expected)} "
            f"(optional: {', '.join(INFORMATIONAL_KEYS)})"
        )
    for key in sorted(expected):
        if key not in data:
            raise ProfileError(f"{source}: missing key '{key}'")
    for key in INFORMATIONAL_KEYS:
        if key in data and not isinstance(data[key], Mapping):
            raise ProfileError(f"{source}: '{key}' must be a mapping, got {data[key]!r}")
    name, version, description = data["name"], data["version"], data["description"]
    if not isinstance(name, str) or not name:
        raise ProfileError(f"{source}: 'name' must be a non-empty string, got {name!r}")
    if isinstance(version, bool) or version != PROFILE_VERSION:
        raise ProfileError(
            f"{source}: 'version' = {version!r} is not supported (expected {PROFILE_VERSION})"
        )
    if not isinstance(description, str):
        raise ProfileError(f"{source}: 'description' must be a string, got {description!r}")
    raw = data["params"]
    if not isinstance(raw, Mapping):
        raise ProfileError(f"{source}: 'params' must be a mapping, got {raw!r}")
    bad = set(raw) - set(CONFIG_GROUPS)
    if bad:
        raise ProfileError(
            f"{source}: unknown parameter group(s) {sorted(bad)}; known {list(CONFIG_GROUPS)}"
        )

    params: dict[str, dict[str, Distribution]] = {}
    for group, cls in CONFIG_GROUPS.items():
        if group not in raw:
            raise ProfileError(f"{source}: missing parameter group 'params.{group}'")
        spec = raw[group]
        if not isinstance(spec, Mapping):
            raise ProfileError(f"{source}: 'params.{group}' must be a mapping, got {spec!r}")
        names = [f.name for f in fields(cls)]
        extra = set(spec) - set(names)
        if extra:
            raise ProfileError(
                f"{source}: unknown parameter(s) {sorted(f'params.{group}.{e}' for e in extra)}"
            )
        params[group] = {}
        for field_name in names:
            where = f"{source}: parameter 'params.{group}.{field_name}'"
            if (group, field_name) in TABLE_PARAMS:
                params[group][field_name] = _parse_table(group, field_name, spec, where)
                continue
            if field_name not in spec:
                raise ProfileError(f"{where} is missing")
            params[group][field_name] = _parse(group, field_name, spec[field_name], where)

    for group, lo_name, hi_name in ORDERED_PAIRS:
        lo_hi = params[group][lo_name].bounds()[1]
        hi_lo = params[group][hi_name].bounds()[0]
        if lo_hi > hi_lo:
            raise ProfileError(
                f"{source}: 'params.{group}.{lo_name}' can reach {lo_hi!r}, above the lowest "
                f"'params.{group}.{hi_name}' = {hi_lo!r}"
            )
    profile = Profile(
        name=name, version=version, description=description, params=params, source=source
    )
    trial = np.random.default_rng(0)
    for _ in range(TRIAL_SAMPLES):
        profile.sample(trial)
    return profile


def _number(value: Any, where: str, what: str = "value") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ProfileError(f"{where}: {what} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ProfileError(f"{where}: {what} must be finite, got {value!r}")
    return value


def _check_value(group: str, name: str, value: Any, where: str) -> Any:
    """Validate one possible value of a parameter; returns it normalised (tuples for lists)."""
    try:
        if name in TUPLE_PARAMS.get(group, {}):
            if not isinstance(value, list | tuple):
                raise ProfileError(
                    f"{where}: must be a list of {TUPLE_PARAMS[group][name]} numbers, got {value!r}"
                )
            value = tuple(value)
            CONFIG_GROUPS[group](**{name: value})  # the dataclass knows the tuple's rules
        else:
            check_param(group, name, value)
    except ConfigError as err:
        raise ProfileError(f"{where}: value {value!r} is out of range ({err})") from err
    return value


def _parse_table(group: str, name: str, spec: Mapping[str, Any], where: str) -> Fixed:
    """An optional per-sector table: absent or null (off), or a fixed list (no distributions)."""
    value = spec.get(name)
    if value is None:
        return Fixed(None)
    if not isinstance(value, list):
        raise ProfileError(f"{where}: must be a fixed list (a table) or null, got {value!r}")
    try:
        config = CONFIG_GROUPS[group](**{name: value})  # the dataclass knows the table's rules
    except ConfigError as err:
        raise ProfileError(f"{where}: value {value!r} is invalid ({err})") from err
    return Fixed(getattr(config, name))


def _parse(group: str, name: str, spec: Any, where: str) -> Distribution:
    is_tuple = name in TUPLE_PARAMS.get(group, {})
    is_int = (group, name) in INT_PARAMS
    if not isinstance(spec, Mapping):
        return Fixed(_check_value(group, name, spec, where))
    if len(spec) == 0:
        raise ProfileError(f"{where}: empty distribution")
    kind = next(iter(spec))
    allowed = {"uniform": set(), "normal": {"clip"}, "choice": {"weights"}}
    if kind not in allowed:
        raise ProfileError(
            f"{where}: unknown distribution {kind!r} (uniform, normal, choice or a fixed value)"
        )
    extra = set(spec) - {kind} - allowed[kind]
    if extra:
        raise ProfileError(f"{where}: unknown key(s) {sorted(extra)} in a {kind} distribution")
    if kind in ("uniform", "normal") and (is_tuple or is_int):
        raise ProfileError(f"{where}: {kind} is not allowed here; use a fixed value or a choice")
    args = spec[kind]

    if kind == "choice":
        if not isinstance(args, list) or not args:
            raise ProfileError(f"{where}: choice needs a non-empty list, got {args!r}")
        options = tuple(_check_value(group, name, a, where) for a in args)
        weights = spec.get("weights", [1.0] * len(options))
        if not isinstance(weights, list) or len(weights) != len(options):
            raise ProfileError(
                f"{where}: weights must be a list of {len(options)} numbers, got {weights!r}"
            )
        w = np.array([_number(x, where, "weight") for x in weights], dtype=np.float64)
        check_weights(where, weights, ProfileError)  # >= 0, a finite positive sum
        return Choice(options, tuple(float(x) for x in w / w.sum()))

    if not isinstance(args, list) or len(args) != 2:
        raise ProfileError(f"{where}: {kind} needs a list of 2 numbers, got {args!r}")
    a, b = (_number(x, where) for x in args)
    dom_lo, dom_hi = PARAM_DOMAINS[group][name]
    if kind == "uniform":
        if a > b:
            raise ProfileError(f"{where}: uniform needs lo <= hi, got {args!r}")
        _check_value(group, name, a, where)
        _check_value(group, name, b, where)
        return Uniform(float(a), float(b))
    if b < 0:
        raise ProfileError(f"{where}: normal std must be >= 0, got {b!r}")
    _check_value(group, name, a, where)
    lo, hi = dom_lo, dom_hi
    if "clip" in spec:
        clip = spec["clip"]
        if not isinstance(clip, list) or len(clip) != 2:
            raise ProfileError(f"{where}: clip must be [lo, hi], got {clip!r}")
        lo, hi = (_number(x, where, "clip") for x in clip)
        if lo > hi:
            raise ProfileError(f"{where}: clip needs lo <= hi, got {clip!r}")
        _check_value(group, name, lo, where)
        _check_value(group, name, hi, where)
    return Normal(float(a), float(b), float(lo), float(hi))
