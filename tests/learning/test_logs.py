"""Training logs: TensorBoard events beside metrics.jsonl, one curve after a resume, and the
notice when TensorBoard cannot be imported."""

from __future__ import annotations

from pathlib import Path

import pytest
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from d3dwa_bullet.errors import WriteError
from d3dwa_bullet.learning.training import TrainConfig, read_metrics, train
from d3dwa_bullet.learning.training import logs as logs_module
from d3dwa_bullet.learning.training.logs import MetricsLog
from d3dwa_bullet.learning.training.state import truncate_logs
from tests.learning.test_training import SMALL_AGENT, TINY_WORLD


def events(out: Path) -> EventAccumulator:
    acc = EventAccumulator(str(out / "tb"))
    acc.Reload()
    return acc


def series(acc: EventAccumulator, tag: str) -> list[tuple[int, float]]:
    return [(e.step, e.value) for e in acc.Scalars(tag)]


def test_a_training_run_writes_event_files_of_every_record(tmp_path: Path) -> None:
    world = tmp_path / "tiny.yaml"
    world.write_text(TINY_WORLD)
    config = TrainConfig(
        method="d3dwa", total_steps=80, worlds=(str(world),), generators=(),
        agent=SMALL_AGENT, eval_every=0, eval_worlds=(str(world),), checkpoint_every=0,
        log_every=20, keep="final", n_envs=1,
    )  # fmt: skip
    out = tmp_path / "run"
    train(config, out, progress=False)
    assert list((out / "tb").glob("events.out.tfevents.*"))
    acc = events(out)
    records = read_metrics(out)
    scalars = {r["tag"] for r in records if "value" in r}
    histograms = {r["tag"] for r in records if "histogram" in r}
    assert {"charts/episodic_return", "losses/td_loss"} <= scalars and histograms
    tb_tags = set(acc.Tags()["scalars"])
    assert scalars <= tb_tags
    assert {t.split("_count/")[0] for t in tb_tags - scalars} == histograms
    for tag in scalars:
        expected = [(r["step"], r["value"]) for r in records if r["tag"] == tag]
        got = series(acc, tag)
        assert [s for s, _ in got] == [s for s, _ in expected]
        assert [v for _, v in got] == pytest.approx([v for _, v in expected], rel=1e-6)


def test_a_resumed_log_hides_the_events_written_after_the_checkpoint(tmp_path: Path) -> None:
    log = MetricsLog(tmp_path)
    for step in (10, 20, 30):
        log.scalar(step, "charts/x", step)
    sizes = log.sizes()  # the checkpoint
    for step in (40, 50):
        log.scalar(step, "charts/x", -1.0)  # logged, then lost with the crash
    log.close()
    truncate_logs(tmp_path, sizes)  # what a resumed Trainer does first
    log = MetricsLog(tmp_path)
    for step in (40, 50, 60):
        log.scalar(step, "charts/x", step)
    log.close()
    expected = [(s, float(s)) for s in (10, 20, 30, 40, 50, 60)]
    assert [(r["step"], r["value"]) for r in read_metrics(tmp_path)] == expected
    assert series(events(tmp_path), "charts/x") == expected


def test_a_new_log_purges_nothing(tmp_path: Path) -> None:
    assert logs_module._step_after_last_record(tmp_path / "metrics.jsonl") is None
    (tmp_path / "metrics.jsonl").write_text('{"step": 7, "tag": "a", "value": 1.0}\n')
    assert logs_module._step_after_last_record(tmp_path / "metrics.jsonl") == 8


def test_without_tensorboard_the_notice_is_one_line_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    monkeypatch.setattr(logs_module, "SummaryWriter", None)
    monkeypatch.setattr(logs_module, "TENSORBOARD_ERROR", "ImportError: no tensorboard")
    monkeypatch.setattr(logs_module, "_notice_given", False)
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        log = MetricsLog(tmp_path / name)
        log.scalar(1, "charts/x", 2.0)
        log.close()
    err = capsys.readouterr().err.splitlines()
    assert err == [
        "d3dwa: TensorBoard is not available (ImportError: no tensorboard); no event files "
        f"are written, the scalars are in {tmp_path / 'a' / 'metrics.jsonl'}"
    ]
    assert not (tmp_path / "a" / "tb").exists()
    assert read_metrics(tmp_path / "b") == [{"step": 1, "tag": "charts/x", "value": 2.0}]


def test_tensorboard_false_writes_no_events_and_says_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    MetricsLog(tmp_path, tensorboard=False).close()
    assert not (tmp_path / "tb").exists() and capsys.readouterr().err == ""


def test_resuming_never_cuts_or_appends_to_a_log_through_a_link(tmp_path: Path) -> None:
    outside = tmp_path / "precious.jsonl"
    outside.write_text('{"mine": 1}\n' * 10)
    run = tmp_path / "run"
    run.mkdir()
    (run / "metrics.jsonl").symlink_to(outside)
    with pytest.raises(WriteError, match="metrics.jsonl: cannot write: it is a symbolic link"):
        truncate_logs(run, {"metrics.jsonl": 12})
    with pytest.raises(WriteError, match="metrics.jsonl: cannot write: it is a symbolic link"):
        MetricsLog(run, tensorboard=False)
    assert outside.read_text() == '{"mine": 1}\n' * 10
