"""Reproduce the paper's Table I (TS1-TS4, US1, H1-H3) and Table II (R1-R3) analogues.

Evaluates every method that can run (the fixed DWA baselines, the ``random`` reference and
each learned method whose policy exists in ``policies/<name>/``) over several seeds, then
writes

    <out>/table1/  <out>/table2/   results.csv, logs, figures, table.md, report.md
    <tables>/table1.md  <tables>/table2.md

A table page is written (atomically) only once every episode of its table has finished;
an interrupted run is resumed by the same command and recomputes nothing finished.

    python scripts/reproduce_tables.py --seeds 5 --workers 2
    python scripts/reproduce_tables.py --ray auto          # on the cluster of `ray start`
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from collections.abc import Sequence
from pathlib import Path

from d3dwa_bullet.cli.app import build_parser
from d3dwa_bullet.cli.eval import TABLE1_GROUPS, TABLE2_GROUPS
from d3dwa_bullet.cli.options import default_methods
from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.evaluation.report import write_report, write_table_page
from d3dwa_bullet.world.registry import world_names

TITLES = {
    "table1": "Table I analogue: simulation worlds (training TS1-TS4, unseen US1, hospital H1-H3)",
    "table2": "Table II analogue: real-style worlds R1-R3 (in simulation)",
}


def run(
    methods: Sequence[str] | None = None,
    seeds: int = 3,
    first_seed: int = 0,
    workers: int | None = None,
    ray: str | None = None,
    out: str | Path = "results",
    tables: str | Path = "tables",
    table1_worlds: Sequence[str] | None = None,
    table2_worlds: Sequence[str] | None = None,
    noise: str = "none",
    quiet: bool = False,
) -> dict[str, Path]:
    """Evaluate both tables and write their pages; returns {"table1": path, "table2": path}.

    The worlds default to the shipped worlds of the tables' groups (TABLE1_GROUPS,
    TABLE2_GROUPS). Raises D3DWAError (bad input, incomplete run) like the CLI would report it.
    """
    methods = list(methods) if methods else default_methods()
    table1_worlds = world_names(*TABLE1_GROUPS) if table1_worlds is None else table1_worlds
    table2_worlds = world_names(*TABLE2_GROUPS) if table2_worlds is None else table2_worlds
    written = {}
    for name, worlds in (("table1", table1_worlds), ("table2", table2_worlds)):
        results = Path(out) / name
        argv = ["eval", "--methods", ",".join(methods), "--worlds", ",".join(worlds),
                "--seeds", str(seeds), "--seed", str(first_seed), "--out", str(results),
                "--noise", noise]  # fmt: skip
        if workers is not None:  # else the CLI's default: all cores
            argv += ["--workers", str(workers)]
        if ray:
            argv += ["--ray", ray]
        if quiet:
            argv.append("--json")
        args = build_parser().parse_args(argv)
        args.command_line = "d3dwa " + " ".join(argv)
        with contextlib.redirect_stdout(io.StringIO()) if quiet else contextlib.nullcontext():
            args.func(args)
        write_report(results)
        written[name] = write_table_page(results, Path(tables) / f"{name}.md", TITLES[name])
    return written


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--methods", help="comma list (default: baselines + methods with a policy)")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per (method, world)")
    ap.add_argument("--seed", type=int, default=0, help="first seed")
    ap.add_argument("--workers", type=int, help="local processes (default: all cores)")
    ap.add_argument("--ray", metavar="ADDRESS", help="local, auto, HOST:PORT or ray://HOST:PORT")
    ap.add_argument("--out", default="results", help="results root (table1/, table2/ inside)")
    ap.add_argument("--tables", default="tables", help="where table1.md and table2.md go")
    ap.add_argument("--noise", default="none", help="noise profile of every episode")
    ap.add_argument("--table1-worlds", help="comma list (default: the train and unseen worlds)")
    ap.add_argument("--table2-worlds", help="comma list (default: the real worlds)")
    args = ap.parse_args(argv)
    try:
        written = run(
            methods=args.methods.split(",") if args.methods else None,
            seeds=args.seeds, first_seed=args.seed, workers=args.workers, ray=args.ray,
            out=args.out, tables=args.tables, noise=args.noise,
            table1_worlds=args.table1_worlds.split(",") if args.table1_worlds else None,
            table2_worlds=args.table2_worlds.split(",") if args.table2_worlds else None,
        )  # fmt: skip
    except D3DWAError as err:
        print(f"reproduce_tables: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("reproduce_tables: interrupted; rerun to resume", file=sys.stderr)
        return 130
    for path in written.values():
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
