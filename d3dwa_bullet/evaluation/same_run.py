"""Is a command the same run as the rows already in its results directory?

A run into a directory that already holds rows may resume it or extend it, never shrink or
mix it (:mod:`d3dwa_bullet.evaluation.results` says why): :func:`check_same_run` names what
differs (jobs left out, episode config, score form, episode settings, a policy's weights, a
method's or a world's source). :func:`check_resumable` is the part that needs no job, for a
command whose jobs take minutes to build (a sweep's generated layouts) to refuse before it.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from d3dwa_bullet.episode_metrics import SCORE_FORM
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.columns import (
    GLOBAL_PLAN_FIELD,
    with_backend,
    with_global_plan,
    with_recovery,
    with_sources,
)
from d3dwa_bullet.evaluation.repeats import Key
from d3dwa_bullet.evaluation.results import (
    EPISODE_SETTINGS,
    check_results_dir,
    read_meta,
    read_results,
    row_key,
)
from d3dwa_bullet.loading import parse_json
from d3dwa_bullet.method_specs import method_family


def run_fields(
    fields: Sequence[str],
    recovery: str,
    methods: Iterable[str],
    backend: str = "pybullet",
    global_plan: str = "none",
) -> tuple[str, ...]:
    """The CSV columns of a run of methods: fields, with the recovery, backend, global plan and
    source columns it needs."""
    external = any(method_family(m) == "external" for m in methods)
    fields = with_global_plan(with_backend(with_recovery(fields, recovery), backend), global_plan)
    return with_sources(fields, external)


def run_settings(
    settings: Mapping[str, Any] | None,
    recovery: str,
    backend: str = "pybullet",
    global_plan: str = "none",
) -> dict[str, Any]:
    """A command's settings as its meta.json records them: with the score form, the recovery
    layer and the global plan when they run, and the simulator backend when it is not PyBullet."""
    out = dict(settings or {"kind": "eval"}) | {"score_form": SCORE_FORM}
    if recovery != "none":
        out["recovery"] = recovery
    if backend != "pybullet":
        out["backend"] = backend
    if global_plan != "none":
        out[GLOBAL_PLAN_FIELD] = global_plan
    return out


def check_resumable(
    out: Path, fields: Sequence[str], config: Any, settings: Mapping[str, Any],
    methods: Iterable[str],
) -> None:  # fmt: skip
    """ResultsError unless out takes a run of methods with these columns, episode config and
    settings (as given to ``evaluate``), whatever its jobs: the checks of
    :func:`check_same_run` that need no job, with the directory's format and columns."""
    recovery, backend, plan = config.recovery_name, config.backend, config.global_plan_name
    fields = run_fields(fields, recovery, methods, backend=backend, global_plan=plan)
    check_results_dir(out, fields, recovery, backend)
    if _holds_rows(out):
        _check_settings(
            out, config, run_settings(settings, recovery, backend=backend, global_plan=plan)
        )


def _holds_rows(out: Path) -> bool:
    path = out / "results.csv"
    if not path.exists():
        return False
    with path.open(encoding="utf-8") as fh:
        fh.readline()
        return bool(fh.readline().strip())


def config_record(config: Any) -> Any:
    """An episode config as meta.json holds it (JSON types: a tuple reads back as a list), to
    compare with a directory's ``config``."""
    return parse_json(json.dumps(asdict(config), default=str), ResultsError, "episode config")


def check_same_run(
    out: Path, keys: Sequence[Key], config: Any, settings: Mapping[str, Any]
) -> None:
    """ResultsError unless a run of jobs ``keys`` with ``config`` (an EpisodeConfig) and
    ``settings`` resumes or extends the rows already in out/results.csv (see the module
    docstring); the message names what differs. A directory without rows takes any run."""
    rows = read_results(out)
    if not rows:
        return
    wanted = set(keys)
    extra = [row_key(r) for r in rows if row_key(r) not in wanted]
    if extra:
        parts = []
        for i, name in enumerate(("worlds", "methods", "policy seeds", "seeds", "noise")):
            listed = {k[i] for k in wanted}
            absent = sorted({k[i] for k in extra} - listed, key=str)
            if absent:
                parts.append(f"{name} {', '.join(map(str, absent))}")
        what = "; ".join(parts) or "other combinations of the worlds, methods and seeds listed"
        raise ResultsError(
            f"{out / 'results.csv'}: holds {len(extra)} episode(s) this command does not list "
            f"({what}); list them too to extend that evaluation, or use another --out directory"
        )
    _check_settings(out, config, settings)


def _check_settings(out: Path, config: Any, settings: Mapping[str, Any]) -> None:
    meta = read_meta(out)
    here = config_record(config)
    if isinstance(meta.get("config"), dict):  # a directory from before backends ran PyBullet
        meta["config"].setdefault("backend", "pybullet")
        if isinstance(meta["config"].get("global_plan"), dict):  # from before the sight carrot
            meta["config"]["global_plan"].setdefault("carrot", "along")
    diffs = "; ".join(
        f"{name} {old!r} there, {new!r} here"
        for name, old, new in differences(meta.get("config", here), here)
    )
    if diffs:  # (a config without a newer field that is unset here is the same config)
        raise ResultsError(
            f"{out / 'meta.json'}: its episodes ran with another episode config ({diffs}); "
            "use the same options to resume, or another --out directory"
        )
    before = meta.get("settings", {})
    form, now = before.get("score_form"), settings.get("score_form")
    if form is not None and now is not None and form != now:
        raise ResultsError(
            f"{out / 'meta.json'}: its rows were scored in form {form!r}, this version scores "
            f"in form {now!r}; one directory holds one form: use another --out directory"
        )
    for key, option in EPISODE_SETTINGS.items():
        if (key in before or key in settings) and before.get(key) != settings.get(key):
            raise ResultsError(
                f"{out / 'meta.json'}: its episodes ran with {option} {before.get(key)!r}, this "
                f"command has {settings.get(key)!r}; use the same value to resume, or another "
                "--out directory"
            )
    changed = changed_keys(before.get("policy_digests", {}), settings.get("policy_digests", {}))
    if changed:
        raise ResultsError(
            f"{out / 'meta.json'}: its {', '.join(changed)} episodes were driven by other "
            "weights than the policy this command loads (retrained or replaced since); use "
            "another --out directory"
        )
    old, now = before.get("method_sources", {}), settings.get("method_sources", {})
    changed = changed_keys(old, now)
    if changed:
        raise ResultsError(
            f"{out / 'meta.json'}: method {changed[0]!r} came from {old[changed[0]]}, this "
            f"command's from {now[changed[0]]}; one directory never mixes two sources under "
            "one name: use another --out directory"
        )
    old = dict(zip(before.get("worlds", []), before.get("world_sources", []), strict=False))
    now = dict(zip(settings.get("worlds", []), settings.get("world_sources", []), strict=False))
    changed = changed_keys(old, now)
    if changed:
        raise ResultsError(
            f"{out / 'meta.json'}: world {changed[0]!r} came from {old[changed[0]]}, this "
            f"command's from {now[changed[0]]}; use another --out directory"
        )


def changed_keys(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """The keys both mappings hold with different values, sorted: what a resumed run changed."""
    return sorted(k for k in old.keys() & new.keys() if old[k] != new[k])


def differences(old: Any, new: Any, prefix: str = "") -> list[tuple[str, Any, Any]]:
    """(dotted name, old value, new value) of each leaf where two JSON values differ."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in sorted(old.keys() | new.keys()):
            out += differences(old.get(k), new.get(k), f"{prefix}{k}.")
        return out
    return [] if old == new else [(prefix.rstrip("."), old, new)]
