"""What a results directory's rows say about their scores (docs/design/score.md#rows): how many
successes hit the robot form's lower clip (t <= t_ref, score 1.0) and how close to t_ref the
fastest came, and whether each score column can be recomputed from the row alone (its outcome,
``time_s`` and ``reference_length_m``, with v_max from meta.json).

    python -m tools.experiments.score_rows docs/pilots/yardstick-barn/sweep
    python -m tools.experiments.score_rows docs/pilots/yardstick-barn/sweep --json

A score "recomputes" when the formula on the row's own cells gives the written value to within
the writing's rounding (1e-6, plus one ulp of slack). BARN's official form takes BARN's
published path on BARN's worlds, which is not on the row: those rows are counted apart.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.cli.compare import job_rows_of
from d3dwa_bullet.episode_metrics import barn_score, episode_score
from d3dwa_bullet.evaluation.results import read_meta
from tools.entry import ToolParser, tool_main

TOLERANCE = 1.5e-6
"""Written scores are rounded to 1e-6; a recomputed value within this of the cell agrees."""


def score_facts(rows: Sequence[dict[str, Any]], v_max: float) -> dict[str, Any]:
    """Counts over ``rows`` (results rows with outcome, time_s in s, reference_length_m in m,
    score and score_barn): successes, those at the robot form's lower clip, the fewest
    t / t_ref, and per score column the rows the row alone does not reproduce (BARN worlds
    apart for BARN's form). v_max: m/s. Rows without a score (before the score) are skipped."""
    scored = [r for r in rows if r.get("score") is not None and r.get("reference_length_m")]
    wins = [r for r in scored if r["outcome"] == "goal"]
    ratios = [r["time_s"] / (r["reference_length_m"] / v_max) for r in wins]
    off = {"score": 0, "score_barn_barn_worlds": 0, "score_barn_other_worlds": 0}
    barn_rows = 0
    for r in scored:
        win, t, length = r["outcome"] == "goal", r["time_s"], r["reference_length_m"]
        off["score"] += abs(episode_score(win, t, length, v_max) - r["score"]) > TOLERANCE
        is_barn = str(r["world"]).startswith("BARN-")
        barn_rows += is_barn
        key = "score_barn_barn_worlds" if is_barn else "score_barn_other_worlds"
        off[key] += abs(barn_score(win, t, length) - r["score_barn"]) > TOLERANCE
    return {
        "rows": len(scored),
        "successes": len(wins),
        "successes_at_score_1": sum(r["score"] >= 1.0 for r in wins),
        "successes_below_t_ref": sum(x < 1.0 for x in ratios),
        "fewest_t_over_t_ref": min(ratios) if ratios else None,
        "barn_world_rows": barn_rows,
        "rows_not_recomputed": off,
    }


def text(facts: dict[str, Any]) -> str:
    """The facts as a few plain lines."""
    off = facts["rows_not_recomputed"]
    fewest = facts["fewest_t_over_t_ref"]
    return (
        f"{facts['rows']} scored rows, {facts['successes']} successes\n"
        f"successes at the robot form's lower clip (t <= t_ref, score 1.0): "
        f"{facts['successes_at_score_1']} ({facts['successes_below_t_ref']} below t_ref)\n"
        f"fewest t / t_ref of a success: {'--' if fewest is None else f'{fewest:.3f}'}\n"
        f"robot score not reproduced from the row alone: {off['score']} rows\n"
        f"BARN's score not reproduced from the row's L: {off['score_barn_barn_worlds']} of "
        f"{facts['barn_world_rows']} rows on BARN's worlds (its published path is not on the row), "
        f"{off['score_barn_other_worlds']} of {facts['rows'] - facts['barn_world_rows']} elsewhere\n"
    )


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="score_rows", description=__doc__.split("\n")[0])
    parser.add_argument("results", type=Path, help="a results directory (eval or sweep)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    rows = job_rows_of(args.results)
    v_max = float(read_meta(args.results)["config"]["planner"]["limits"]["v_max"])
    facts = score_facts(rows, v_max)
    print(json.dumps(facts, indent=1) if args.json else text(facts), end="\n" if args.json else "")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
