"""The layouts' order of a sequential plan: fixed by its seed before the first episode.

Each stratum's layouts are shuffled by ``numpy.random.default_rng(seed)`` (one generator, the
strata in the plan's order), then interleaved in proportion: the i-th of a stratum of n sits at
(i + 0.5) / n of the way through, ties broken by the strata's order. So every prefix holds each
stratum in about its share of the whole (a look at 10 % of the layouts holds about 10 % of each
stratum), and the same seed and layouts give the same order anywhere.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from d3dwa_bullet.evaluation.style_tables import style_of
from d3dwa_bullet.world.barn_difficulty import TERCILE_GROUPS


def stratum_of(row: Mapping[str, Any]) -> str | None:
    """A sweep row's (or job's: world and layout group) stratum as a plan names it: ``barn``
    for a BARN world, a generated layout's style (``R1-style`` ...), else its layout group
    (``shipped``, ``given``) or None."""
    if row.get("layout") in TERCILE_GROUPS:
        return "barn"
    return style_of(row) or row.get("layout") or None


def layout_order(strata: Mapping[str, Sequence[str]], seed: int) -> list[str]:
    """{stratum: its layouts} (in the plan's strata order) -> every layout, in the plan's
    order. Each stratum's layouts are sorted before the shuffle, so their given order does
    not matter. ValueError for a layout in two strata."""
    rng = np.random.default_rng(seed)
    keyed = []
    seen: set[str] = set()
    for rank, (name, layouts) in enumerate(strata.items()):
        ordered = sorted(layouts)
        twice = seen.intersection(ordered)
        if twice:
            raise ValueError(f"layout {sorted(twice)[0]!r} is in stratum {name!r} and another")
        seen.update(ordered)
        shuffled = [ordered[i] for i in rng.permutation(len(ordered))]
        keyed += [((i + 0.5) / len(shuffled), rank, layout) for i, layout in enumerate(shuffled)]
    return [layout for *_, layout in sorted(keyed)]
