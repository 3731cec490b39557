"""The diversity curve (issue 56, part 3): do more training worlds buy success on BARN's challenge?

As ros_jackal draws it: one learned method (``d3dwa-barn`` by default) trained on K of BARN's
250 train worlds (``d3dwa train --barn-worlds K``; nested, 5 in 50 in 250:
docs/design/training.md#barn-training), every training seed evaluated on the 50 challenge worlds. Each
point is ``K=EVALDIR``, a ``d3dwa eval`` results directory of the seeds trained on K worlds;
``--commands`` prints the training and evaluation commands that make them (each resumes where it
stopped).

- K is checked against ``barn_worlds`` in the config.json of every seed's policy folder (the
  ``--policy`` the results' meta.json names, else the shipped ``policies/<method>/``) when the
  folder is there; a mismatch, a policy not trained on BARN, fewer than :data:`MIN_SEEDS`
  training seeds, a world outside ``challenge``, an incomplete evaluation, or points over
  different worlds, noise or recovery layers are refused in one line.
- Per point and metric (success, the robot score, BARN's official score): each training seed's
  value (its mean over the challenge worlds), their mean and the 95 % Student-t interval over
  seeds (``stats.t_interval``, SciPy's t: with 3 to 5 seeds a bootstrap would undercover).
- The answer: the largest K (A) against the smallest (B), paired by challenge world, each side
  averaged over its seeds there, read as ``d3dwa compare`` reads a pair
  (``readings.reading_of``: better, equivalent within the margin, or inconclusive with the
  layouts that would decide), with compare's default margins (``--margin-*`` as compare takes them).

    python -m tools.experiments.diversity_curve --commands
    python -m tools.experiments.diversity_curve 5=runs/barn-diversity/eval-w5 \\
      50=runs/barn-diversity/eval-w50 250=runs/barn-diversity/eval-w250 \\
      --out docs/figures/diversity_curve.png --table runs/barn-diversity/curve.md
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.margins import MARGIN_OPTIONS, MARGINS, check_margin, option_value
from d3dwa_bullet.evaluation.paired import METRICS, metric_value, paired_scores
from d3dwa_bullet.evaluation.readings import reading_of, reading_text, readings_table
from d3dwa_bullet.evaluation.results import (
    check_results_dir,
    completion,
    job_rows,
    read_meta,
    recovery_of,
)
from d3dwa_bullet.evaluation.stats import t_interval
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.resources import policies_dir
from d3dwa_bullet.seed_dirs import parse_seeds, seed_dir
from d3dwa_bullet.world.barn import barn_index, barn_split_ids
from tools.entry import ToolParser, tool_main

METHOD = "d3dwa-barn"
"""The method the curve trains (configs/d3dwa-barn.yaml); its 250 point is the method itself."""
KS = (5, 50, 250)
"""ros_jackal's training-world counts."""
MIN_SEEDS = 3
"""Training seeds a point needs (issue 56: at least 3 per point)."""
TRAIN_SIZE = len(barn_split_ids("train"))
CHALLENGE = frozenset(barn_split_ids("challenge"))
LABELS = {"success": "success [%]", "score": "score", "score_barn": "BARN official score"}
SEED_DOT = 0.85
"""Where each seed's dot sits on the log axis, as a factor of K (left of the mean's bar)."""

Rows = list[dict[str, Any]]


def parse_point(text: str) -> tuple[int, Path]:
    """``K=EVALDIR`` as (K, dir); ConfigError unless K is a whole number in 1..250."""
    k, sep, folder = text.partition("=")
    if not sep or not folder or not k.strip().isdigit():
        raise ConfigError(
            f"point {text!r} is not K=EVALDIR (K: training worlds, e.g. 5=runs/eval-w5)"
        )
    if not 1 <= int(k) <= TRAIN_SIZE:
        raise ConfigError(f"point {text!r}: K must be in [1, {TRAIN_SIZE}] (BARN's train split)")
    return int(k), Path(folder)


def policy_folder(folder: Path, method: str) -> Path:
    """The policy folder a results directory's seeds were driven from: its meta.json's
    ``--policy``, else the shipped one."""
    policy = read_meta(folder).get("settings", {}).get("policy")
    return Path(policy) if policy else policies_dir() / method


def check_trained_worlds(k: int, policy: Path, seeds: Sequence[int]) -> str:
    """How K was checked: 'config.json' when every seed's config.json there records
    barn_worlds K, else why it could not be (no folder, no config). ResultsError (one line,
    naming the file, field and both values) when one records another count or no BARN."""
    checked = 0
    for seed in seeds:
        config = seed_dir(policy, seed) / "config.json"
        if not config.is_file():
            continue
        data = load_json(config, ResultsError)
        if not isinstance(data, dict) or "barn_worlds" not in data:
            continue  # a config from before barn_worlds: nothing to check against
        if data.get("barn_split", "none") != "train":
            raise ResultsError(
                f"{config}: barn_split is {data.get('barn_split', 'none')!r}: this seed did not "
                f"train on BARN's train worlds, so it is no point K={k} of the curve"
            )
        if data["barn_worlds"] != k:
            raise ResultsError(
                f"{config}: barn_worlds is {data['barn_worlds']!r}, but the point says K={k}: "
                "give the point the count its policies trained on"
            )
        checked += 1
    if checked == len(seeds):
        return "config.json"
    missing = len(seeds) - checked
    return f"unchecked ({missing} of {len(seeds)} seeds without a config.json in {policy})"


def point_rows(k: int, folder: Path, method: str) -> tuple[Rows, str]:
    """(the method's rows, how K was checked) of one point, refused in one line when it is not
    one (module docstring)."""
    if not (folder / "results.csv").is_file():
        raise ResultsError(f"point {k}={folder}: no results.csv (run its d3dwa eval first)")
    check_results_dir(folder)
    done, listed = completion(folder)
    if done < listed:
        raise ResultsError(
            f"{folder}: {done} of its {listed} episodes are in: the evaluation is incomplete "
            "(run its d3dwa eval again to resume it)"
        )
    every = job_rows(folder)
    rows = [r for r in every if r["method"] == method]
    if not rows:
        have = ", ".join(sorted({r["method"] for r in every})) or "none"
        raise ResultsError(f"{folder}: no rows of {method!r} (methods there: {have})")
    outside = sorted({r["world"] for r in rows if barn_index(r["world"]) not in CHALLENGE})
    if outside:
        raise ResultsError(
            f"{folder}: world {outside[0]} is not in BARN's challenge split: the curve is read "
            "on challenge alone (d3dwa eval --suite barn --split challenge)"
        )
    seeds = sorted({r["policy_seed"] for r in rows}, key=lambda s: -1 if s is None else s)
    if len(seeds) < MIN_SEEDS or None in seeds:
        shown = ", ".join("one policy" if s is None else f"seed-{s}" for s in seeds)
        raise ResultsError(
            f"{folder}: {len(seeds)} training seed{'s' * (len(seeds) != 1)} of {method!r} "
            f"({shown}); a point of the curve needs {MIN_SEEDS} or more seed-<k> folders"
        )
    for metric in METRICS:
        if any(metric_value(r, metric) is None for r in rows):
            raise ResultsError(
                f"{folder}: rows without {metric!r} (results from before the score: resume its "
                "d3dwa eval to score them)"
            )
    return rows, check_trained_worlds(k, policy_folder(folder, method), seeds)


def check_comparable(points: Mapping[int, tuple[Path, Rows]]) -> None:
    """ResultsError unless every point ran the same worlds under one noise and recovery layer."""
    (k0, (dir0, rows0)), *rest = points.items()

    def what(folder: Path, rows: Rows) -> dict[str, Any]:
        return {"worlds": {r["world"] for r in rows}, "noise": {r["noise"] for r in rows},
                "recovery": recovery_of(folder)}  # fmt: skip

    first = what(dir0, rows0)
    if len(first["noise"]) != 1:
        raise ResultsError(f"{dir0}: rows under {len(first['noise'])} noise profiles; give one")
    for k, (folder, rows) in rest:
        got = what(folder, rows)
        for name in ("worlds", "noise", "recovery"):
            if got[name] != first[name]:
                shown = [f"{len(x)} worlds" if name == "worlds" else
                         x if isinstance(x, str) else ", ".join(sorted(x))
                         for x in (got[name], first[name])]  # fmt: skip
                raise ResultsError(
                    f"points {k} ({folder}) and {k0} ({dir0}) differ in {name}: {shown[0]} vs "
                    f"{shown[1]}{' (not the same ones)' if name == 'worlds' else ''}; a curve "
                    "compares one setting"
                )


def seed_values(rows: Rows, metric: str) -> dict[int, float]:
    """{training seed: its mean over worlds of metric} (each world's rows averaged first)."""
    per: dict[int, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        per[r["policy_seed"]][r["world"]].append(metric_value(r, metric) or 0.0)  # None refused
    return {s: float(np.mean([np.mean(v) for v in w.values()])) for s, w in sorted(per.items())}


def summary(rows: Rows) -> dict[str, dict[str, Any]]:
    """{metric: {"mean", "low", "high", "seeds": {seed: value}}}: the 95 % t interval over
    training seeds of their means over worlds, cut to [0, 1]."""
    out = {}
    for metric in METRICS:
        values = seed_values(rows, metric)
        mean, low, high = t_interval(list(values.values()))
        # every metric lies in [0, 1]: a bound t puts outside it says no more than the edge
        low, high = max(low, 0.0), min(high, 1.0)
        out[metric] = {"mean": mean, "low": low, "high": high, "seeds": values}
    return out


def reading(
    points: Mapping[int, tuple[Path, Rows]], margins: Mapping[str, float]
) -> dict[str, Any]:
    """The largest K (A) against the smallest (B), paired by world: {metric: reading record}."""
    a, b = max(points), min(points)
    rows = [r | {"method": f"K={k}"} for k in (a, b) for r in points[k][1]]
    return {
        metric: {"metric": metric} | reading_of(
            paired_scores(rows, f"K={a}", f"K={b}", by_seed=False, metric=metric), margin
        )
        for metric, margin in margins.items()
    }  # fmt: skip


def answer(a: int, b: int, records: Mapping[str, Mapping[str, Any]]) -> str:
    """One sentence: do more training worlds buy success here (and what the score says)."""
    r = records["success"]
    text = reading_text(r)
    if r.get("low") is not None:
        low, high = 100 * r["low"], 100 * r["high"]
        text += f"; {a} - {b}: {100 * r['difference']:+.1f} points [{low:+.1f}, {high:+.1f}]"
    verdicts = {"A better": "Yes", "B better": "No (fewer read better)", "equivalent": "No"}
    verdict = verdicts.get(r.get("reading") or "", "Not decided")
    out = f"Do more training worlds buy success here? {verdict}: {a} against {b} worlds, "
    out += f"success: {text}."
    if "score" in records:
        out += f" Score: {reading_text(records['score'])}."
    return out.replace("A better", f"{a} worlds better").replace("B better", f"{b} worlds better")


def _cell(metric: str, s: Mapping[str, Any]) -> tuple[str, str]:
    scale, fmt = (100.0, ".1f") if metric == "success" else (1.0, ".3f")
    main = f"{scale * s['mean']:{fmt}} [{scale * s['low']:{fmt}}, {scale * s['high']:{fmt}}]"
    seeds = ", ".join(f"{scale * v:{fmt}}" for v in s["seeds"].values())
    return main, seeds


def markdown(curve: Mapping[str, Any]) -> str:
    """The table (one row per K) and the reading, as Markdown."""
    head = "| training worlds | seeds | K checked by |"
    rule = "|---:|---|---|"
    for metric in METRICS:
        head += f" {LABELS[metric]} [95 %] | per seed |"
        rule += "---|---|"
    lines = [f"Diversity curve of `{curve['method']}` on BARN challenge ({curve['worlds']} worlds, "
             f"noise {curve['noise']}, recovery {curve['recovery']}).", "", head, rule]  # fmt: skip
    for p in curve["points"]:
        cells = [c for m in METRICS for c in _cell(m, p[m])]
        seeds = ", ".join(map(str, p["seeds"]))
        lines.append(f"| {p['k']} | {seeds} | {p['checked']} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Interval: Student t over training seeds, cut to [0, 1]; per seed in seed order.",
        "",
    ]
    group = {f"A = {curve['a']} worlds, B = {curve['b']} worlds": curve["reading"]}
    return "\n".join(lines) + "\n" + readings_table(group) + "\n" + curve["answer"] + "\n"


def draw(curve: Mapping[str, Any], out: Path) -> Path:
    """Two panels (success, score) over K on a log axis: each seed a faint dot, the mean with its
    interval; written atomically."""
    import matplotlib  # start-up cost: only the figure needs it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from d3dwa_bullet.evaluation.plotting import save_figure  # with matplotlib, for the figure only

    fig, axes = plt.subplots(1, 2, figsize=(8.0, 3.6))
    ks = [p["k"] for p in curve["points"]]
    for ax, metric in zip(axes, ("success", "score"), strict=True):
        scale = 100.0 if metric == "success" else 1.0
        for p in curve["points"]:
            dots = [scale * v for v in p[metric]["seeds"].values()]
            # beside the interval bar, not under it: a seed must stay visible
            ax.scatter([p["k"] * SEED_DOT] * len(dots), dots, s=14, color="C0", alpha=0.35, lw=0)
        s = [p[metric] for p in curve["points"]]
        ys = np.array([scale * c["mean"] for c in s])
        err = [ys - [scale * c["low"] for c in s], [scale * c["high"] for c in s] - ys]
        ax.errorbar(ks, ys, yerr=err, fmt="o-", color="C0", capsize=4, lw=1.2)
        ax.set_xscale("log")
        ax.set_xticks(ks, [str(k) for k in ks])
        ax.minorticks_off()
        ax.set_xlim(min(ks) / 1.6, max(ks) * 1.6)
        ax.set_xlabel("BARN training worlds")
        ax.set_ylabel(LABELS[metric] + ", 95 % interval over seeds")
        ax.grid(alpha=0.3)
    a, b = curve["a"], curve["b"]
    said = reading_text(curve["reading"]["success"])
    for side, k in (("A", a), ("B", b)):
        said = said.replace(f"{side} better", f"{k} worlds better")
    fig.suptitle(f"{curve['method']} on BARN challenge ({curve['worlds']} worlds, noise "
                 f"{curve['noise']}, recovery {curve['recovery']})\n{a} against {b} "
                 f"worlds, success: {said}", fontsize=9)  # fmt: skip
    fig.tight_layout()
    return save_figure(fig, out, dpi=110)


def curve_of(
    points: Mapping[int, Path], method: str, margins: Mapping[str, float]
) -> dict[str, Any]:
    """Everything the table, figure and --json show (refusals as ResultsError, one line)."""
    if len(points) < 2:
        raise ConfigError("a curve needs two points or more (K=EVALDIR ...), got "
                          f"{len(points)}")  # fmt: skip
    read = {k: point_rows(k, folder, method) for k, folder in sorted(points.items())}
    data = {k: (points[k], rows) for k, (rows, _) in read.items()}
    check_comparable(data)
    first_dir, first_rows = next(iter(data.values()))
    records = reading(data, margins)
    a, b = max(data), min(data)
    return {
        "method": method, "worlds": len({r["world"] for r in first_rows}),
        "noise": first_rows[0]["noise"], "recovery": recovery_of(first_dir), "a": a, "b": b,
        "points": [{"k": k, "dir": str(points[k]), "checked": checked,
                    "seeds": sorted({r["policy_seed"] for r in rows})} | summary(rows)
                   for k, (rows, checked) in read.items()],
        "reading": records, "answer": answer(a, b, records),
    }  # fmt: skip


def commands(seeds: str = "0-2", root: str = "runs/barn-diversity") -> list[str]:
    """The commands that make the curve's points and then the curve, in order; each resumes."""
    lines, evals = [], []
    config = f"configs/{METHOD}.yaml"
    for k in KS:
        if k == TRAIN_SIZE:  # the method itself: its own seeds (configs/d3dwa-barn.yaml)
            policy = f"runs/{METHOD}"
            lines.append(f"d3dwa train --config {config} --seeds 0-4 --out {policy} "
                         f"--export policies/{METHOD}")  # fmt: skip
        else:
            policy = f"{root}/w{k}"
            lines.append(f"d3dwa train --config {config} --barn-worlds {k} --seeds {seeds} "
                         f"--out {policy}")  # fmt: skip
        evals.append((k, policy, f"{root}/eval-w{k}"))
    for _, policy, out in evals:
        lines.append(f"d3dwa eval --suite barn --split challenge --methods {METHOD} --policy "
                     f"{policy} --recovery nav2 --noise none --seeds 1 --out {out}")  # fmt: skip
    points = " ".join(f"{k}={out}" for k, _, out in evals)
    lines.append(f"python -m tools.experiments.diversity_curve {points} "
                 f"--out docs/figures/diversity_curve.png --table {root}/curve.md")  # fmt: skip
    return lines


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="diversity_curve", description=__doc__.split("\n")[0])
    parser.add_argument(
        "points", nargs="*", help="K=EVALDIR: a d3dwa eval of the seeds trained on K worlds"
    )
    parser.add_argument("--method", default=METHOD, help="the learned method (default %(default)s)")
    parser.add_argument("--out", type=Path, help="the PNG to write")
    parser.add_argument("--table", type=Path, help="also write the Markdown table here")
    parser.add_argument("--commands", action="store_true",
                        help="print the commands that make every point, then stop")  # fmt: skip
    parser.add_argument("--train-seeds", default="0-2", help="with --commands: seeds per point")
    for metric, option in MARGIN_OPTIONS.items():
        parser.add_argument(option, type=float, default=option_value(metric, MARGINS[metric]),
                            help="equivalence margin, as `d3dwa compare` takes it "
                            "(default %(default)g)")  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print the curve's numbers as JSON")
    args = parser.parse_args(argv)
    if args.commands:
        parse_seeds(args.train_seeds, "--train-seeds")  # ConfigError: one line naming it
        print("\n".join(commands(args.train_seeds)))
        return 0
    if args.out is None or args.out.suffix.lower() != ".png":
        parser.error(f"--out must name a .png file, got {args.out}")
    margins = {m: check_margin(getattr(args, o[2:].replace("-", "_")), m)
               for m, o in MARGIN_OPTIONS.items()}  # fmt: skip
    points: dict[int, Path] = {}
    for text in args.points:
        k, folder = parse_point(text)
        if k in points:
            raise ConfigError(f"point K={k} is given twice ({points[k]} and {folder})")
        points[k] = folder
    curve = curve_of(points, args.method, margins)
    draw(curve, args.out)
    table = markdown(curve)
    if args.table is not None:
        args.table.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(args.table, table)
    curve["figure"] = str(args.out)
    print(json.dumps(curve, indent=1) if args.json else table + f"\nfigure: {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
