"""Holm's procedure over a plan's headline cells: the readings re-taken on adjusted p-values.

A plan reads many cells (the yardstick: 24 cells, two world families, three metrics), each at
5 %; read one by one, some cell reads a difference by chance. Holm's step-down procedure
(``statsmodels.stats.multitest.multipletests``, method "holm") keeps the chance of any false
claim in a family at ALPHA, whatever the dependence between the cells. It is applied twice over
the same family (docs/design/readings-recipe.md#multiplicity):

- to the difference test: each record's two-sided p (twice the smaller one-sided p);
- to TOST: each record's TOST p.

The reading is then :func:`readings.reading_rule` on the adjusted p-values (the direction's
one-sided p is half the adjusted two-sided one), so it is still one of the four readings and
an adjusted reading is never bolder than the unadjusted one. A record without p-values (no
reading, fewer than two layouts) is left out of the family and unchanged. Pure: no simulator.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from statsmodels.stats.multitest import multipletests

from d3dwa_bullet.evaluation.readings import ALPHA, reading_rule


def holm(records: Sequence[Mapping[str, Any]], alpha: float = ALPHA) -> list[dict[str, Any]]:
    """The records (each with "p_a_better", "p_b_better", "tost_p", "reading") with
    "adjusted" ("Holm over k" for the k records in the family), "p_difference" (two-sided,
    Holm-adjusted), "tost_p_adjusted", "reading_unadjusted" and "reading" re-taken on the
    adjusted p-values; records without p-values get "adjusted": None, else unchanged.
    An inconclusive adjusted reading that was not inconclusive says why."""
    family = [i for i, r in enumerate(records) if r.get("p_a_better") is not None]
    out = [dict(r) | {"adjusted": None} for r in records]
    if not family:
        return out
    two_sided = [
        min(1.0, 2 * min(records[i]["p_a_better"], records[i]["p_b_better"])) for i in family
    ]
    tost = [records[i]["tost_p"] for i in family]
    diff_adj = multipletests(two_sided, alpha=alpha, method="holm")[1]
    tost_adj = multipletests(tost, alpha=alpha, method="holm")[1]
    label = f"Holm over {len(family)}"
    for i, p2, pt in zip(family, diff_adj, tost_adj, strict=True):
        r = out[i]
        a_side = r["p_a_better"] <= r["p_b_better"]
        p_a = float(p2) / 2 if a_side else r["p_a_better"]
        p_b = r["p_b_better"] if a_side else float(p2) / 2
        reading = reading_rule(p_a, p_b, float(pt), alpha)
        r |= {"adjusted": label, "p_difference": float(p2), "tost_p_adjusted": float(pt),
              "reading_unadjusted": r["reading"], "reading": reading,
              "equivalent": float(pt) < alpha}  # fmt: skip
        if reading == "inconclusive" and r["reading_unadjusted"] != "inconclusive":
            r |= {"needed": None, "why": f"{r['reading_unadjusted']} before Holm's adjustment"}
    return out
