"""``d3dwa drive`` against ``d3dwa serve --realtime`` over localhost: the loop paced by the
wall clock, physics in another process, Kachaka's default limits. Slow: a 25 s episode."""

from __future__ import annotations

import json
import signal

import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from tests.support.cli import run  # noqa: E402
from tests.support.hang_guard import within  # noqa: E402
from tests.support.serve_process import start_serve  # noqa: E402


@pytest.mark.slow
def test_dwa3_reaches_the_r1_goal_in_realtime(capsys):
    with within(180):
        serve, address = start_serve("--realtime")
        try:
            code, out, err = run(
                capsys, "drive", "--kachaka", address, "--goal", "3,0", "--method", "dwa3",
                "--json",
            )  # fmt: skip
        finally:
            serve.send_signal(signal.SIGINT)
            serve.communicate()
    assert code == 0, err
    summary = json.loads(out)
    assert summary["outcome"] == "goal" and summary["stop_acknowledged"], summary
    assert serve.returncode == 0
