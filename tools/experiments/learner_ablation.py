"""Short learner ablations: one committed config with a few fields changed, over seeds.

    python -m tools.experiments.learner_ablation --config configs/d3dwa.yaml --steps 40000 \\
        --seeds 0-2 --set agent.tau_soft=0.001 --set agent.gamma=0.99 --out runs/abl/tau001
    python -m tools.experiments.learner_ablation --summarise runs/abl/* --json

Each variant trains ``--seeds`` seeds of the config (``total_steps`` = ``--steps``, greedy
evaluation every ``--eval-every``) into ``<out>/seed-<k>/`` (``--resume`` continues them), then
prints per seed the growth of the mean Q of the taken actions (``losses/q_values``) and every
greedy evaluation's success and value calibration (mean Q of the visited (s, a) against the
discounted return they earned). ``--summarise`` reads finished or running variants only.
This is a developer instrument (docs/history.md#learner): the variants are evidence, not
methods.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from d3dwa_bullet.errors import ConfigError, D3DWAError
from d3dwa_bullet.learning.training import load_train_config, read_metrics, train
from d3dwa_bullet.learning.training.config import TrainConfig
from d3dwa_bullet.learning.value_calibration import ValueCalibration
from d3dwa_bullet.loading import load_yaml, parse_yaml
from d3dwa_bullet.seed_dirs import seed_dirs
from tools.entry import ToolParser, fail, tool_main


def parse_set(items: list[str]) -> dict[str, Any]:
    """``a.b=value`` pairs (values parsed as YAML scalars) -> a nested dict."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, raw = item.partition("=")
        if not sep or not key:
            raise SystemExit(f"learner_ablation: error: --set {item!r}: expected FIELD=VALUE")
        node = out
        *parents, leaf = key.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = parse_yaml(raw, ConfigError, f"--set {item}")
    return out


def variant_config(base: Path, steps: int, eval_every: int, changes: dict[str, Any]) -> dict:
    """The base config's fields with ``changes`` merged in (one level deep for ``agent``)."""
    data = load_train_config(base).to_dict()
    for key, value in changes.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    data.update(total_steps=steps, eval_every=eval_every, checkpoint_every=eval_every)
    return data


def seed_summary(run: Path) -> dict[str, Any]:
    """The figures of one seed's run directory, read back from its metrics.jsonl."""
    q_taken = read_metrics(run, "losses/q_values")
    success = read_metrics(run, "eval/success_rate")
    mean_q = read_metrics(run, "eval/mean_q")
    ret = read_metrics(run, "eval/discounted_return")
    evals = []
    for s, q, g in zip(success, mean_q, ret, strict=False):
        cal = ValueCalibration(q["value"], g["value"], pairs=0, episodes=0)
        evals.append(
            {
                "step": s["step"],
                "success": s["value"],
                "mean_q": q["value"],
                "discounted_return": g["value"],
                "ratio": cal.ratio,
                "calibrated": cal.calibrated,
            }
        )
    marks = [3_000, 12_000, 24_000, 40_000, 60_000, 100_000, 250_000]
    growth = {}
    for m in marks:
        near = [r for r in q_taken if r["step"] <= m]
        if near and near[-1]["step"] >= 0.8 * m:
            growth[str(m)] = round(near[-1]["value"], 4)
    return {"run": str(run), "q_taken": growth, "evals": evals}


def summarise(variants: list[Path]) -> list[dict[str, Any]]:
    out = []
    for v in (v for v in variants if v.is_dir()):
        seeds = seed_dirs(v)
        runs = [seed_summary(p) for p in seeds.values() if (p / "metrics.jsonl").exists()]
        changes = (
            load_yaml(v / "variant.yaml", ConfigError) if (v / "variant.yaml").exists() else {}
        )
        out.append({"variant": v.name, "changes": changes or {}, "seeds": runs})
    return out


def _flat(changes: dict[str, Any], prefix: str = "") -> list[str]:
    out = []
    for k, val in changes.items():
        if isinstance(val, dict):
            out += _flat(val, f"{prefix}{k}.")
        else:
            out.append(f"{prefix}{k} {val}")
    return out


def markdown(summary: list[dict[str, Any]]) -> str:
    """One row per seed of every variant: what changed, Q taken over time, the final greedy
    evaluation's success and value calibration."""
    lines = [
        "| variant | changed (from the config) | seed | Q taken at 3k / 12k / 24k / 40k "
        "| final: success | mean Q | discounted return | ratio | tracks? |",
        "|---|---|---:|---|---:|---:|---:|---:|---|",
    ]
    for v in summary:
        changed = ", ".join(_flat(v["changes"])) or "none (as configured)"
        for s in v["seeds"]:
            q = " / ".join(f"{x:.2f}" for x in s["q_taken"].values()) or "--"
            e = s["evals"][-1] if s["evals"] else None
            if e is None:
                lines.append(
                    f"| {v['variant']} | {changed} | {Path(s['run']).name} | {q} | -- | | | | |"
                )
                continue
            ratio = "--" if e["ratio"] is None else f"{e['ratio']:.2f}"
            lines.append(
                f"| {v['variant']} | {changed} | {Path(s['run']).name} | {q} | {e['success']:.2f} "
                f"(step {e['step']}) | {e['mean_q']:.3f} | {e['discounted_return']:.3f} | {ratio} "
                f"| {'yes' if e['calibrated'] else 'no'} |"
            )
    return "\n".join(lines)


def describe(summary: list[dict[str, Any]]) -> str:
    lines = []
    for v in summary:
        lines.append(f"== {v['variant']}")
        for s in v["seeds"]:
            growth = " ".join(f"{k}:{q}" for k, q in s["q_taken"].items())
            lines.append(f"  {Path(s['run']).name}: Q of taken actions at steps {growth}")
            for e in s["evals"]:
                ratio = "-" if e["ratio"] is None else f"{e['ratio']:.2f}"
                lines.append(
                    f"    step {e['step']:>6}: success {e['success']:.2f}  mean Q "
                    f"{e['mean_q']:.3f}  return {e['discounted_return']:.3f}  ratio {ratio}"
                    f"{'' if e['calibrated'] else '  (not calibrated)'}"
                )
    return "\n".join(lines)


@tool_main
def main(argv: list[str] | None = None) -> int:
    ap = ToolParser(prog="python -m tools.experiments.learner_ablation")
    ap.add_argument("--config", type=Path, default=Path("configs/d3dwa.yaml"))
    ap.add_argument("--steps", type=int, default=40_000)
    ap.add_argument("--eval-every", type=int, default=10_000)
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--summarise", nargs="+", type=Path, metavar="VARIANT_DIR")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--markdown", action="store_true", help="with --summarise: one table")
    args = ap.parse_args(argv)
    try:
        if args.summarise:
            summary = summarise(args.summarise)
            if args.markdown:
                print(markdown(summary))
            else:
                print(json.dumps(summary, indent=1) if args.json else describe(summary))
            return 0
        if args.out is None or args.steps < 1 or args.eval_every < 1:
            ap.error("--out is required, --steps and --eval-every must be >= 1")
        lo, _, hi = args.seeds.partition("-")
        seeds = range(int(lo), int(hi or lo) + 1)
        data = variant_config(args.config, args.steps, args.eval_every, parse_set(args.set))
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "variant.yaml").write_text(yaml.safe_dump(parse_set(args.set) or {}))
        for seed in seeds:
            config = TrainConfig.from_dict({**data, "seed": seed}, f"{args.config} + --set")
            run = args.out / f"seed-{seed}"
            resume = args.resume and (run / "config.json").exists()
            if (run / "summary.json").exists() and not args.resume:
                continue
            train(None if resume else config, run, resume=resume, progress=True)
        print(describe(summarise([args.out])))
    except (D3DWAError, ValueError) as err:
        fail("learner_ablation", str(err))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
