"""A policy's decision period and the recovery layer it trained inside travel with its ONNX
export (``learning/agents/policy_terms.py``, docs/design/agent.md#decision-period): the export's
controller holds each action as long as its torch checkpoint's and chooses the same ones, a
file exported before they were recorded is the paper's agent, and a bad value, in the file
or in the checkpoint, is one line naming the file, the key and the value."""

from __future__ import annotations

from pathlib import Path

import onnx
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.onnx_export import export_onnx
from d3dwa_bullet.learning.agents.onnx_policy import (
    METADATA_KEYS,
    OPTIONAL_FIELDS,
    load_onnx_policy,
    onnx_metadata,
    sample_observations,
)
from d3dwa_bullet.learning.agents.policy_terms import decision_period, trained_recovery
from d3dwa_bullet.planning.observation_kinds import observation_layout
from tests.support.held_policy import held_checkpoint

HOLD = 10
NOTES = (
    f" (one decision every {HOLD} control steps)"
    " (trained inside the recovery layer 'nav2': run with --recovery so)"
)
OBS = sample_observations(observation_layout("paper"), 35, seed=7)
"""Three and a half decision periods of observations."""


@pytest.fixture(scope="module")
def held(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(a checkpoint trained with decision_steps 10 inside nav2, its ONNX export)."""
    root = tmp_path_factory.mktemp("held")
    checkpoint = held_checkpoint(root / "checkpoint", decision_steps=HOLD, recovery="nav2")
    return checkpoint, export_onnx(checkpoint, root / "held.onnx").file


@pytest.fixture(scope="module")
def asked(held: tuple[Path, Path]) -> list[int]:
    """The greedy action of every observation of OBS: what a per-step driver would choose."""
    policy, _, _ = load_onnx_policy(held[1])
    return [policy(o) for o in OBS]


def one_line(err: pytest.ExceptionInfo, *names: object) -> None:
    """The error's message is one line naming each of names."""
    message = str(err.value)
    assert "\n" not in message, message
    for name in names:
        assert str(name) in message, (name, message)


def _props(file: Path) -> dict[str, str]:
    return {p.key: p.value for p in onnx.load(file).metadata_props}


def _with_props(file: Path, out: Path, **props: str | None) -> Path:
    """A copy of ``file`` whose metadata has ``props`` set, or removed where None."""
    model = onnx.load(file)
    changed = _props(file) | props
    del model.metadata_props[:]
    onnx.helper.set_model_props(model, {k: v for k, v in changed.items() if v is not None})
    out.write_bytes(model.SerializeToString())
    return out


def test_the_export_records_the_decision_period_and_recovery(held) -> None:
    props = _props(held[1])
    assert props[METADATA_KEYS["decision_steps"]] == "10"
    assert props[METADATA_KEYS["recovery"]] == "nav2"
    meta = onnx_metadata(held[1])
    assert (meta["decision_steps"], meta["recovery"]) == (HOLD, "nav2")


def test_the_onnx_controller_holds_and_chooses_as_the_torch_one(held, asked) -> None:
    checkpoint, file = held
    torch_controller = make_controller("d3dwa", checkpoint)
    onnx_controller = make_controller("d3dwa", onnx=file)
    assert torch_controller.hold == onnx_controller.hold == HOLD
    assert torch_controller.source == f"{checkpoint}{NOTES}"
    assert onnx_controller.source == f"{file} (ONNX, exported for d3dwa){NOTES}"
    torch_controller.reset(0)
    onnx_controller.reset(0)
    chosen = [onnx_controller(o)[0] for o in OBS]
    assert chosen == [torch_controller(o)[0] for o in OBS]
    assert chosen == [asked[t - t % HOLD] for t in range(len(OBS))]  # asked at 0, 10, 20, 30
    assert chosen != asked  # the policy changes its mind within a period: the hold matters
    other = next(t for t in range(len(OBS)) if asked[t] != chosen[-1])
    onnx_controller.reset(1)  # a new episode asks at once, whatever was held
    assert onnx_controller(OBS[other])[0] == asked[other]


def test_a_file_exported_before_them_is_the_papers_agent(held, asked, tmp_path) -> None:
    gone = {METADATA_KEYS[field]: None for field in OPTIONAL_FIELDS}
    version = {METADATA_KEYS["format_version"]: "1"}
    old = _with_props(held[1], tmp_path / "old.onnx", **gone, **version)
    assert set(_props(old)) == set(METADATA_KEYS.values()) - set(gone)  # the first format
    meta = onnx_metadata(old)
    assert (meta["decision_steps"], meta["recovery"]) == (1, "none")
    controller = make_controller("d3dwa", onnx=old)
    assert controller.hold == 1 and controller.source == f"{old} (ONNX, exported for d3dwa)"
    controller.reset(0)
    assert [controller(o)[0] for o in OBS] == asked  # asked every step


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("decision_steps", "0"),
        ("decision_steps", "101"),
        ("decision_steps", "2.5"),
        ("decision_steps", "-3"),
        ("decision_steps", "ten"),
        ("decision_steps", ""),
        ("decision_steps", "10\n"),
        ("decision_steps", "\uff11\uff10"),  # fullwidth "10": digits to Python, not to us
        ("recovery", "nav3"),
        ("recovery", "NAV2"),
        ("recovery", ""),
    ],
)
def test_a_bad_value_in_the_file_is_one_line(held, tmp_path, field, value) -> None:
    bad = _with_props(held[1], tmp_path / "bad.onnx", **{METADATA_KEYS[field]: value})
    loads = (
        lambda: load_onnx_policy(bad),
        lambda: onnx_metadata(bad),
        lambda: make_controller("d3dwa", onnx=bad),
    )
    for load in loads:
        with pytest.raises(CheckpointError) as err:
            load()
        one_line(err, bad, METADATA_KEYS[field], repr(value))


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("decision_steps", 0),
        ("decision_steps", 101),
        ("decision_steps", 2.5),
        ("decision_steps", True),
        ("decision_steps", None),
        ("recovery", "nav3"),
        ("recovery", None),
    ],
)
def test_a_bad_value_in_the_checkpoint_neither_exports_nor_drives(tmp_path, field, value):
    checkpoint = held_checkpoint(tmp_path / "checkpoint", **{field: value})
    out = tmp_path / "x.onnx"
    for load in (
        lambda: export_onnx(checkpoint, out),
        lambda: make_controller("d3dwa", checkpoint),
    ):
        with pytest.raises(CheckpointError) as err:
            load()
        one_line(err, checkpoint / "meta.json", f"metadata.{field}", repr(value))
    assert not out.exists()


def test_a_long_bad_value_is_cut_to_one_short_line() -> None:
    with pytest.raises(CheckpointError) as err:
        decision_period("9" * 10_000, "f.onnx: metadata d3dwa.decision_steps")
    assert len(str(err.value)) < 200 and str(err.value).startswith("f.onnx: metadata")
    with pytest.raises(CheckpointError) as err:
        decision_period(10**5000, "meta.json: metadata.decision_steps")  # too long to print
    assert len(str(err.value)) < 200
    with pytest.raises(CheckpointError) as err:
        trained_recovery("x" * 10_000, "f.onnx: metadata d3dwa.recovery")
    assert len(str(err.value)) < 200


@pytest.mark.parametrize(("value", "period"), [(1, 1), ("1", 1), (10, 10), ("100", 100)])
def test_good_periods_read_as_ints(value, period) -> None:
    assert decision_period(value, "here") == period


def test_a_version_2_file_without_them_is_refused(held, tmp_path) -> None:
    """Version 2 is what tells an older runner (which reads version 1 only) to refuse a held
    policy; a version-2 file must then say its period, never let it default."""
    gone = {METADATA_KEYS["decision_steps"]: None}
    bad = _with_props(held[1], tmp_path / "bad.onnx", **gone)
    with pytest.raises(CheckpointError, match=r"metadata lacks \['d3dwa.decision_steps'\]"):
        onnx_metadata(bad)
    assert _props(held[1])[METADATA_KEYS["format_version"]] == "2"
