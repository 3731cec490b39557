"""Every way out of the loop stops the robot: a stale stream, a stalled loop (the watchdog),
an exception in the loop, and the end of the episode."""

from __future__ import annotations

import time

import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.errors import RobotLinkError  # noqa: E402
from d3dwa_bullet.live import (  # noqa: E402
    DriveResult,
    DriveSettings,
    KachakaLink,
    SimulatedKachaka,
    drive,
)
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.support.cli import refused  # noqa: E402
from transfer.sim_bridge import ReplayPipeline  # noqa: E402


class FrozenScan(SimulatedKachaka):
    """A robot whose scan stops updating after ``freeze_after`` snapshots (its odometry
    goes on)."""

    freeze_after = 5

    def GetRosLaserScan(self, request, context):  # noqa: N802
        messages = self._published[0]  # the newest snapshot's messages, as reads get them
        if self.cursor > self.freeze_after:
            with self._cond:
                messages["scan"] = self._frozen
        else:
            self._frozen = messages["scan"]
        return super().GetRosLaserScan(request, context)


class FrozenStamps(SimulatedKachaka):
    """A robot whose scan and odometry stop updating (stamps and all) after ``freeze_after``
    snapshots, while it still moves: both streams stop together, so neither lags the other
    and only their age can tell."""

    freeze_after = 5

    def _snapshot(self) -> None:
        super()._snapshot()
        with self._cond:
            messages = self._published[0]
            if self.cursor > self.freeze_after:
                messages["scan"], messages["odometry"] = self._frozen
            else:
                self._frozen = messages["scan"], messages["odometry"]


def run_drive(address: str, result: DriveResult, **settings) -> DriveResult:
    link = KachakaLink(address, timeout=30)
    pipeline = ReplayPipeline(make_controller("dwa3"))
    options = {"lockstep": True, "watchdog_s": 60.0} | settings
    try:
        return drive(link, pipeline, DriveSettings(goal=(3.0, 0.0), **options), result=result)
    finally:
        link.close()


def test_a_stale_scan_stops_the_robot(serve):
    world = load_world("R1")
    sim, address = serve(world, kind=FrozenScan, mode="lockstep")
    result = DriveResult()
    with pytest.raises(
        RobotLinkError, match=r"stale scan: 0.30 s older than the odometry \(limit 0.2 s\)"
    ):
        run_drive(address, result)
    # the scan freezes at the 5th snapshot: 0.1 and 0.2 s behind pass, 0.3 s does not
    assert result.steps == 7 and result.stopped
    assert sim.requests[-1][:2] == (0.0, 0.0)


def test_lockstep_stamps_that_freeze_stop_the_robot_within_three_periods(serve):
    """Lockstep counts a stamp's age in commands, not on the wall: the loop runs a step in a
    few ms, so 0.2 s of wall would have taken a hundred frozen readings (issue 58, class 4).
    However slow or fast this machine is, the third command on frozen stamps is not sent."""
    sim, address = serve(load_world("R1"), kind=FrozenStamps, mode="lockstep")
    result = DriveResult()
    with pytest.raises(RobotLinkError, match=r"stale (scan|odometry): .* over 3 control periods"):
        run_drive(address, result)
    # snapshot k answers the read after command k - 1; from the 6th the stamps are the 5th's
    frozen_from = FrozenStamps.freeze_after  # commands sent when the first frozen one is read
    assert result.steps - frozen_from <= 3 and result.steps == frozen_from + 2
    assert result.stopped and sim.requests[-1][:2] == (0.0, 0.0)


def test_the_cli_names_the_frozen_stream_in_one_line_in_lockstep(capsys, serve):
    sim, address = serve(load_world("R1"), kind=FrozenStamps, mode="lockstep")
    line = refused(
        capsys, "drive", "--kachaka", address, "--goal", "3,0", "--method", "dwa3",
        "--lockstep", "--watchdog", "60", "--timeout", "30",
    )  # fmt: skip
    assert "stale scan" in line and "control periods" in line, line
    assert sim.requests[-1][:2] == (0.0, 0.0)


def test_the_watchdog_stops_a_stalled_loop(serve):
    sim, address = serve(load_world("R1"), mode="lockstep")
    result = DriveResult()
    link = KachakaLink(address, timeout=30)
    pipeline = ReplayPipeline(make_controller("dwa3"))
    settings = DriveSettings(goal=(3.0, 0.0), lockstep=True, watchdog_s=0.2)

    def stall(*_):  # the third step hangs in the loop (say, a slow disk under the bag)
        if result.steps == 3:
            time.sleep(1.5)

    with pytest.raises(RobotLinkError, match="watchdog stopped the robot"):
        drive(link, pipeline, settings, result=result, on_step=stall)
    link.close()
    assert result.steps == 3
    assert sim.received[3] == (0.0, 0.0)  # the watchdog's stop came right after step 3
    assert all(r == (0.0, 0.0) for r in sim.received[3:])  # and nothing moved it after


def test_an_exception_in_the_loop_stops_the_robot(serve):
    sim, address = serve(load_world("R1"), mode="lockstep")
    result = DriveResult()
    link = KachakaLink(address, timeout=30)
    pipeline = ReplayPipeline(make_controller("dwa3"))

    def fail(*_):
        if result.steps == 4:
            raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        drive(link, pipeline, DriveSettings((3.0, 0.0), lockstep=True), result=result, on_step=fail)
    link.close()
    assert result.stopped and sim.requests[-1][:2] == (0.0, 0.0) and len(sim.received) == 5


def test_the_cli_reports_a_loop_failure_in_one_line(capsys, serve, monkeypatch, tmp_path):
    sim, address = serve(load_world("R1"), mode="lockstep")

    def broken(self, reading, decided, command):
        raise OSError("No space left on device")

    monkeypatch.setattr("d3dwa_bullet.live.recording.DriveRecorder.__call__", broken)
    line = refused(
        capsys, "drive", "--kachaka", address, "--goal", "3,0", "--method", "dwa3",
        "--lockstep", "--watchdog", "60", "--timeout", "30", "--record", str(tmp_path / "b"),
    )  # fmt: skip
    assert "drive failed: OSError: No space left on device" in line
    assert "the robot was stopped after 1 commands" in line
    assert sim.requests[-1][:2] == (0.0, 0.0)


def test_the_end_of_the_episode_stops_the_robot(serve):
    sim, address = serve(load_world("R1"), mode="lockstep")
    result = run_drive(address, DriveResult(), time_limit=1.0)
    assert result.outcome == "timeout" and result.steps == 10 and result.stopped
    assert sim.requests[-1][:2] == (0.0, 0.0) and len(sim.received) == 11


class HangingScan(SimulatedKachaka):
    """A robot whose scan call stops answering after ``hang_after`` snapshots."""

    hang_after = 5

    def GetRosLaserScan(self, request, context):  # noqa: N802
        if self.cursor > self.hang_after:
            time.sleep(1.0)  # past the client's deadline
        return super().GetRosLaserScan(request, context)


def test_a_call_past_its_deadline_stops_the_robot(serve):
    sim, address = serve(load_world("R1"), kind=HangingScan, mode="lockstep")
    result = DriveResult()
    link = KachakaLink(address, timeout=0.3)
    pipeline = ReplayPipeline(make_controller("dwa3"))
    with pytest.raises(RobotLinkError, match="GetRosLaserScan got no answer in time"):
        drive(
            link, pipeline, DriveSettings((3.0, 0.0), lockstep=True, watchdog_s=60), result=result
        )
    link.close()
    assert result.steps == 5 and result.stopped and sim.received[-1] == (0.0, 0.0)
