"""What a policy chooses: how widely its (weights, horizon) choices spread, per run.

Reads every episode's per-step log of a sweep (or eval) directory and, per (noise, method,
training seed), counts the steps spent on each (wp, wc, ws, tau) tuple. It prints the number of
tuples used, the *perplexity* of that time-share histogram (exp of its entropy: 1 for a policy
that holds one tuple, 100 for one spread evenly over the 100 actions) and the share of steps on
one reference tuple (by default DWA III's, ``--tuple dwa3``; 1 % is the uniform chooser's share).
A diagnostic for issue 40: does a policy trained under noise settle on the tuple the fixed
planner wins with?

``--policy FOLDER`` (the seed-<k> folders the sweep drove, one learned method) also reads how
sure each seed is of its choices: at every decision step of its logs (each ``decision_steps``-th
step) it evaluates the seed's network (or DQDWA's table, at the logged observation's
discretised state) on the logged observation and reports the medians of
Q(best) - Q(second best) and Q(best) - Q(reference tuple), and how often the network's argmax
is the logged action (1.0 unless the logs are not this policy's).

    python -m tools.experiments.action_spread runs/r3-nav2 --methods d3dwa-dr
    python -m tools.experiments.action_spread runs/r3-nav2 --methods d3dwa-dr --policy policies/d3dwa-dr
"""

from __future__ import annotations

import json
from collections import Counter, defaultdict
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.jobs import row_log
from d3dwa_bullet.evaluation.results import job_rows
from d3dwa_bullet.method_specs import FIXED
from d3dwa_bullet.seed_dirs import seed_dirs
from tools.entry import ToolParser, tool_main

Tuple4 = tuple[float, float, float, float]


def perplexity(counts: Counter[Tuple4]) -> float:
    """exp(entropy) of the histogram counts: the effective number of tuples."""
    p = np.array(list(counts.values()), dtype=float)
    p = p[p > 0] / p.sum()
    return float(np.exp(-(p * np.log(p)).sum()))


def reference_tuple(name: str) -> Tuple4:
    """A fixed method's (wp, wc, ws, tau); ResultsError naming an unknown one."""
    if name not in FIXED:
        raise ResultsError(f"--tuple: {name!r} is not a fixed method ({', '.join(sorted(FIXED))})")
    a = FIXED[name]
    return (a.wp, a.wc, a.ws, a.tau)


def _logs(out: Path, methods: Sequence[str]) -> Iterator[tuple[Mapping[str, Any], dict[str, Any]]]:
    """(row, per-step log) of every episode of the methods in results directory out."""
    if not (out / "results.csv").is_file():
        raise ResultsError(f"{out}: no results.csv")
    for r in job_rows(out):
        if r["method"] in methods:
            yield r, row_log(out, r)


def spread(
    out: Path, methods: Sequence[str], reference: Tuple4, policy: Path | None = None
) -> list[dict[str, Any]]:
    """One record per (noise, method, policy seed) of the chosen methods; with ``policy`` (the
    seed folders of the one method) also each seed's value margins (:func:`_margins`), from
    the same pass over the logs."""
    if policy is not None and len(methods) != 1:
        raise ResultsError(f"--policy reads one method's seeds, got --methods {','.join(methods)}")
    networks = _networks(policy, reference) if policy is not None else {}
    counts: dict[tuple[str, str, int | None], Counter[Tuple4]] = defaultdict(Counter)
    decisions: dict[tuple[str, str, int | None], list[np.ndarray]] = defaultdict(list)
    for r, log in _logs(out, methods):
        run = (r["noise"], r["method"], r["policy_seed"])
        steps = zip(log["wp"], log["wc"], log["ws"], log["tau"], strict=True)
        counts[run].update(
            (float(wp), float(wc), float(ws), float(tau)) for wp, wc, ws, tau in steps
        )
        if policy is not None:
            if r["policy_seed"] not in networks:
                k = r["policy_seed"]
                raise ResultsError(f"--policy {policy}: no seed-{k} for {out}'s rows of seed {k}")
            decisions[run].append(_decision_margins(log, *networks[r["policy_seed"]]))
    if not counts:
        raise ResultsError(f"{out}: no episodes of {', '.join(methods)}")
    return [
        {
            "noise": run[0],
            "method": run[1],
            "policy_seed": run[2],
            "steps": sum(c.values()),
            "tuples": len(c),
            "perplexity": perplexity(c),
            "reference_share": c[reference] / sum(c.values()),
            **(_margins(np.concatenate(decisions[run])) if run in decisions else {}),
        }  # fmt: skip
        for run, c in sorted(counts.items())
    ]


def _networks(policy: Path, reference: Tuple4) -> dict[int, tuple[Any, int, int]]:
    """{seed: (its agent, a D3QN or a DQDWA table; the reference tuple's action index; its
    decision period)} of the seed-<k> folders of ``policy``; ResultsError for none."""
    # start-up cost: torch, only with --policy
    from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint
    from d3dwa_bullet.learning.agents.policy_terms import checkpoint_terms
    from d3dwa_bullet.planning.actions import ActionSet, PlannerAction

    folders = seed_dirs(policy)
    if not folders:
        raise ResultsError(f"--policy {policy}: no seed-<k> folders")
    networks = {}
    for k, folder in folders.items():
        agent, meta = load_checkpoint(folder)
        ref = ActionSet.from_dict(meta["actions"]).encode(PlannerAction(*reference))
        networks[k] = (agent, ref, checkpoint_terms(meta, str(folder / "meta.json"))[0])
    return networks


def _decision_margins(log: Mapping[str, Any], agent: Any, ref: int, period: int) -> np.ndarray:
    """Per decision step of an episode's log (each ``period``-th step): Q(best) - Q(2nd),
    Q(best) - Q(ref), and whether the network's argmax is the logged action."""
    from d3dwa_bullet.learning.agents.policy import all_q_values

    at = slice(0, None, period)
    q = all_q_values(agent, log["observations"][at])
    chosen = np.asarray(log["action"], dtype=int)[at]
    top = np.sort(q, axis=1)
    return np.column_stack(
        [top[:, -1] - top[:, -2], top[:, -1] - q[:, ref], q.argmax(axis=1) == chosen]
    )


def _margins(m: np.ndarray) -> dict[str, float]:
    """Medians of a run's decision margins (:func:`_decision_margins`) and its argmax share."""
    return {"best_minus_second": float(np.median(m[:, 0])),
            "best_minus_reference": float(np.median(m[:, 1])),
            "argmax_is_logged": float(m[:, 2].mean()), "decisions": len(m)}  # fmt: skip


def markdown(records: Sequence[dict[str, Any]], reference: str) -> str:
    head = ["noise", "method", "seed", "steps", "tuples used", "perplexity", f"{reference} share"]
    sure = any("best_minus_second" in r for r in records)
    if sure:
        head += ["decisions", "Q(best) - Q(2nd), median", f"Q(best) - Q({reference}), median",
                 "argmax = logged"]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    for r in records:
        cells = [r["noise"], r["method"], r["policy_seed"] if r["policy_seed"] is not None else "-",
                 r["steps"], r["tuples"], f"{r['perplexity']:.0f}",
                 f"{100 * r['reference_share']:.1f} %"]  # fmt: skip
        if sure:
            cells += ([r["decisions"], f"{r['best_minus_second']:.3f}",
                       f"{r['best_minus_reference']:.3f}", f"{r['argmax_is_logged']:.2f}"]
                      if "decisions" in r else [""] * 4)  # fmt: skip
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    return "\n".join(lines) + "\n"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="action_spread", description=__doc__.split("\n")[0])
    parser.add_argument("dir", type=Path, help="a results directory of `d3dwa sweep` or `eval`")
    parser.add_argument("--methods", required=True, help="comma-separated methods to read")
    parser.add_argument("--tuple", default="dwa3", help="the reference fixed method's tuple")
    parser.add_argument("--policy", type=Path, help="the seed folders of the one learned method")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    reference = reference_tuple(args.tuple)
    methods = [m for m in args.methods.split(",") if m]
    records = spread(args.dir, methods, reference, args.policy)
    print(json.dumps(records, indent=1) if args.json else markdown(records, args.tuple), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
