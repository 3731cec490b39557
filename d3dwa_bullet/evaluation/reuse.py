"""``--reuse DIR``: take episodes another results directory already ran instead of running them.

Same seed, same episode, bit for bit: a job of this run whose key (world, method, policy seed,
seed, noise) is a row of DIR/results.csv need not run again if DIR provably ran the same
episode. :func:`plan_reuse` requires, before any episode runs (ResultsError naming the field
otherwise): DIR a results directory other than ``--out``, with this run's columns and score
form; the same episode config (``config.*``), ``--recovery`` and ``--time-limit``; for every
learned run of a reusable row, the same policy digest; a world of one name the same content.
A world is the same when both meta.json files hold its content digest (``world_digests``,
written since this module) and they are equal, or, for a directory from before, when both
runs name it by a name that fixes it (a shipped, BARN or generated world, not a file). Rows
that cannot be proven the same are not reused but run: a method from outside the package, a
noise profile from a file, an explicit noise config (a sweep's axis levels), a world file of
a directory without digests.

Drift (the code changed since DIR ran): ``check`` of the reusable episodes, evenly spaced
over them in job order, and the first of every method and noise profile not among those
(:func:`check_picks`), are rerun first and every cell compared with DIR's; any difference
refuses the run naming the key and the first differing column, and nothing is written to
OUT. Otherwise the fresh rows are kept and the others appended as the exact strings DIR wrote,
with DIR's logs when it has them (committed result folders do not: trajectory figures then
leave those methods out, and the page says how many episodes have no log).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from tqdm import tqdm

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.job import Job
from d3dwa_bullet.evaluation.repeats import Key
from d3dwa_bullet.evaluation.results import (
    RESULTS_FORMAT,
    csv_header,
    policy_seed_cell,
    read_meta,
    save_log,
)
from d3dwa_bullet.evaluation.same_run import config_record, differences
from d3dwa_bullet.io import atomic_write_bytes, read_text
from d3dwa_bullet.method_specs import method_family
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE

if TYPE_CHECKING:
    from d3dwa_bullet.world.model import World

REUSED_KEY = "reused"
"""meta.json settings entry: [{"from": DIR, "episodes": N, "checked": K}, ...], accumulated."""
DIGESTS_KEY = "world_digests"
"""meta.json settings entry: {world key: SHA-256 of the world's content}."""


@dataclass(frozen=True)
class Reuse:
    """What ``--reuse DIR --reuse-check K`` asks for."""

    dir: Path
    check: int = 3


def reuse_arg(directory: str | None, check: int, out: str | Path) -> Reuse | None:
    """The checked options (ConfigError, one line): DIR a results directory other than out,
    K >= 1. None without --reuse."""
    if check < 1:
        raise ConfigError(f"--reuse-check must be >= 1 (episodes rerun against DIR), got {check}")
    if directory is None:
        return None
    path = Path(directory)
    if not (path / "results.csv").is_file() or not (path / "meta.json").is_file():
        raise ConfigError(
            f"--reuse {directory}: not a results directory (no results.csv and meta.json)"
        )
    if path.resolve() == Path(out).resolve():
        raise ConfigError(
            f"--reuse {directory}: is the --out directory; a run resumes it without --reuse"
        )
    return Reuse(path, check)


def world_digest(world: World) -> str:
    """SHA-256 (hex) of a world's content: every field but where it was read from."""
    data = asdict(replace(world, source=""))
    text = json.dumps(data, sort_keys=True, default=lambda o: np.asarray(o).tolist())
    return hashlib.sha256(text.encode()).hexdigest()


def world_digests(worlds: Iterable[World]) -> dict[str, str]:
    """{world key: content digest} of a run's worlds (the settings entry DIGESTS_KEY). A name
    is digested once, however many jobs list its world (a key names one content:
    ``jobs.check_distinct``): a BARN world takes ~3 ms, and a sweep lists it in dozens of jobs."""
    digests: dict[str, str] = {}
    for world in worlds:
        if world.name not in digests:
            digests[world.name] = world_digest(world)
    return digests


@dataclass
class ReusePlan:
    """The reusable jobs of a run: ``checks`` rerun and compared, ``copies`` taken from DIR."""

    source: Path
    checks: list[Job]
    copies: list[Job]
    cells: dict[Key, dict[str, str]]
    """DIR's rows as written, by key."""
    fields: list[str]
    fresh: list[tuple[Job, Any]] = field(default_factory=list)

    @property
    def taken(self) -> set[Key]:
        return {j.key for j in self.checks + self.copies}

    def rerun(self, run: Callable[..., Iterable[tuple[Job, Any]]], worker: Any, config: Any,
              v_max: float, progress: bool) -> None:  # fmt: skip
        """Run the check episodes (``run(worker, jobs, config)``, a backend) and compare every
        cell with DIR's; ResultsError naming the key and the first differing column."""
        bar = tqdm(
            total=len(self.checks), disable=not progress, desc="reuse check", unit="ep", leave=False
        )  # a refusal is then the only line left
        with bar:
            for job, result in run(worker, self.checks, config):
                here = _cells(job.row(result, v_max), self.fields)
                there = self.cells[job.key]
                for name in self.fields:
                    if here[name] != there[name]:
                        raise ResultsError(
                            f"--reuse {self.source}: episode {job.key} reran with {name} "
                            f"{here[name]!r}, {self.source / 'results.csv'} has {there[name]!r}; "
                            "DIR's rows or the code changed since it ran: run without --reuse"
                        )
                self.fresh.append((job, result))
                bar.update(1)

    def copy(self, out: Path, append: Callable[[Mapping[str, Any]], None], v_max: float) -> None:
        """Append the checked episodes' fresh rows and DIR's other rows (its exact strings),
        with their logs (DIR's when it has them)."""
        for job, result in self.fresh:
            save_log(result, out / "logs" / job.log_name)
            append(job.row(result, v_max))
        for job in self.copies:
            log = self.source / "logs" / job.log_name
            if log.is_file():
                atomic_write_bytes(out / "logs" / job.log_name, log.read_bytes())
            append(self.cells[job.key])


def _cells(row: Mapping[str, Any], fields: Sequence[str]) -> dict[str, str]:
    """A row's cells as results.csv holds them (the strings appending_rows writes)."""
    buffer = io.StringIO(newline="")
    csv.DictWriter(buffer, fieldnames=list(fields), extrasaction="ignore").writerow(row)
    return dict(
        zip(fields, next(csv.reader(io.StringIO(buffer.getvalue(), newline=""))), strict=True)
    )


def _raw_rows(source: Path) -> dict[tuple[str, ...], dict[str, str]]:
    """DIR's rows as written, by their key cells; a last line cut short by a kill is left out."""
    text = read_text(source / "results.csv", ResultsError, "CSV file")
    text = text[: text.rfind("\n") + 1]
    rows = csv.DictReader(io.StringIO(text, newline=""))
    keys = ("world", "method", "policy_seed", "seed", "noise")
    return {tuple(r[k] for k in keys): r for r in rows if None not in r and None not in r.values()}


def _named_worlds(settings: Mapping[str, Any]) -> set[str]:
    """World keys a run named by a name that fixes the world (shipped, BARN, generated), not
    by a file: eval records each key's argument, sweep its --worlds and generator styles."""

    def named(arg: str) -> bool:
        return not Path(arg).suffix

    if settings.get("kind") == "eval":
        pairs = zip(settings.get("worlds", []), settings.get("world_sources", []), strict=False)
        return {key for key, arg in pairs if named(arg)}
    first = int(settings.get("layout_seed") or UNSEEN_LAYOUT_SEED_BASE)  # 2^31 before --layout-seed
    seeds = range(first, first + int(settings.get("layouts", 0)))
    generated = {f"{style}-s{seed}" for style in settings.get("styles", []) for seed in seeds}
    return {a for a in settings.get("worlds", []) if named(a)} | generated


def _same_world(name: str, there: Mapping[str, Any], here: Mapping[str, Any]) -> bool | None:
    """True if DIR's world ``name`` is provably this run's, None if that cannot be proven."""
    digests = there.get(DIGESTS_KEY)
    if isinstance(digests, dict) and name in digests:
        return digests[name] == here.get(DIGESTS_KEY, {}).get(name)
    return True if name in _named_worlds(there) and name in _named_worlds(here) else None


def _provable(job: Job, there: Mapping[str, Any], here: Mapping[str, Any]) -> bool:
    """A job whose episode the key and the checked settings fix: not from outside the package,
    no explicit noise config, no profile file."""
    sources = {**there.get("method_sources", {}), **here.get("method_sources", {})}
    return not (
        method_family(job.method) == "external" or job.method in sources
        or job.noise_config is not None or Path(job.noise).suffix or "/" in job.noise
    )  # fmt: skip


def _check_settings(source: Path, meta: Mapping[str, Any], config: Any,
                    settings: Mapping[str, Any], fields: Sequence[str]) -> None:  # fmt: skip
    """ResultsError naming the first meta.json field by which DIR's episodes differ."""
    where = f"--reuse {source}"
    if meta.get("format") != RESULTS_FORMAT or csv_header(source) != list(fields):
        raise ResultsError(
            f"{where}: its results.csv has columns {csv_header(source)} (format "
            f"{meta.get('format')!r}), this command writes {list(fields)} (format {RESULTS_FORMAT})"
        )
    diffs = differences(meta.get("config"), config_record(config))
    if diffs:
        name, old, new = diffs[0]
        raise ResultsError(
            f"{where}: its episodes ran with config.{name} {old!r}, this command has {new!r}"
        )
    there = meta.get("settings", {})
    for name in ("score_form", "recovery", "time_limit"):
        if there.get(name) != settings.get(name):
            raise ResultsError(
                f"{where}: its episodes ran with settings.{name} {there.get(name)!r}, this "
                f"command has {settings.get(name)!r}"
            )


def plan_reuse(reuse: Reuse, todo: Sequence[Job], config: Any, settings: Mapping[str, Any],
               fields: Sequence[str]) -> ReusePlan:  # fmt: skip
    """The jobs of ``todo`` (in job order) DIR provably ran; ResultsError (one line, the field)
    if DIR's episodes differ from this run's (see the module docstring)."""
    meta = read_meta(reuse.dir)
    _check_settings(reuse.dir, meta, config, settings, fields)
    there = meta.get("settings", {})
    rows = _raw_rows(reuse.dir)
    cells: dict[Key, dict[str, str]] = {}
    reusable: list[Job] = []
    for job in todo:
        w, m, p, s, n = job.key
        row = rows.get((w, m, policy_seed_cell(p), str(s), n))
        if row is None or not _provable(job, there, settings):
            continue
        same = _same_world(w, there, settings)
        if same is None:
            continue
        if not same:
            raise ResultsError(
                f"--reuse {reuse.dir}: its world {w!r} differs from this command's (content digest)"
            )
        if m in settings.get("policy_digests", {}) or any(
            k.startswith(f"{m}/") for k in settings.get("policy_digests", {})
        ):  # a learned run: the same weights
            name = m if p is None else f"{m}/seed-{p}"
            old, new = (
                there.get("policy_digests", {}).get(name),
                settings["policy_digests"].get(name),
            )
            if not old or old != new:
                raise ResultsError(
                    f"--reuse {reuse.dir}: the policy digest of {m!r}"
                    + ("" if p is None else f" seed {p}")
                    + f" is {old or 'not recorded'} there, {new or 'none'} here; drop that method or --reuse"
                )
        cells[job.key] = row
        reusable.append(job)
    picked = check_picks(reusable, reuse.check)
    checks = [j for i, j in enumerate(reusable) if i in picked]
    copies = [j for i, j in enumerate(reusable) if i not in picked]
    return ReusePlan(reuse.dir, checks, copies, cells, list(fields))


def check_picks(reusable: Sequence[Job], k: int) -> set[int]:
    """Indices of the episodes rerun against DIR, by a rule fixed before any runs (never by
    an outcome): ``k`` evenly spaced in job order, then the first episode of each method and
    of each noise profile not yet among them, so a drift that touches one method or one
    profile only (its policy, the profile's file) is met by at least one check."""
    if not reusable:
        return set()
    picked = set(np.linspace(0, len(reusable) - 1, min(k, len(reusable))).round().astype(int))
    for attribute in ("method", "noise"):
        covered = {getattr(reusable[i], attribute) for i in picked}
        for i, job in enumerate(reusable):
            if getattr(job, attribute) not in covered:
                covered.add(getattr(job, attribute))
                picked.add(i)
    return {int(i) for i in picked}


def reused_record(out: Path, plan: ReusePlan | None) -> list[dict[str, Any]]:
    """OUT's settings entry REUSED_KEY: what earlier runs into out reused, plus this plan's
    episodes (copied) and checks (rerun), accumulated per source directory."""
    earlier = read_meta(out).get("settings", {}).get(REUSED_KEY, [])
    record = [dict(e) for e in earlier if isinstance(e, dict)]
    if plan is None or not plan.taken:
        return record
    source = str(plan.source.resolve())
    entry = next((e for e in record if e.get("from") == source), None)
    if entry is None:
        entry = {"from": source, "episodes": 0, "checked": 0}
        record.append(entry)
    entry["episodes"] += len(plan.copies)
    entry["checked"] += len(plan.checks)
    return record


def reused_lines(settings: Mapping[str, Any]) -> list[str]:
    """ "N episodes reused from DIR (K rerun to check: identical)" per source a run's
    settings record."""
    return [
        f"{e['episodes']} episode{'' if e['episodes'] == 1 else 's'} reused from "
        f"{_shown(e['from'])} ({e['checked']} rerun to check: identical)"
        for e in settings.get(REUSED_KEY, [])
    ]


def _shown(source: str) -> str:
    """A recorded (absolute) DIR as a page shows it: relative to the working directory when it
    lies under it, so a page written in a checkout names no machine's path."""
    try:
        return str(Path(source).relative_to(Path.cwd()))
    except ValueError:
        return source


def reused_note(settings: Mapping[str, Any]) -> str:
    """What a results page says of the reused episodes ('' if none): the lines of
    :func:`reused_lines`, and that an episode DIR kept no log of has none here."""
    lines = reused_lines(settings)
    if not lines:
        return ""
    return (
        "; ".join(lines) + ". A reused episode whose directory kept no per-step log has none "
        "here either: trajectory figures leave it out (docs/design/metrics.md#reuse).\n\n"
    )
