"""A refusal comes before the heavy imports: counts, names and user files are checked before a
command imports torch, PyBullet, numba or matplotlib, so bad input costs well under 2 s.

The cases run in one fresh interpreter (this test process has those modules loaded already);
after each, the script reports which of them ``sys.modules`` holds.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

HEAVY = ("torch", "pybullet", "numba", "matplotlib")

SCRIPT = """
import json, sys
from d3dwa_bullet.cli.app import main
heavy = {heavy!r}
out = []
for argv in json.loads(sys.argv[1]):
    code = main(argv)
    out.append([code, [m for m in heavy if m in sys.modules]])
print(json.dumps(out))
"""


def alias_bomb(path: Path) -> Path:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, 10)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_refusals_import_nothing_heavy(tmp_path):
    bomb = str(alias_bomb(tmp_path / "bomb.yaml"))
    out = str(tmp_path / "out")
    cases = [
        ["run", "--world", "R1", "--method", "dwa3", "--noise", bomb],
        ["run", "--world", "R1", "--method", "dwa3", "--time-limit", "1e12"],
        ["eval", "--policy-seeds", "0-99999999999", "--out", out],
        ["eval", "--seeds", "1000000000000", "--out", out],
        ["eval", "--worlds", "R1", "--noise", bomb, "--out", out],
        ["sweep", "--layouts", "1000000000", "--out", out],
        ["sweep", "--profiles", bomb, "--out", out],
        ["train", "--config", "/dev/zero", "--out", out],
        ["train", "--config", bomb, "--out", out],
        ["train", "--n-envs", "100000", "--out", out],
        ["train", "--seeds", "0-99999999999", "--out", out],
        ["train", "--total-steps", "10000000000000", "--out", out],
    ]
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT.format(heavy=HEAVY), json.dumps(cases)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    results = json.loads(proc.stdout)
    errors = [line for line in proc.stderr.splitlines() if line.startswith("d3dwa: error: ")]
    assert len(errors) == len(cases), proc.stderr
    for argv, (code, loaded) in zip(cases, results, strict=True):
        assert code == 2, (argv, proc.stderr)
        assert loaded == [], f"{argv} refused only after importing {loaded}"
    assert not Path(out).exists()
