"""An ONNX file exported by ``d3dwa export`` named as a method: its action set, decision
period and observation come from its metadata, it drives the episode of the checkpoint it
was exported from, and a truncated or missing file is refused in one line."""

from __future__ import annotations

import pytest

pytest.importorskip("onnxruntime", reason="the robot extra is not installed")

from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.episode import EpisodeConfig, run_episode  # noqa: E402
from d3dwa_bullet.errors import ExternalMethodError  # noqa: E402
from d3dwa_bullet.external.resolve import external_floors, resolve  # noqa: E402
from d3dwa_bullet.learning.agents.onnx_export import export_onnx  # noqa: E402
from d3dwa_bullet.method_specs import method_family  # noqa: E402
from d3dwa_bullet.params import TerminationParams, recovery_params  # noqa: E402
from d3dwa_bullet.resources import policies_dir  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.external.test_external_episodes import same_episode  # noqa: E402

CHECKPOINT = policies_dir() / "d3dwa" / "seed-0"
NAV2 = EpisodeConfig(
    recovery=recovery_params("nav2"), termination=TerminationParams(time_limit=8.0)
)


@pytest.fixture(scope="module")
def onnx_file(tmp_path_factory) -> str:
    return str(export_onnx(CHECKPOINT, tmp_path_factory.mktemp("onnx") / "mine.onnx").file)


def test_an_onnx_file_is_a_method_with_its_declared_terms(onnx_file):
    assert method_family(onnx_file) == "external"
    method = resolve(onnx_file)
    assert (method.kind, method.actions.size, method.hold) == ("chooser", 100, 10)
    assert external_floors(method) == ("random", "random@10")
    assert "(sha256 " in method.origin
    world = load_world("R1")
    theirs = run_episode(world, make_controller(onnx_file), config=NAV2)
    ours = run_episode(world, make_controller("d3dwa", CHECKPOINT), config=NAV2)
    same_episode(ours, theirs)
    assert theirs.summary()["method_source"] == method.origin


def test_a_truncated_or_missing_onnx_file_is_refused(onnx_file, tmp_path):
    cut = tmp_path / "cut.onnx"
    cut.write_bytes(open(onnx_file, "rb").read()[:5000])
    with pytest.raises(ExternalMethodError, match=f"method '{cut}': ") as err:
        resolve(str(cut))
    assert "\n" not in str(err.value)
    with pytest.raises(ExternalMethodError, match="no such file"):
        resolve(str(tmp_path / "gone.onnx"))
