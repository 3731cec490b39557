"""tools/bench/ray_floor: the lidar's ray batch on BARN, the variants that keep every range, and the part of
the batch past the first hit; episode_cost's family choice (docs/design/episode-cost.md#barns-floor)."""

from __future__ import annotations

from tools.bench.episode_cost import main as episode_cost_main
from tools.bench.ray_floor import main, world_floor


def test_the_filtered_and_threaded_casts_keep_every_range():
    row = world_floor("BARN-150", 3, seed=0, repeats=1)
    assert row["same_ranges"] is True
    assert set(row["us_per_scan"]) == {"threads_1", "threads_0", "robot_filtered", "cut_at_hit"}
    assert 0.3 < row["beams_hit"] <= 1.0  # the beams do meet BARN's cylinders
    assert all(us > 0 for us in row["us_per_scan"].values())


def test_bad_counts_worlds_and_families_are_refused_in_one_line(capsys):
    assert main(["--poses", "0"]) == 2
    assert "--poses and --repeats must be >= 1" in capsys.readouterr().err
    assert main(["--worlds", "BARN-999", "--poses", "1", "--repeats", "1"]) == 2
    assert "BARN world 999" in capsys.readouterr().err
    assert episode_cost_main(["--families", "BARN,R9"]) == 2
    assert "--families must be a comma list of BARN, R-style, got R9" in capsys.readouterr().err
