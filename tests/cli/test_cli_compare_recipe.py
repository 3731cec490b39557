"""`d3dwa compare` prints the recipe's readings beside these policies' where a learned side has
two or more training seeds, and says why not where it has one (issue 77)."""

from __future__ import annotations

import json

from d3dwa_bullet.cli.app import main
from tests.support.results_logs import write_results


def results_dir(path, seeds, layouts=12):
    """d3dwa at the given training seeds against dwa3 on `layouts` layouts under `real`; each
    d3dwa seed reaches the goal on a different share of the layouts (a seed spread)."""
    rows = []
    for k in range(layouts):
        w = f"L{k}"
        rows.append(dict(world=w, method="dwa3", policy_seed="", seed=0, noise="real",
                         outcome="goal" if k % 2 else "timeout", time_s=5.0 + k))  # fmt: skip
        for s in seeds:
            rows.append(dict(world=w, method="d3dwa", policy_seed=s, seed=0, noise="real",
                             outcome="goal" if (k + s) % (3 + s) else "timeout", time_s=4.0 + k))  # fmt: skip
    write_results(path, ((r, {}) for r in rows), sweep=False)
    (path / "meta.json").write_text(json.dumps({"format": 3, "settings": {}, "jobs": []}))
    return path


def test_both_questions_are_printed_each_saying_which(tmp_path, capsys):
    out = results_dir(tmp_path / "r", seeds=(0, 1, 2))
    assert main(["compare", str(out), "--methods", "d3dwa,dwa3"]) == 0
    printed = capsys.readouterr().out
    policies = printed.index("Readings about these policies (training seeds fixed)")
    recipe = printed.index("Readings about the recipe (training seed random)")
    assert policies < recipe
    table = printed[recipe:].split("\n\n")[1]
    assert table.startswith("| tasks | metric (margin) | layouts |")
    assert "| all | success (±3 points) | 12 |" in table


def test_recipe_json_has_a_record_per_group_and_the_interval_is_wider(tmp_path, capsys):
    out = results_dir(tmp_path / "r", seeds=(0, 1, 2))
    assert main(["compare", str(out), "--methods", "d3dwa,dwa3", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    everything = next(g for g in record["groups"] if g["group"] == "all")
    mine, today = everything["recipe"]["success"], everything["readings"]["success"]
    assert mine["seeds_a"] == 3 and mine["seeds_b"] == 0 and record["recipe_why"] is None
    assert mine["difference"] == today["difference"]
    assert mine["high"] - mine["low"] >= today["high"] - today["low"]


def test_one_training_seed_says_why_the_recipe_is_not_read(tmp_path, capsys):
    out = results_dir(tmp_path / "r", seeds=(3,))
    assert main(["compare", str(out), "--methods", "d3dwa,dwa3"]) == 0
    printed = capsys.readouterr().out
    assert "Readings about these policies" in printed
    assert "not read: method 'd3dwa' has one training seed (3)" in " ".join(printed.split())
