"""The one PyBullet import (d3dwa_bullet.sim.bullet): no banner, nothing else lost."""

from __future__ import annotations

import os
import subprocess
import sys

from d3dwa_bullet.sim import bullet, lidar, simulator

BANNER = "pybullet build time"


def run_python(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )


def test_a_plain_pybullet_import_prints_the_banner():
    """The premise: without the helper the C extension writes the banner."""
    out = run_python("import pybullet")
    assert BANNER in out.stdout + out.stderr


def test_importing_the_simulator_prints_no_banner_and_keeps_other_output():
    code = (
        "import sys\n"
        "print('before-out'); print('before-err', file=sys.stderr)\n"
        "import d3dwa_bullet.sim.simulator\n"
        "print('after-out'); print('after-err', file=sys.stderr)\n"
    )
    out = run_python(code)
    assert BANNER not in out.stdout + out.stderr
    assert out.stdout.split() == ["before-out", "after-out"]
    assert out.stderr.split() == ["before-err", "after-err"]


def test_simulator_and_lidar_use_the_one_import():
    assert simulator.p is bullet.p and lidar.p is bullet.p
    assert bullet.p.__name__ == "pybullet"


def test_silenced_fds_drops_descriptor_writes_and_restores_them(capfd):
    os.write(1, b"kept-1\n")
    with bullet.silenced_fds():
        os.write(1, b"dropped-1\n")
        os.write(2, b"dropped-2\n")
    os.write(2, b"kept-2\n")
    out, err = capfd.readouterr()
    assert out == "kept-1\n" and err == "kept-2\n"
