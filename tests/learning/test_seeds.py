"""Training over seeds: one run directory per seed, resumable per seed, every seed exported."""

from __future__ import annotations

import json
import os
import signal
from dataclasses import replace
from pathlib import Path

import pytest
import torch

import d3dwa_bullet.learning.training.greedy_eval as greedy_eval
import d3dwa_bullet.learning.training.seeds as seeds_module
from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import ConfigError, TrainingError
from d3dwa_bullet.learning.training import TrainConfig, load_train_config, train
from d3dwa_bullet.learning.training.run_dir import write_config
from d3dwa_bullet.learning.training.seeds import train_seeds
from d3dwa_bullet.resources import configs_dir, policies_dir
from d3dwa_bullet.seed_dirs import parse_seeds
from tests.learning.test_training import TINY_WORLD, _config, _weights


@pytest.fixture
def tiny(tmp_path: Path) -> str:
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY_WORLD)
    return str(path)


@pytest.mark.parametrize(
    ("text", "seeds"),
    [("0-4", [0, 1, 2, 3, 4]), ("0,3,7", [0, 3, 7]), ("2", [2]), ("0-1,5", [0, 1, 5])],
)
def test_parse_seeds(text: str, seeds: list[int]) -> None:
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize("text", ["", "a", "3-1", "0,0", "-1", "1-", "0-2,2"])
def test_parse_seeds_refuses(text: str) -> None:
    with pytest.raises(ConfigError, match="--seeds"):
        parse_seeds(text)


def test_every_seed_trains_into_its_folder_and_resumes(tiny: str, tmp_path: Path) -> None:
    out, export = tmp_path / "runs", tmp_path / "policies"
    config = _config(tiny, total_steps=40)
    done = train_seeds(config, out, [0, 2], export=export, progress=False)
    assert [(o.seed, o.status) for o in done] == [(0, "done"), (2, "done")]
    for k in (0, 2):
        saved = json.loads((out / f"seed-{k}" / "config.json").read_text())
        assert saved["seed"] == k
        assert (export / f"seed-{k}" / "weights.pt").is_file()
        assert (export / f"seed-{k}" / "config.json").is_file()
        assert json.loads((export / f"seed-{k}" / "summary.json").read_text())["status"] == "done"
    w0, w2 = _weights(export / "seed-0"), _weights(export / "seed-2")
    assert any(not torch.equal(w0[k], w2[k]) for k in w0)  # the seeds really differ
    with pytest.raises(ConfigError, match="already holds a training run"):
        train_seeds(config, out, [0, 2], progress=False)
    again = train_seeds(config, out, [0, 1, 2], resume=True, export=export, progress=False)
    assert [o.status for o in again] == ["skipped", "done", "skipped"]
    # a finished seed is exported again over its own export (summary.json included)
    assert [o.exported for o in again] == [export / f"seed-{k}" for k in (0, 1, 2)]
    assert _weights(export / "seed-0").keys() == w0.keys()
    assert all(torch.equal(_weights(export / "seed-0")[k], w0[k]) for k in w0)
    assert json.loads((export / "seed-1" / "summary.json").read_text())["status"] == "done"


def test_a_failing_seed_is_reported_and_the_others_kept(
    tiny: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_train = seeds_module.train

    def train(config: TrainConfig, out: Path, **kw):
        if config.seed == 1:
            raise TrainingError(f"{out}: environment worker 0 died mid-run")
        return real_train(config, out, **kw)

    monkeypatch.setattr(seeds_module, "train", train)
    outcomes = train_seeds(_config(tiny, total_steps=30), tmp_path / "r", [0, 1, 2], progress=False)
    assert [o.status for o in outcomes] == ["done", "failed", "done"]
    assert "worker 0 died" in (outcomes[1].error or "")


def test_cli_trains_seeds_and_refuses_mixed_options(tiny: str, tmp_path: Path, capsys) -> None:
    config = tmp_path / "c.yaml"
    config.write_text(json.dumps(_config(tiny, total_steps=30).to_dict()))
    out = tmp_path / "runs"
    argv = ["train", "--config", str(config), "--seeds", "0,1", "--out", str(out), "--no-progress"]
    assert main(argv) == 0
    assert "seed 1: done" in capsys.readouterr().out
    assert main([*argv, "--seed", "3"]) == 2
    assert "--seed and --seeds" in capsys.readouterr().err
    assert main(["train", "--config", str(config), "--seeds", "0-x", "--out", str(out)]) == 2
    assert "'0-x'" in capsys.readouterr().err


@pytest.mark.parametrize(
    "method", ["d3dwa", "d3dwa-weights", "d3dwa-dr", "d3dwa-history-dr", "dqdwa"]
)
def test_committed_configs_share_one_budget_and_a_rule_fixed_in_advance(method: str) -> None:
    config = load_train_config(configs_dir() / f"{method}.yaml")
    reference = load_train_config(configs_dir() / "d3dwa.yaml")
    # one budget in control steps (0.1 s), whatever the decision period
    assert config.total_steps * config.decision_steps == 250_000
    assert (config.decision_steps, config.recovery) == (
        reference.decision_steps,
        reference.recovery,
    )
    # the D3QN seeds ship their final checkpoint; dqdwa its best validation (issue 41: its
    # seeds peaked early and declined), on the validation layouts, never an evaluation world
    assert config.keep == ("best" if method == "dqdwa" else "final") and config.eval_every > 0
    assert config.eval_worlds == reference.eval_worlds
    if config.family == "d3qn":  # one agent config: only the action set and the noise differ
        assert config.agent == reference.agent
    else:  # the tabular agent on the same horizon and exploration schedule
        assert config.agent.gamma == reference.agent.gamma  # type: ignore[union-attr]
        assert config.agent.eps_decay == reference.agent.eps_decay  # type: ignore[union-attr]


def test_keep_best_refuses_worlds_a_table_reports(tiny: str, tmp_path: Path) -> None:
    for world in ("TS1", "R2-style-s2147483650"):
        config = _config(tiny, keep="best", eval_every=20, eval_worlds=(world,))
        with pytest.raises(ConfigError, match="no table reports"):
            train(config, tmp_path / world, progress=False)
        with pytest.raises(ConfigError, match="no table reports"):
            train_seeds(config, tmp_path / f"s-{world}", [0], progress=False)
        assert not (tmp_path / world / "config.json").exists()
    ok = _config(tiny, keep="best", eval_every=20, eval_worlds=("R2-style-s3",), total_steps=20)
    assert train(ok, tmp_path / "ok", progress=False)["status"] == "done"
    # a shipped seed's own config loads and names the rule of its committed config
    shipped = load_train_config(policies_dir() / "d3dwa" / "seed-0" / "config.json")
    assert shipped.keep == load_train_config(configs_dir() / "d3dwa.yaml").keep


def test_one_episode_of_a_folder_of_seeds_drives_its_first_seed(tmp_path: Path) -> None:
    import shutil

    from d3dwa_bullet.controllers import make_controller

    for k in (3, 1):
        shutil.copytree(policies_dir() / "d3dwa" / "seed-0", tmp_path / "d3dwa" / f"seed-{k}")
    controller = make_controller("d3dwa", tmp_path / "d3dwa")
    # then what the policy recorded: its decision period, the recovery layer it trained in
    assert controller.source.startswith(f"{tmp_path / 'd3dwa' / 'seed-1'} (training seed 1 of 2)")
    assert make_controller("d3dwa", tmp_path / "d3dwa" / "seed-3").policy is not None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "method: d3dwa\nagent:\n  lr: fast\n",
            "field 'agent.lr' must be a finite number, got 'fast'",
        ),
        ("- 1\n- 2\n", "expected a mapping of TrainConfig fields"),
        ("total_steps: many\n", "field 'total_steps' must be a whole number, got 'many'"),
        ("method: d3dwa\nagent: 3\n", "field 'agent' must be a mapping"),
    ],
)
def test_bad_config_values_name_the_field(tmp_path: Path, capsys, text: str, message: str) -> None:
    config = tmp_path / "c.yaml"
    config.write_text(text)
    assert main(["train", "--config", str(config), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and str(config) in err[0]
    assert not (tmp_path / "run").exists()


def test_total_steps_errors_name_the_option(tmp_path: Path, capsys) -> None:
    config = str(configs_dir() / "d3dwa.yaml")
    assert main(["train", "--config", config, "--total-steps", "-5", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip() == "d3dwa: error: --total-steps must be >= 1, got -5"


@pytest.mark.slow
def test_seeds_as_ray_tasks_write_the_runs_a_local_run_writes(tiny: str, tmp_path: Path) -> None:
    """A private local Ray instance (ray.init(address='local')), as the eval tests start: 40-80 s
    (starting Ray is most of it), so slow."""
    ray = pytest.importorskip("ray", reason="ray is not installed (pip install '.[ray]')")
    from tests.learning.test_training import _episodes

    config = _config(tiny, total_steps=30)
    local = train_seeds(config, tmp_path / "local", [0, 1], progress=False)
    try:
        on_ray = train_seeds(config, tmp_path / "ray", [0, 1], ray_address="local", progress=False)
    finally:
        if ray.is_initialized():
            ray.shutdown()
    assert [o.status for o in on_ray] == [o.status for o in local] == ["done", "done"]
    for k in (0, 1):
        assert _episodes(tmp_path / "ray" / f"seed-{k}") == _episodes(
            tmp_path / "local" / f"seed-{k}"
        )
    assert not ray.is_initialized()


def test_ray_without_seeds_is_refused(tmp_path: Path, capsys) -> None:
    assert main(["train", "--method", "d3dwa", "--ray", "local", "--out", str(tmp_path)]) == 2
    assert "--seeds" in capsys.readouterr().err


def test_resume_restarts_a_seed_stopped_before_its_first_checkpoint(
    tiny: str, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """A seed killed before its first checkpoint holds a config and logs but nothing to go
    on from: --resume trains it again from step 0 instead of refusing it."""
    out = tmp_path / "runs"
    config = _config(tiny, total_steps=40)
    train_seeds(config, out, [0], progress=False)
    reference = (out / "seed-0" / "episodes.csv").read_text()
    run = out / "seed-1"
    run.mkdir(parents=True)
    write_config(run, replace(config, seed=1))  # what a killed seed-1 leaves behind
    (run / "episodes.csv").write_text("stale\n")
    (run / "metrics.jsonl").write_text('{"step": 7, "tag": "x", "value": 1}\n')
    done = train_seeds(config, out, [0, 1], resume=True, progress=False)
    assert [(o.seed, o.status) for o in done] == [(0, "skipped"), (1, "done")]
    assert "stopped before its first checkpoint" in capsys.readouterr().err
    episodes = (run / "episodes.csv").read_text()
    assert "stale" not in episodes and episodes.splitlines()[0] == reference.splitlines()[0]
    assert json.loads((run / "summary.json").read_text())["env_steps"] >= 40


def test_ctrl_c_during_a_seeds_final_evaluation_stops_the_whole_command(
    tiny: str, tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One Ctrl-C while seed 0 runs its final evaluation: seed 1 never starts, the command
    exits 130, and --resume ends seed 0 (without evaluating it again) and trains seed 1."""
    evaluated: list[tuple[int, int]] = []

    def evaluate(agent, config: TrainConfig, step: int) -> dict:
        evaluated.append((config.seed, step))
        if len(evaluated) == 1:
            os.kill(os.getpid(), signal.SIGINT)  # the user's Ctrl-C, mid-evaluation
        return {"step": step, "success_rate": 0.0, "collision_rate": 0.0, "mean_return": 0.0,
                "mean_time_s": None, "outcomes": {"tiny": ["timeout"]}}  # fmt: skip

    monkeypatch.setattr(greedy_eval, "evaluate", evaluate)
    config = tmp_path / "c.json"
    config.write_text(json.dumps(_config(tiny, total_steps=30, eval_every=1000).to_dict()))
    out = tmp_path / "runs"
    argv = ["train", "--config", str(config), "--seeds", "0-1", "--out", str(out), "--no-progress"]
    assert main(argv) == 130
    printed = capsys.readouterr()
    assert "seed 0: interrupted" in printed.out
    assert "seed 1: not started (interrupted)" in printed.out
    assert "--resume" in printed.err.strip().splitlines()[-1]
    assert evaluated == [(0, 30)]
    assert not (out / "seed-1").exists()  # never started, not even its directory
    seed0 = out / "seed-0"
    assert json.loads((seed0 / "summary.json").read_text())["status"] == "interrupted"
    assert not (seed0 / "policy").exists() and not (seed0 / "checkpoints" / "final").exists()
    assert main([*argv, "--resume"]) == 0
    assert evaluated == [(0, 30), (1, 30)]  # seed 0's evaluation was kept, not run again
    for k in (0, 1):
        assert json.loads((out / f"seed-{k}" / "summary.json").read_text())["status"] == "done"
        assert (out / f"seed-{k}" / "policy" / "weights.pt").is_file()


def test_ctrl_c_between_two_seeds_is_not_lost(
    tiny: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A Ctrl-C while a finished seed is exported (outside any training) stops the loop too."""
    real_finish = seeds_module._finish

    def finish(outcome, *args):
        if outcome.seed == 0:
            os.kill(os.getpid(), signal.SIGINT)
        return real_finish(outcome, *args)

    monkeypatch.setattr(seeds_module, "_finish", finish)
    outcomes = train_seeds(_config(tiny, total_steps=20), tmp_path / "r", [0, 1], progress=False)
    assert [(o.seed, o.status) for o in outcomes] == [(0, "done"), (1, "stopped")]
    assert not (tmp_path / "r" / "seed-1").exists()
