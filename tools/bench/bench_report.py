"""Benchmark a results page over many worlds: ``write_report`` on a constructed eval directory
(``--worlds`` BARN worlds, DWA III, the held chooser and a learned method at five training seeds,
without noise and under ``harsh``), its training-seed bootstrap vectorised (as every command runs)
and one resample at a time (as before), in the same run; the two pages must be identical.

    python -m tools.bench.bench_report
    python -m tools.bench.bench_report --worlds 250 --json

No episode runs: the rows are drawn from a seeded generator, outcomes and times alike, so the
figure is the page's own cost (its intervals over training seeds, per world and per group).
"""

from __future__ import annotations

import json
import random
import shutil
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from d3dwa_bullet.evaluation import seed_stats
from d3dwa_bullet.evaluation.report import write_report
from d3dwa_bullet.evaluation.results import job_rows, row_key
from tests.support.results_logs import write_results
from tools.entry import ToolParser, tool_main

METHODS: dict[str, list[int | str]] = {"dwa3": [""], "random@10": [""], "d3dwa": [0, 1, 2, 3, 4]}
PROFILES = ("none", "harsh")


def constructed(out: Path, worlds: int, seed: int = 0) -> Path:
    """An eval results directory of ``worlds`` BARN worlds (every sixth id, wrapping into the
    rest), rows drawn from a seeded generator."""
    rng = random.Random(seed)
    names = [f"BARN-{k}" for k in [*range(0, 300, 6), *(i for i in range(300) if i % 6)][:worlds]]
    rows = []
    for world in names:
        for method, seeds in METHODS.items():
            for policy_seed in seeds:
                for noise in PROFILES:
                    goal = rng.random() < 0.8
                    rows.append(dict(world=world, method=method, policy_seed=policy_seed, seed=0,
                                     noise=noise, outcome="goal" if goal else "timeout",
                                     time_s=30 + 20 * rng.random(), score=rng.random() * goal,
                                     score_barn=0.2 * rng.random() * goal))  # fmt: skip
    write_results(out, ((r, {}) for r in rows), sweep=False)
    settings = {
        "seeds": [0],
        "methods": list(METHODS),
        "worlds": names,
        "noise": ",".join(PROFILES),
    }
    jobs = [list(row_key(r)) for r in job_rows(out)]
    (out / "meta.json").write_text(json.dumps({"format": 4, "settings": settings, "jobs": jobs}))
    return out


def timed_page(source: Path, out: Path, vectorised: bool) -> tuple[float, str]:
    """(seconds write_report took on a copy of source at out, the page it wrote; its title
    names out's folder, the same for both sides)."""
    shutil.copytree(source, out)
    seed_stats.VECTORISED = vectorised
    try:
        start = time.perf_counter()
        report = write_report(out)
        return time.perf_counter() - start, report.path.read_text()
    finally:
        seed_stats.VECTORISED = True


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="bench_report", description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", type=int, default=50, help="BARN worlds (default 50)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    if not 1 <= args.worlds <= 300:
        parser.error(f"--worlds must be 1..300, got {args.worlds}")
    with tempfile.TemporaryDirectory() as tmp:
        source = constructed(Path(tmp) / "results", args.worlds)
        fast, page = timed_page(source, Path(tmp) / "vectorised" / "page", True)
        slow, before = timed_page(source, Path(tmp) / "one_at_a_time" / "page", False)
    record = {"worlds": args.worlds, "vectorised_s": round(fast, 2),
              "one_at_a_time_s": round(slow, 2), "ratio": round(fast / slow, 3),
              "identical_pages": page == before}  # fmt: skip
    if args.json:
        print(json.dumps(record))
    else:
        print(f"{args.worlds} worlds: page {fast:.1f} s vectorised, {slow:.1f} s one resample at a "
              f"time (ratio {fast / slow:.3f}); identical pages: {page == before}")  # fmt: skip
    return 0 if page == before else 1


if __name__ == "__main__":
    raise SystemExit(main())
