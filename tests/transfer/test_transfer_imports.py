"""``import transfer`` stays free of the simulator: bag code runs where pybullet is not
installed. Only ``transfer.sim_bridge`` (not imported by ``transfer/__init__``) needs it.

Each check runs in a fresh interpreter, so modules other tests imported do not count.
"""

from __future__ import annotations

import json
import subprocess
import sys


def modules_after(statement: str) -> dict[str, bool]:
    """Whether a fresh interpreter holds pybullet and transfer.sim_bridge after statement."""
    probe = (
        f"import json, sys; {statement}; "
        "print(json.dumps({m: m in sys.modules for m in "
        "('pybullet', 'transfer.sim_bridge')}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=120
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_import_transfer_loads_no_simulator():
    loaded = modules_after("import transfer")
    assert loaded == {"pybullet": False, "transfer.sim_bridge": False}


def test_the_bag_modules_load_no_simulator():
    statement = "import transfer.synthetic, transfer.compare, transfer.replay, transfer.bag_writer"
    assert modules_after(statement) == {"pybullet": False, "transfer.sim_bridge": False}


def test_the_probe_sees_the_simulator_when_it_is_imported():
    """The check above could fail: the simulator side does bring pybullet in (the bridge picks
    its backend when it runs, so the PyBullet simulator is imported beside it here)."""
    loaded = modules_after("import transfer.sim_bridge, d3dwa_bullet.sim.simulator")
    assert loaded["pybullet"] and loaded["transfer.sim_bridge"]
