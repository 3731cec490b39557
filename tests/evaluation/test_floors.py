"""The "against chance" and "against the reference" sections (docs/design/methods.md#floors): a velocity
planner's reference row stands apart from the floors, and one run on each side gives no
interval and no "cleared"."""

from __future__ import annotations

from d3dwa_bullet.evaluation.floors import ONE_RUN_EACH, chance_sections, floor_records, floor_table

PLANNER = "tests.support.external_methods:Straight"


def _row(method: str, world: str, seed: int, goal: bool, policy_seed: int | None = None) -> dict:
    return {"world": world, "method": method, "policy_seed": policy_seed, "seed": seed,
            "noise": "real", "outcome": "goal" if goal else "timeout", "time_s": 5.0}  # fmt: skip


def test_a_velocity_planner_is_read_against_its_reference_apart_from_the_floors() -> None:
    worlds = [f"L{k}" for k in range(6)]
    rows = [_row(PLANNER, w, s, True) for w in worlds for s in (0, 1)]
    rows += [_row("dwa3", w, s, k % 2 == 0) for k, w in enumerate(worlds) for s in (0, 1)]
    rows += [_row("d3dwa", w, 0, True, p) for w in worlds for p in (0, 1)]
    rows += [_row(f, w, s, False) for f in ("random", "random@10") for w in worlds for s in (0, 1)]
    page = chance_sections(rows, ["d3dwa", PLANNER, "dwa3", "random", "random@10"])
    chance, reference = page.split("## Against the reference")
    assert "## Against chance" in chance and PLANNER not in chance and "`random@10`" in chance
    assert f"| {PLANNER} | `dwa3` |" in reference and "Cleared" not in reference
    assert "a reading, not a floor cleared" in reference


def test_one_run_on_each_side_has_no_interval_and_clears_nothing() -> None:
    rows = [_row("d3dwa", f"L{k}", 0, True, 0) for k in range(4)]
    rows += [_row("random", f"L{k}", 0, False) for k in range(4)]
    (record,) = floor_records(rows, ["d3dwa"])
    assert record["one_run_each"] and not record["cleared"]
    table = floor_table([record])
    assert f"1.00, {ONE_RUN_EACH} | -- |" in table and "[1.00, 1.00]" not in table
