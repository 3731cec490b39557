"""A robot's error text reaches the terminal escaped: ``d3dwa drive`` prints the details of
a failed call, and they may carry ESC and BEL (issue 31)."""

from __future__ import annotations

import grpc
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.live import SimulatedKachaka  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.support.cli import refused  # noqa: E402

HOSTILE = "busy\x1b]0;owned\x07\x1b[2J\x1b[31m"


class HostileRobot(SimulatedKachaka):
    """A robot whose version call fails with terminal escapes in its details."""

    def GetRobotVersion(self, request, context):  # noqa: N802
        context.abort(grpc.StatusCode.INTERNAL, HOSTILE)


def test_a_robots_error_details_are_printed_escaped(capsys, serve):
    sim, address = serve(load_world("R1"), kind=HostileRobot, mode="lockstep")
    line = refused(
        capsys, "drive", "--kachaka", address, "--goal", "3,0", "--method", "dwa3",
        "--lockstep", "--timeout", "30",
    )  # fmt: skip
    assert "\x1b" not in line and "\x07" not in line
    assert "GetRobotVersion failed: INTERNAL: busy\\x1b]0;owned\\x07\\x1b[2J\\x1b[31m" in line
