"""tools.bench.bench_throughput: a cell's rate is its own command's episodes over its wall time."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from tools.bench import bench_throughput


def test_a_cell_counts_the_rows_its_command_wrote(tmp_path: Path) -> None:
    rows = "world,outcome,steps\nR1,goal,300\nR2,timeout,600\nR3,collision,100\n"
    write = (  # half a second: the wall time, rounded to 0.01 s, is then exact to 2 %
        f"import pathlib, time; time.sleep(0.5); "
        f"pathlib.Path({str(tmp_path)!r}, 'results.csv').write_text({rows!r})"
    )
    cell = bench_throughput.measure([sys.executable, "-c", write], tmp_path)
    assert cell["episodes"] == 3 and cell["goals"] == 1
    assert cell["episodes_per_min"] == pytest.approx(180.0 / cell["wall_s"], rel=0.1)


def test_only_the_learned_family_names_a_training_seed() -> None:
    args = {m: bench_throughput.cell_argv(m, "nav2", "BARN", Path("o"), 1, "0,6", 2)
            for m in bench_throughput.FAMILIES.values()}  # fmt: skip
    assert [("--policy-seeds" in a) for a in args.values()] == [False, False, True]
    assert all(a[a.index("--world-ids") + 1] == "0,6" for a in args.values())


def test_a_failing_cell_is_one_line_and_status_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [
        sys.executable,
        "-c",
        "import sys; sys.exit('d3dwa: error: --world-ids 9999: out of range')",
    ]
    with pytest.raises(SystemExit) as done:
        bench_throughput.measure(argv, tmp_path)
    err = capsys.readouterr().err.strip()
    assert (
        done.value.code == 2 and len(err.splitlines()) == 1 and err.endswith("9999: out of range")
    )
