"""BARN-style worlds against BARN's 300: difficulty measures, path length and DWA III's success.

Issue 78 part 3 (docs/design/barn-style.md, docs/worlds-barn-style.md). Draws ``--count``
BARN-style worlds from ``--world-seed`` on (evaluation seeds, 2^31 up) and sets each measure
:mod:`~d3dwa_bullet.world.barn_difficulty` takes of BARN's 300 (mean and least clearance of the
reference path's cells, characteristic dimension, tortuosity), the reference path length (m)
and the filled share of the grid's rows 1-28 against BARN's, each with a two-sample
Kolmogorov-Smirnov test and an Anderson-Darling k-sample test (SciPy; its p-value is capped to
[0.001, 0.25]). One figure (``--out``): the empirical distribution of each measure, both
families.

With ``--runs DIR`` (a ``d3dwa sweep --suite barn-style`` results directory) it also sets DWA
III's success there against its success on BARN's 300 (``--barn-results``, the yardstick's
results.csv), both from the rows of method dwa3, no noise, with the recovery layer ``nav2``:
each rate with its Wilson 95 % interval, the difference with its Newcombe 95 % interval
(statsmodels) and Fisher's exact test.

    python -m tools.experiments.barn_style_check --count 300 --out docs/figures/barn_style_check.png \\
      --runs docs/pilots/barn-style/dwa3 --json
"""

from __future__ import annotations

import csv
import json
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats
from statsmodels.stats.proportion import confint_proportions_2indep, proportion_confint

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.world.barn import BARN_WORLDS, path_length, read_world_file, world_file
from d3dwa_bullet.world.barn_difficulty import difficulty_of
from d3dwa_bullet.world.barn_style import TRAINING_SEEDS, barn_style_draw, check_eval_seed
from tools.entry import ToolParser, tool_main

MEASURES = {
    "clearance_mean": "mean path clearance, m",
    "clearance_min": "least path clearance, m",
    "characteristic_dimension": "characteristic dimension, m",
    "tortuosity": "tortuosity, 1",
    "reference_length": "reference path length, m",
    "fill": "filled share of rows 1-28",
}
"""The measures compared, with their axis labels."""
BARN_RESULTS = Path("docs/pilots/yardstick-barn/sweep/results.csv")
"""DWA III's episodes on BARN's 300 (the yardstick's sweep)."""
ALPHA = 0.05


def measures(grid: np.ndarray, path: np.ndarray) -> dict[str, float]:
    """The measures (:data:`MEASURES`) of a grid (30, 30) bool and its path (K, 2) int cells."""
    return difficulty_of(grid, path).to_dict() | {
        "reference_length": path_length(path),
        "fill": float(np.asarray(grid, dtype=bool)[1:-1].mean()),
    }


def barn_table() -> list[dict[str, float]]:
    """The measures of BARN's 300 worlds, by world number."""
    return [measures(*read_world_file(world_file(i))) for i in range(BARN_WORLDS)]


def style_table(count: int, first: int) -> list[dict[str, float]]:
    """The measures of ``count`` BARN-style worlds from seed ``first`` on, with seed, fill
    setting, passes and grids drawn."""
    rows = []
    for seed in range(first, first + count):
        d = barn_style_draw(seed)
        rows.append(
            measures(d.grid, d.path)
            | {"seed": d.seed, "setting_fill": d.fill, "passes": d.passes, "draws": d.draws}
        )
    return rows


def two_sample(a: Sequence[float], b: Sequence[float]) -> dict[str, float]:
    """KS and Anderson-Darling k-sample tests of two samples, with their medians."""
    ks = stats.ks_2samp(a, b)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # AD's p-value capped to [0.001, 0.25]: said so
        ad = stats.anderson_ksamp([np.asarray(a), np.asarray(b)])
    return {
        "median_barn": float(np.median(a)),
        "median_style": float(np.median(b)),
        "ks_d": float(ks.statistic),
        "ks_p": float(ks.pvalue),
        "ad_stat": float(ad.statistic),
        "ad_p": float(ad.pvalue),
    }


def dwa3_outcomes(path: Path, prefix: str) -> list[bool]:
    """Success of every dwa3 episode without noise under the layer nav2 on worlds named
    ``prefix``... in a results.csv: ConfigError if there is none."""
    if not path.is_file():
        raise ConfigError(f"{path}: no such results.csv")
    with path.open(newline="") as f:
        rows = [
            r["outcome"] == "goal"
            for r in csv.DictReader(f)
            if r["method"] == "dwa3" and r["noise"] == "none" and r.get("recovery") == "nav2"
            and r["world"].upper().startswith(prefix.upper())
        ]  # fmt: skip
    if not rows:
        raise ConfigError(f"{path}: no dwa3 episode without noise under nav2 on {prefix}* worlds")
    return rows


def success_comparison(style: list[bool], barn: list[bool]) -> dict[str, Any]:
    """DWA III's success on both families: rates, Wilson intervals, difference (BARN-style
    minus BARN, points) with Newcombe's interval, Fisher's exact p."""
    k1, n1, k2, n2 = sum(style), len(style), sum(barn), len(barn)
    lo, hi = confint_proportions_2indep(k1, n1, k2, n2, method="newcomb", compare="diff")
    fisher = stats.fisher_exact([[k1, n1 - k1], [k2, n2 - k2]])
    out: dict[str, Any] = {}
    for name, k, n in (("style", k1, n1), ("barn", k2, n2)):
        w = proportion_confint(k, n, method="wilson")
        out[name] = {
            "successes": k,
            "episodes": n,
            "rate": k / n,
            "wilson95": [float(w[0]), float(w[1])],
        }
    out["difference_points"] = 100 * (k1 / n1 - k2 / n2)
    out["difference_newcombe95_points"] = [100 * float(lo), 100 * float(hi)]
    out["fisher_p"] = float(fisher.pvalue)
    return out


def ad_text(p: float) -> str:
    """SciPy's Anderson-Darling p-value as it may be read: capped to [0.001, 0.25]."""
    return ">=0.25" if p >= 0.25 else ("<=0.001" if p <= 0.001 else f"={p:.3f}")


def figure(
    barn: list[dict[str, float]], style: list[dict[str, float]], tests: dict, out: Path
) -> None:
    """One PNG: the empirical distribution of each measure, BARN's 300 against BARN-style."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5))
    for ax, (key, label) in zip(axes.ravel(), MEASURES.items(), strict=True):
        for rows, name, colour in ((barn, f"BARN's {len(barn)}", "tab:blue"),
                                   (style, f"BARN-style ({len(style)})", "tab:orange")):  # fmt: skip
            values = np.sort([r[key] for r in rows])
            ax.step(
                values,
                np.arange(1, len(values) + 1) / len(values),
                where="post",
                label=name,
                color=colour,
            )
        t = tests[key]
        ax.set_title(
            f"{label}\nKS D={t['ks_d']:.3f} p={t['ks_p']:.3f}; AD p{ad_text(t['ad_p'])}", fontsize=9
        )
        ax.set_ylabel("share of worlds")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("BARN-style worlds against BARN's 300: empirical distributions (issue 78 part 3)")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=300, help="BARN-style worlds (default 300)")
    ap.add_argument(
        "--world-seed", type=int, default=TRAINING_SEEDS, help="first seed (default 2^31)"
    )
    ap.add_argument("--out", type=Path, help="the figure, a PNG")
    ap.add_argument("--runs", type=Path, help="a sweep --suite barn-style results directory")
    ap.add_argument("--barn-results", type=Path, default=BARN_RESULTS, help="DWA III on BARN's 300")
    ap.add_argument("--table", type=Path, help="also write the BARN-style measures as CSV")
    ap.add_argument("--json", action="store_true", help="print JSON")
    args = ap.parse_args(argv)
    if args.count < 2:
        raise ConfigError(f"--count must be an integer >= 2 (a two-sample test), got {args.count}")
    check_eval_seed(args.world_seed, args.count, "--world-seed")
    if args.out is not None and args.out.suffix.lower() != ".png":
        raise ConfigError(f"--out: {args.out} is not a .png file")
    barn, style = barn_table(), style_table(args.count, args.world_seed)
    tests = {k: two_sample([r[k] for r in barn], [r[k] for r in style]) for k in MEASURES}
    report: dict[str, Any] = {"count": args.count, "world_seed": args.world_seed, "tests": tests}
    if args.runs is not None:
        report["dwa3_success"] = success_comparison(
            dwa3_outcomes(args.runs / "results.csv", "BARN-style-"),
            dwa3_outcomes(args.barn_results, "BARN-"),
        )
    if args.out is not None:
        figure(barn, style, tests, args.out)
    if args.table is not None:
        with args.table.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(style[0]))
            writer.writeheader()
            writer.writerows(style)
    if args.json:
        print(json.dumps(report, indent=1))
        return 0
    print(
        f"BARN-style seeds {args.world_seed}..{args.world_seed + args.count - 1} against BARN's 300"
    )
    print(
        f"{'measure':<26} {'median BARN':>11} {'median style':>12} {'KS D':>6} {'KS p':>7} {'AD p':>6}"
    )
    for key, t in tests.items():
        flag = " *" if min(t["ks_p"], t["ad_p"]) < ALPHA else ""
        print(
            f"{key:<26} {t['median_barn']:>11.3f} {t['median_style']:>12.3f} {t['ks_d']:>6.3f} "
            f"{t['ks_p']:>7.4f} {ad_text(t['ad_p']):>7}{flag}"
        )
    if "dwa3_success" in report:
        s = report["dwa3_success"]
        print(
            f"DWA III success, no noise, nav2: BARN-style {s['style']['successes']}/{s['style']['episodes']}, "
            f"BARN {s['barn']['successes']}/{s['barn']['episodes']}; difference {s['difference_points']:+.1f} "
            f"points [{s['difference_newcombe95_points'][0]:+.1f}, {s['difference_newcombe95_points'][1]:+.1f}], "
            f"Fisher p = {s['fisher_p']:.3f}"
        )
    return 0


if __name__ == "__main__":
    main()
