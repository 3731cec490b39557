"""The sim package re-exports its public names lazily: pure modules stay free of pybullet."""

from __future__ import annotations

import subprocess
import sys

import pytest

import d3dwa_bullet.sim as sim
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.sim.noise_config import NoiseConfig
from d3dwa_bullet.sim.scan import LaserScan
from d3dwa_bullet.sim.simulator import Simulator


def test_reexports_are_the_defining_modules_objects():
    assert (sim.Simulator, sim.NoiseModel, sim.NoiseConfig, sim.LaserScan) == (
        Simulator,
        NoiseModel,
        NoiseConfig,
        LaserScan,
    )
    assert set(sim.__all__) <= set(dir(sim))
    for name in sim.__all__:
        assert getattr(sim, name).__name__ == name
    with pytest.raises(AttributeError, match="no_such_name"):
        sim.no_such_name  # noqa: B018


def test_pure_sim_modules_import_no_pybullet():
    code = (
        "import sys; import d3dwa_bullet.sim.scan, d3dwa_bullet.sim.noise; "
        "print('pybullet' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
