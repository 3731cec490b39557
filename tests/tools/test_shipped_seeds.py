"""The shipped-seeds table comes from each seed's summary.json."""

from __future__ import annotations

import json

from tools.experiments.shipped_seeds import markdown, seed_records


def test_one_row_per_method_with_every_seed(tmp_path):
    for k, (step, success, wall) in enumerate([(40_276, 0.5, 600.0), (200_432, 0.75, 840.0)]):
        folder = tmp_path / "d3dwa" / f"seed-{k}"
        folder.mkdir(parents=True)
        summary = {"env_steps": 250_000, "wall_time_s": wall,
                   "best_eval": {"step": step, "success_rate": success}}  # fmt: skip
        (folder / "summary.json").write_text(json.dumps(summary))
    (tmp_path / "dqdwa").mkdir()  # no seeds: no row
    records = seed_records(tmp_path)
    assert [r["method"] for r in records] == ["d3dwa"]
    row = markdown(records).splitlines()[2]
    assert row == "| `d3dwa` | 0, 1 | 250k | 40k, 200k | 0.50, 0.75 | --, -- | 10.0-14.0 min |"


def test_a_keep_final_seed_reports_its_final_checkpoint(tmp_path):
    folder = tmp_path / "d3dwa-dr" / "seed-0"
    folder.mkdir(parents=True)
    summary = {"env_steps": 250_000, "wall_time_s": 1200.0,
               "best_eval": {"step": 100_934, "success_rate": 0.89},
               "final_eval": {"step": 250_000, "success_rate": 0.67}}  # fmt: skip
    (folder / "summary.json").write_text(json.dumps(summary))
    (folder / "config.json").write_text(json.dumps({"keep": "final"}))
    row = markdown(seed_records(tmp_path)).splitlines()[2]
    assert row == "| `d3dwa-dr` | 0 | 250k | 250k | 0.67 | -- | 20.0-20.0 min |"


def test_value_ratios_and_decision_periods_come_from_each_seed(tmp_path):
    # seed 0: a ratio; seed 1: a mean return under 0.1, so the gap is what counts
    values = [{"mean_q": 0.28, "mean_return": 0.16, "ratio": 1.75, "gap": 0.12},
              {"mean_q": 0.07, "mean_return": 0.04, "ratio": 1.75, "gap": 0.03}]  # fmt: skip
    for k, v in enumerate(values):
        folder = tmp_path / "d3dwa" / f"seed-{k}"
        folder.mkdir(parents=True)
        summary = {"env_steps": 25_000, "wall_time_s": 600.0,
                   "final_eval": {"step": 25_000, "success_rate": 0.89, "values": v}}  # fmt: skip
        (folder / "summary.json").write_text(json.dumps(summary))
        (folder / "config.json").write_text(json.dumps({"keep": "final", "decision_steps": 10}))
    row = markdown(seed_records(tmp_path)).splitlines()[2]
    assert (
        row
        == "| `d3dwa` | 0, 1 | 250k | 250k, 250k | 0.89, 0.89 | 1.75, gap +0.030 | 10.0-10.0 min |"
    )
