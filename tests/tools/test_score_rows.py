"""tools/experiments/score_rows: the lower clip's successes and which score columns the row
alone reproduces, on rows built here (docs/design/score.md#rows)."""

from __future__ import annotations

from d3dwa_bullet.episode_metrics import barn_score, episode_score
from tools.experiments.score_rows import score_facts, text

V_MAX = 0.4


def row(world: str, outcome: str, t: float, length: float, barn_length: float | None = None):
    win = outcome == "goal"
    return {
        "world": world,
        "outcome": outcome,
        "time_s": t,
        "reference_length_m": length,
        "score": round(episode_score(win, t, length, V_MAX), 6),
        "score_barn": round(barn_score(win, t, barn_length or length), 6),
    }


def test_counts_the_lower_clip_and_the_rows_the_row_alone_does_not_reproduce() -> None:
    rows = [
        row("R1", "goal", 9.0, 4.0),  # t_ref 10 s: below it, score 1.0
        row("R1", "goal", 10.0, 4.0),  # at t_ref: 1.0, not below
        row("R2", "goal", 20.0, 4.0),  # 0.5
        row("R2", "timeout", 60.0, 4.0),
        row("BARN-0", "goal", 40.0, 10.0, barn_length=13.6),  # BARN's path, not the row's L
        row("BARN-1", "collision", 3.0, 10.0, barn_length=13.6),  # a failure scores 0 either way
    ]
    facts = score_facts(rows, V_MAX)
    assert facts["rows"] == 6 and facts["successes"] == 4
    assert facts["successes_at_score_1"] == 2 and facts["successes_below_t_ref"] == 1
    assert abs(facts["fewest_t_over_t_ref"] - 0.9) < 1e-12
    assert facts["barn_world_rows"] == 2
    assert facts["rows_not_recomputed"] == {
        "score": 0,
        "score_barn_barn_worlds": 1,
        "score_barn_other_worlds": 0,
    }
    assert "1 of 2 rows on BARN's worlds" in text(facts)


def test_a_written_score_that_disagrees_is_counted() -> None:
    bad = row("R1", "goal", 20.0, 4.0)
    bad["score"] = 0.9
    facts = score_facts([bad], V_MAX)
    assert facts["rows_not_recomputed"]["score"] == 1
    assert facts["successes_at_score_1"] == 0
