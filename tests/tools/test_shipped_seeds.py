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
    assert row == "| `d3dwa` | 0, 1 | 250k | 40k, 200k | 0.50, 0.75 | 10.0-14.0 min |"
