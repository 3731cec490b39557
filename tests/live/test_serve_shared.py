"""``d3dwa serve`` is one robot shared by every client: no client's input may break it for
the others, and no client's waiting may hold up another's reads."""

from __future__ import annotations

import math
import threading
import time

import grpc
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from kachaka_api.generated import kachaka_api_pb2 as pb2  # noqa: E402
from kachaka_api.generated.kachaka_api_pb2_grpc import KachakaApiStub  # noqa: E402

from d3dwa_bullet.live import KachakaLink  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402


def finite_pose(link: KachakaLink) -> tuple[float, float, float]:
    pose = link.read().odometry.pose
    assert all(math.isfinite(p) for p in pose), pose
    return pose


@pytest.mark.parametrize(
    "request_", [{"linear": math.nan}, {"angular": math.inf}, {"linear": -math.inf}]
)
@pytest.mark.parametrize("mode", ["lockstep", "realtime"])
def test_a_non_finite_command_is_refused_and_the_robot_stays_whole(serve, mode, request_):
    sim, address = serve(load_world("R1"), mode=mode)
    link = KachakaLink(address, timeout=5)
    link.command(0.1, 0.0)  # manual control on, the robot moving
    before = finite_pose(link)
    stub = KachakaApiStub(link.channel)
    with pytest.raises(grpc.RpcError) as caught:
        stub.SetRobotVelocity(pb2.SetRobotVelocityRequest(**request_), timeout=5)
    assert caught.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    assert "finite" in caught.value.details()
    assert sim.requests[-1][2] is False and all(map(math.isfinite, sim.received[-1]))
    if mode == "realtime":
        time.sleep(0.2)  # the physics thread steps on with the last accepted command
    after = finite_pose(link)
    link.command(0.1, 0.0)  # another client (or this one) still drives it
    assert all(math.isfinite(p) for p in finite_pose(link))
    if mode == "lockstep":
        assert after == before  # a refused command did not step the robot
    link.close()
