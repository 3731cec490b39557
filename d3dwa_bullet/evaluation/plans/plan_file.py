"""A sequential plan, as a YAML file: one format, one loader (:func:`load_plan`), one checker.

A plan fixes before its first episode (docs/design/sequential-plans.md):

- ``name``: what the plan is called;
- ``order_seed``: the seed of the layouts' order (:mod:`~d3dwa_bullet.evaluation.plans.order`);
- ``alpha``: the level, in (0, 0.5): the difference test spends alpha / 2 each way, each of
  TOST's two one-sided tests spends alpha;
- ``spending``: the alpha-spending function, ``lan-demets-obrien-fleming``;
- ``headline``: the metric whose reading stops a cell (one of ``paired.METRICS``);
- ``margins``: {metric: margin}, each a positive finite number in the metric's units (success
  as a fraction: 0.05 is 5 points), at most 1; the headline's margin is required;
- ``profiles``: the noise profiles, each cell read under each;
- ``families``: {name: {strata: [...], looks: [...], maximum: N}}: the world families read
  apart, each with its strata (interleaved in the order), its looks (increasing layout counts)
  and its maximum (the last look, appended when the looks stop short of it);
- ``cells``: [{a, b, question}]: the pairs A, B and what each reads: ``policies`` (the
  training seeds fixed) or ``recipe`` (the training seed a random effect); a cell may add
  ``global_plan: [A's, B's]``, two different ``--global-plan`` values, to read its sides across
  that setting (then a and b may be one method: ``{a: dwa3, b: dwa3, global_plan: [scan, none]}``).
  Each side of such a cell is labelled ``<method> [global-plan <value>]`` (:func:`side_label`),
  the name its episodes carry in the plan's reading and its looks.jsonl / looks.md; a cell
  without the field reads under the sweep's own ``--global-plan``, its sides named by their
  methods (docs/design/sequential-plans.md#across-a-setting);
- ``seeds`` (optional): {method: N}, the training seeds each learned method brings: its N
  lowest-numbered seed folders, fixed before any episode (``plan_seeds.py`` checks the folder
  holds them); when given, every learned side of a ``recipe`` cell is listed;
- ``multiplicity`` (optional): ``none`` (the default: every cell at alpha), ``bonferroni`` or
  ``holm`` over the plan's m cells, a cell being (pair, profile, family) (``recycling.py``).

Bad input is a ConfigError of one line naming the file, the field and the value: a missing or
unknown field, a margin not a positive finite number, an alpha outside (0, 0.5), looks that do
not increase, a maximum below the first look (or a look beyond it), a seed count that is not a
whole number >= 1, a fixed method (no training seed) or one no cell names listed in ``seeds``,
an unknown multiplicity control, a cell's ``global_plan`` that is not a list of two
``--global-plan`` values (``none``, ``scan``, ``map``: a sweep's episodes always have their world's
map, so ``map`` always runs) or names one twice.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ConfigError, D3DWAError
from d3dwa_bullet.evaluation.paired import METRICS, MIN_LAYOUTS
from d3dwa_bullet.evaluation.plans.recycling import MULTIPLICITY
from d3dwa_bullet.evaluation.recipe import QUESTIONS
from d3dwa_bullet.io import read_text
from d3dwa_bullet.limits import MAX_DOCUMENT_BYTES
from d3dwa_bullet.loading import parse_yaml
from d3dwa_bullet.method_specs import method_family
from d3dwa_bullet.planning.global_plan_params import GLOBAL_PLANS

SPENDING = ("lan-demets-obrien-fleming",)
"""The alpha-spending functions a plan may name."""
FIELDS = ("name", "order_seed", "alpha", "spending", "headline", "margins", "profiles",
          "families", "cells")  # fmt: skip
OPTIONAL = ("seeds", "multiplicity")
"""Fields a plan may leave out (a plan without them reads as before they existed)."""
FAMILY_FIELDS = ("strata", "looks", "maximum")
CELL_FIELDS = ("a", "b", "question")
CELL_OPTIONAL = ("global_plan",)
"""A cell's optional field: its two sides' ``--global-plan`` values (the module's docstring)."""


def side_label(method: str, global_plan: str) -> str:
    """The name of a cell's side run under a ``--global-plan`` value: ``dwa3 [global-plan scan]``."""
    return f"{method} [global-plan {global_plan}]"


@dataclass(frozen=True)
class Family:
    """A world family: its strata (names, in the order's interleaving), its looks (layout
    counts, strictly increasing, the last the maximum)."""

    name: str
    strata: tuple[str, ...]
    looks: tuple[int, ...]

    @property
    def maximum(self) -> int:
        return self.looks[-1]

    @property
    def fractions(self) -> tuple[float, ...]:
        """The information fraction at each look: its layouts over the maximum."""
        return tuple(n / self.maximum for n in self.looks)


@dataclass(frozen=True)
class Cell:
    """A pair A, B and the question its reading answers (one of :data:`QUESTIONS`), each side
    under the sweep's ``--global-plan`` or, with global_plan, under its own."""

    a: str
    b: str
    question: str
    global_plan: tuple[str, str] | None = None
    """(A's, B's) ``--global-plan`` values; None: both under the sweep's."""

    @property
    def sides(self) -> tuple[str, str]:
        """The names A's and B's episodes carry in the plan's reading: the methods, or with
        global_plan each one's :func:`side_label`."""
        if self.global_plan is None:
            return self.a, self.b
        return side_label(self.a, self.global_plan[0]), side_label(self.b, self.global_plan[1])


@dataclass(frozen=True)
class Plan:
    """A checked plan file (see the module's docstring); digest: sha256 of its text."""

    name: str
    order_seed: int
    alpha: float
    spending: str
    headline: str
    margins: Mapping[str, float]
    profiles: tuple[str, ...]
    families: tuple[Family, ...]
    cells: tuple[Cell, ...]
    digest: str
    seeds: Mapping[str, int] = field(default_factory=dict)
    """{learned method: the training seeds it brings}; empty: every seed its folder holds."""
    source: str = ""
    """Where the plan came from (its file), for messages."""
    multiplicity: str = "none"
    """How alpha is shared among the cells (one of ``recycling.MULTIPLICITY``)."""

    @property
    def methods(self) -> tuple[str, ...]:
        """Every method a cell names, in the cells' order."""
        return tuple(dict.fromkeys(m for c in self.cells for m in (c.a, c.b)))

    @property
    def global_plans(self) -> tuple[str, ...]:
        """Every ``--global-plan`` value a cell's global_plan names, in the cells' order
        (empty when no cell has the field)."""
        return tuple(dict.fromkeys(g for c in self.cells for g in c.global_plan or ()))

    @property
    def cell_count(self) -> int:
        """m: the plan's cells, each (pair, profile, family)."""
        return len(self.cells) * len(self.profiles) * len(self.families)


def _fields(
    value: Any, names: Sequence[str], where: str, optional: Sequence[str] = ()
) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: must be a mapping of {', '.join(names)}, got {value!r}")
    unknown = [k for k in value if k not in names and k not in optional]
    if unknown:
        raise ConfigError(
            f"{where}: unknown field {unknown[0]!r} (fields: {', '.join([*names, *optional])})"
        )
    missing = [k for k in names if k not in value]
    if missing:
        raise ConfigError(f"{where}: missing field {missing[0]!r}")
    return value


def _name(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f"{where}: must be a non-empty name, got {value!r}")
    return value.strip()


def _names(value: Any, where: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not value:
        raise ConfigError(f"{where}: must be a non-empty list of names, got {value!r}")
    names = tuple(_name(v, f"{where}[{i}]") for i, v in enumerate(value))
    if len(set(names)) != len(names):
        raise ConfigError(f"{where}: names a value twice: {list(names)!r}")
    return names


def _count(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ConfigError(f"{where}: must be a whole number of layouts >= 1, got {value!r}")
    return value


def _family(name: str, value: Any, where: str) -> Family:
    f = _fields(value, FAMILY_FIELDS, where)
    if not isinstance(f["looks"], list) or not f["looks"]:
        raise ConfigError(
            f"{where}.looks: must be a non-empty list of layout counts, got {f['looks']!r}"
        )
    looks = [_count(v, f"{where}.looks[{i}]") for i, v in enumerate(f["looks"])]
    for i in range(1, len(looks)):
        if looks[i] <= looks[i - 1]:
            raise ConfigError(f"{where}.looks: must increase, got {looks[i]} after {looks[i - 1]}")
    if looks[0] < MIN_LAYOUTS:
        raise ConfigError(
            f"{where}.looks: the first look needs {MIN_LAYOUTS} layouts or more (a paired test), got {looks[0]}"
        )
    maximum = _count(f["maximum"], f"{where}.maximum")
    if maximum < looks[0]:
        raise ConfigError(f"{where}.maximum: {maximum} is below the first look ({looks[0]})")
    if looks[-1] > maximum:
        raise ConfigError(f"{where}.looks: {looks[-1]} is beyond the maximum ({maximum})")
    if looks[-1] < maximum:
        looks.append(maximum)
    return Family(name, _names(f["strata"], f"{where}.strata"), tuple(looks))


def _margin(metric: str, value: Any, where: str) -> float:
    if metric not in METRICS:
        raise ConfigError(f"{where}: unknown metric {metric!r} (one of {', '.join(METRICS)})")
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not (ok and math.isfinite(value) and 0 < value <= 1):
        raise ConfigError(
            f"{where}.{metric}: must be a positive finite number up to 1 (the metric's units), got {value!r}"
        )
    return float(value)


def _global_plan(value: Any, where: str) -> tuple[str, str]:
    """A cell's global_plan: two different ``--global-plan`` values."""
    if not isinstance(value, list) or len(value) != 2:
        raise ConfigError(
            f"{where}: must be a list of two --global-plan values [A's, B's], got {value!r}"
        )
    for i, v in enumerate(value):
        if not isinstance(v, str) or v not in GLOBAL_PLANS:
            raise ConfigError(
                f"{where}[{i}]: must be a --global-plan value ({', '.join(GLOBAL_PLANS)}), got {v!r}"
            )
    if value[0] == value[1]:
        raise ConfigError(f"{where}: the two sides must differ, got {value[0]!r} twice")
    return value[0], value[1]


def _family_of(method: str, where: str) -> str:
    try:
        return method_family(method)
    except D3DWAError as err:  # an unknown name
        raise ConfigError(f"{where}: {err}") from err


def _seeds(value: Any, cells: Sequence[Cell], source: str) -> dict[str, int]:
    """{method: N} of a plan's ``seeds``, checked against its cells (the module's docstring)."""
    if not isinstance(value, Mapping) or not value:
        raise ConfigError(
            f"{source}: seeds must be a non-empty mapping method: training seeds, got {value!r}"
        )
    named = {m for c in cells for m in (c.a, c.b)}
    seeds = {}
    for method, n in value.items():
        where = f"{source}: seeds.{method}"
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ConfigError(f"{where}: must be a whole number of training seeds >= 1, got {n!r}")
        family = _family_of(str(method), where)
        if family != "learned":
            raise ConfigError(
                f"{where}: {method} is a {family} method, with no training seed; list learned ones"
            )
        if method not in named:
            raise ConfigError(f"{where}: no cell reads {method}")
        seeds[str(method)] = n
    for i, c in enumerate(cells):
        for side in (c.a, c.b) if c.question == "recipe" else ():
            if side not in seeds and _family_of(side, f"{source}: cells[{i}]") == "learned":
                raise ConfigError(
                    f"{source}: cells[{i}] reads {side} at the recipe level, but seeds does not list it"
                )
    return seeds


def check_plan(data: Any, source: str, digest: str = "") -> Plan:
    """The :class:`Plan` of a parsed plan file (source names it in errors); ConfigError of
    one line naming the field and value otherwise."""
    d = _fields(data, FIELDS, source, OPTIONAL)
    seed = d["order_seed"]
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"{source}: order_seed must be a whole number >= 0, got {seed!r}")
    alpha = d["alpha"]
    ok = isinstance(alpha, (int, float)) and not isinstance(alpha, bool)
    if not (ok and 0 < alpha < 0.5):
        raise ConfigError(f"{source}: alpha must be a number in (0, 0.5), got {alpha!r}")
    if d["spending"] not in SPENDING:
        raise ConfigError(
            f"{source}: spending must be one of {', '.join(SPENDING)}, got {d['spending']!r}"
        )
    if d["headline"] not in METRICS:
        raise ConfigError(
            f"{source}: headline must be one of {', '.join(METRICS)}, got {d['headline']!r}"
        )
    if not isinstance(d["margins"], Mapping):
        raise ConfigError(
            f"{source}: margins must be a mapping metric: margin, got {d['margins']!r}"
        )
    margins = {str(m): _margin(str(m), v, f"{source}: margins") for m, v in d["margins"].items()}
    if d["headline"] not in margins:
        raise ConfigError(f"{source}: margins: missing the headline metric {d['headline']!r}")
    if not isinstance(d["families"], Mapping) or not d["families"]:
        raise ConfigError(f"{source}: families must be a non-empty mapping, got {d['families']!r}")
    families = tuple(_family(_name(k, f"{source}: families"), v, f"{source}: families.{k}")
                     for k, v in d["families"].items())  # fmt: skip
    if not isinstance(d["cells"], list) or not d["cells"]:
        raise ConfigError(
            f"{source}: cells must be a non-empty list of {{a, b, question}}, got {d['cells']!r}"
        )
    cells = []
    for i, value in enumerate(d["cells"]):
        where = f"{source}: cells[{i}]"
        c = _fields(value, CELL_FIELDS, where, CELL_OPTIONAL)
        a, b = _name(c["a"], f"{where}.a"), _name(c["b"], f"{where}.b")
        across = (
            _global_plan(c["global_plan"], f"{where}.global_plan") if "global_plan" in c else None
        )
        if a == b and across is None:
            raise ConfigError(
                f"{where}: a and b must differ, got {a!r} twice (or read it across a setting: global_plan)"
            )
        if c["question"] not in QUESTIONS:
            raise ConfigError(
                f"{where}.question: must be one of {', '.join(sorted(QUESTIONS))}, got {c['question']!r}"
            )
        cells.append(Cell(a, b, c["question"], across))
    if len({c.sides for c in cells}) != len(cells):
        raise ConfigError(f"{source}: cells: a pair is given twice")
    seeds = _seeds(d["seeds"], cells, source) if "seeds" in d else {}
    multiplicity = d.get("multiplicity", "none")
    if multiplicity not in MULTIPLICITY:
        raise ConfigError(
            f"{source}: multiplicity must be one of {', '.join(MULTIPLICITY)}, got {multiplicity!r}"
        )
    return Plan(_name(d["name"], f"{source}: name"), seed, float(alpha), d["spending"], d["headline"],
                margins, _names(d["profiles"], f"{source}: profiles"), families, tuple(cells),
                digest, seeds, source, multiplicity)  # fmt: skip


def load_plan(path: str | Path) -> Plan:
    """The checked plan of a YAML file, its digest the sha256 of the file's text (what a
    resumed run compares); ConfigError of one line naming the file otherwise."""
    text = read_text(path, ConfigError, "plan file", MAX_DOCUMENT_BYTES)
    digest = hashlib.sha256(text.encode()).hexdigest()
    return check_plan(parse_yaml(text, ConfigError, str(path)), str(path), digest)


def check_fits(plan: Plan, methods: Sequence[str], profiles: Sequence[str]) -> None:
    """ConfigError (one line) when a cell's method is not among a run's methods, or a plan's
    profile not among its profiles (``none``, the noise-free baseline, is always run)."""
    for m in plan.methods:
        if m not in methods:
            raise ConfigError(f"plan cell method {m!r} is not in --methods ({', '.join(methods)})")
    for p in plan.profiles:
        if p not in profiles and p != "none":
            raise ConfigError(f"plan profile {p!r} is not in --profiles ({', '.join(profiles)})")
