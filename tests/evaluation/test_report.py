"""`d3dwa report`: one Markdown page per results directory, honest about incomplete data;
scripts/reproduce_tables.py writes the two table pages."""

from __future__ import annotations

import json
import re
from pathlib import Path

import matplotlib.pyplot as plt
import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation import jobs as evaluation
from d3dwa_bullet.evaluation.report import world_span, write_report, write_table_page
from d3dwa_bullet.evaluation.results import CSV_FIELDS
from scripts import reproduce_tables

IMAGE = re.compile(r"!\[[^\]]*\]\(([^)]+)\)")


def eval_args(world: str, out: Path, seeds: int = 1, methods: str = "dwa1,dwa3") -> list[str]:
    return ["eval", "--methods", methods, "--worlds", world, "--seeds", str(seeds),
            "--out", str(out), "--workers", "1", "--json"]  # fmt: skip


@pytest.fixture(scope="module")
def eval_dir(one_second_world, tmp_path_factory):
    out = tmp_path_factory.mktemp("eval")
    assert main(eval_args(one_second_world, out)) == 0
    return out


@pytest.fixture(scope="module")
def policies(tmp_path_factory):
    root = tmp_path_factory.mktemp("policies")
    (root / "d3dwa").mkdir()
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([0, 1], [0, 1])
    fig.savefig(root / "d3dwa" / "learning_curve.png")
    (root / "d3dwa-weights" / "seed-2").mkdir(parents=True)  # a training seed's curve
    fig.savefig(root / "d3dwa-weights" / "seed-2" / "learning_curve.png")
    plt.close(fig)
    (root / "dqdwa").mkdir()  # a policy without a curve is simply left out
    return root


def images_exist(page: str, out: Path) -> list[str]:
    links = IMAGE.findall(page)
    assert links and all((out / link).is_file() for link in links), links
    assert not any(Path(link).is_absolute() for link in links)
    return links


def test_eval_report_embeds_tables_figures_and_learning_curves(eval_dir, policies, capsys):
    assert main(["report", str(eval_dir), "--policies", str(policies), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["complete"] and out["kind"] == "eval" and out["expected"] == 2
    page = (eval_dir / "report.md").read_text()
    assert "**Complete**: all 2 episodes finished." in page
    assert "| DWA III (2,1,1) |" in page and "tiny Time" in page and "Success rate" in page
    links = images_exist(page, eval_dir)
    assert "figures/tiny_time.png" in links
    assert "figures/learning_curve_d3dwa.png" in links and "dqdwa" not in " ".join(links)
    assert "figures/learning_curve_d3dwa-weights_seed-2.png" in links
    assert "### D3DWA (w/o horizon), seed-2 (`" in page


def test_interrupted_run_leaves_no_table_and_an_honest_page(
    one_second_world, tmp_path, monkeypatch
):
    assert main(eval_args(one_second_world, tmp_path)) == 0
    assert (tmp_path / "table.md").exists()
    real, calls = evaluation.run_job, []

    def interrupted(job, cfg):  # the second new episode never finishes
        calls.append(job)
        if len(calls) > 1:
            raise KeyboardInterrupt
        return real(job, cfg)

    monkeypatch.setattr(evaluation, "run_job", interrupted)
    # dwa1 and dwa3 repeat their noise-free episode: only the random chooser's seeds are new
    more = eval_args(one_second_world, tmp_path, seeds=3, methods="dwa1,dwa3,random")
    assert main(more) == 130
    assert not (tmp_path / "table.md").exists()  # the old table would pose as this run's
    report = write_report(tmp_path, policies_dir=tmp_path / "none")
    assert (report.done, report.expected, report.complete) == (3, 5, False)
    page = report.path.read_text()
    assert "INCOMPLETE: 3 of 5 episodes finished" in page and "(PARTIAL)" in page
    assert "--seeds 3" in page  # how to resume
    with pytest.raises(ResultsError, match="only 3 of 5 episodes"):
        write_table_page(tmp_path, tmp_path / "t.md", "Table")
    assert not (tmp_path / "t.md").exists()


def test_sweep_report(one_second_world, tmp_path, capsys):
    args = ["sweep", "--methods", "dwa1", "--worlds", one_second_world, "--layouts", "0",
            "--levels", "1", "--axes", "lidar_dropout", "--profiles", "none,paper", "--seeds", "1",
            "--out", str(tmp_path), "--workers", "1", "--json"]  # fmt: skip
    assert main(args) == 0
    capsys.readouterr()
    assert main(["report", str(tmp_path), "--policies", str(tmp_path / "none")]) == 0
    assert capsys.readouterr().out.strip() == f"report: {tmp_path / 'report.md'}"
    page = (tmp_path / "report.md").read_text()
    assert "**Complete**: all 3 episodes finished." in page
    assert "lidar.dropout_prob = L" in page and "### Named profiles" in page
    assert set(images_exist(page, tmp_path)) == {
        "figures/sweep_lidar_dropout.png",
        "figures/sweep_profiles.png",
    }


def write_old_dir(path: Path, meta: dict | None) -> Path:
    path.mkdir()
    (path / "results.csv").write_text(",".join(CSV_FIELDS) + "\n")
    if meta is not None:
        (path / "meta.json").write_text(json.dumps(meta))
    return path


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: p / "missing", "no such results directory"),
        (lambda p: write_old_dir(p / "old", None), "without meta.json (older version?)"),
        (lambda p: write_old_dir(p / "v1", {"format": 1}), "results format 1"),
        (lambda p: (p / "empty").mkdir() or p / "empty", "not a results directory"),
    ],
)
def test_report_bad_directory_exits_2_with_one_line(make, message, tmp_path, capsys):
    assert main(["report", str(make(tmp_path))]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("d3dwa: error:") and message in err and "\n" not in err


def test_reproduce_tables_writes_both_table_pages(one_second_world, tmp_path):
    written = reproduce_tables.run(
        methods=["dwa1"], seeds=1, workers=1, out=tmp_path / "results",
        tables=tmp_path / "tables", table1_worlds=[one_second_world], table2_worlds=[one_second_world],
        quiet=True,
    )  # fmt: skip
    assert set(written) == {"table1", "table2"}
    table1 = (tmp_path / "tables" / "table1.md").read_text()
    assert table1.startswith("# Table I analogue") and "| DWA I (1,1,2) |" in table1
    assert (tmp_path / "results" / "table2" / "report.md").exists()


def test_a_page_of_many_worlds_counts_them_in_its_title():
    assert world_span(["R1", "R2"]) == "R1, R2"
    challenge = [f"BARN-{i}" for i in range(0, 300, 6)]
    assert world_span(challenge) == "50 worlds, BARN-0 to BARN-294"
