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


def test_plain_reads_never_wait_behind_clients_waiting_for_the_next_snapshot(serve):
    """Many clients holding the newest cursor (waiting for a snapshot that, in lockstep,
    only a command makes) leave a plain read and a command their answer within drive's
    default deadline (0.5 s)."""
    sim, address = serve(load_world("R1"), mode="lockstep")
    channel = grpc.insecure_channel(address)
    stub = KachakaApiStub(channel)
    cursor = stub.GetRosOdometry(pb2.GetRequest(), timeout=5).metadata.cursor
    waiting = pb2.GetRequest(metadata=pb2.Metadata(cursor=cursor))
    answered: list[int] = []

    def wait_for_next() -> None:
        answered.append(stub.GetRosOdometry(waiting, timeout=10).metadata.cursor)

    waiters = [threading.Thread(target=wait_for_next) for _ in range(24)]
    for thread in waiters:
        thread.start()
    time.sleep(0.3)  # every waiter has sent its call
    link = KachakaLink(address, timeout=0.5)
    reading = link.read()  # RobotLinkError (deadline exceeded) if it queued behind them
    assert reading.odometry.stamp_ns > 0
    link.command(0.1, 0.0)  # a command gets through too, and makes the next snapshot
    for thread in waiters:
        thread.join(timeout=10)
    link.close()
    channel.close()
    assert len(answered) == len(waiters) and all(c >= cursor for c in answered)
