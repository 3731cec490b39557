"""Learning curves over seeds, from each seed's metrics.jsonl and summary.json."""

from __future__ import annotations

import json

from tools.experiments.seed_curves import main, seed_curves


def run_dir(tmp_path):
    for k in (0, 2):
        seed = tmp_path / "run" / f"seed-{k}"
        seed.mkdir(parents=True)
        lines = [{"step": s, "tag": "eval/success_rate", "value": (s + k) / 100} for s in (20, 40)]
        lines.append({"step": 40, "tag": "charts/epsilon", "value": 0.1})
        (seed / "metrics.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
        (seed / "summary.json").write_text(json.dumps({"best_eval": {"step": 40}}))
        (seed / "config.json").write_text(json.dumps({"method": "d3dwa"}))
    return tmp_path / "run"


def test_each_seed_curve_and_its_kept_step(tmp_path):
    curves = seed_curves(run_dir(tmp_path))
    assert sorted(curves) == [0, 2]
    steps, values, kept = curves[2]
    assert steps.tolist() == [20, 40] and values.tolist() == [0.22, 0.42] and kept == 40


def test_a_keep_final_seed_marks_its_final_checkpoint(tmp_path):
    run = run_dir(tmp_path)
    summary = {"best_eval": {"step": 20}, "final_eval": {"step": 40}}
    (run / "seed-0" / "summary.json").write_text(json.dumps(summary))
    (run / "seed-0" / "config.json").write_text(json.dumps({"method": "d3dwa-dr", "keep": "final"}))
    assert seed_curves(run)[0][2] == 40  # not the best validation's step 20


def test_a_run_deciding_every_10_steps_is_read_in_control_steps(tmp_path):
    run = run_dir(tmp_path)
    config = {"method": "d3dwa-barn", "decision_steps": 10}
    (run / "seed-2" / "config.json").write_text(json.dumps(config))
    steps, values, kept = seed_curves(run)[2]
    assert steps.tolist() == [200, 400] and values.tolist() == [0.22, 0.42] and kept == 400
    assert seed_curves(run)[0][0].tolist() == [20, 40]  # no decision_steps: one step a decision


def test_figure_and_a_run_without_evaluations(tmp_path, capsys):
    run = run_dir(tmp_path)
    assert main([str(run), "--out", str(tmp_path / "c.png")]) == 0
    assert (tmp_path / "c.png").read_bytes()[:4] == b"\x89PNG"
    (tmp_path / "empty").mkdir()
    assert main([str(tmp_path / "empty"), "--out", str(tmp_path / "d.png")]) == 2
    assert "no seed-<k>/metrics.jsonl with evaluations" in capsys.readouterr().err
