"""``d3dwa export --onnx DIR``: trained D3QN policies -> ONNX files, for robots without torch.

    d3dwa export --onnx onnx/                       every shipped seed of every network method
    d3dwa export --onnx onnx/ --method d3dwa --seeds 0,2
    d3dwa export --onnx onnx/ --method d3dwa --policy runs/d3dwa   a trained folder of seeds

A folder of training seeds becomes ``DIR/<method>/seed-<k>.onnx``; a single checkpoint
directory ``DIR/<method>/<its name>.onnx``. Each file is checked against the torch network
before it is written (``learning.agents.onnx_export``), and one line per file says what was
written and the largest |Q_onnx - Q_torch| measured. The method, policy folder, seeds and
DIR are all checked before the first file is written; ``d3dwa run --onnx FILE`` then drives
an episode with one. An existing file is replaced only if it is a policy ``export`` wrote
(its d3dwa metadata reads), or with ``--force``; a symbolic link, in DIR or as DIR/<method>,
is never written through.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from d3dwa_bullet.cli.output import check_out_dir, json_text
from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.io import file_stem
from d3dwa_bullet.seed_dirs import SEED_DIR, parse_seeds, seed_dirs

ONNX_SUFFIX = ".onnx"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export", help="export trained D3QN policies to ONNX files")
    p.add_argument(
        "--onnx",
        required=True,
        metavar="DIR",
        help="directory to write DIR/<method>/seed-<k>.onnx into (created if missing)",
    )
    p.add_argument(
        "--method",
        help="a learned method whose policy is a network, such as d3dwa (not dqdwa; default: "
        "every one with shipped policies)",
    )
    p.add_argument(
        "--policy",
        metavar="DIR",
        help="with --method: a checkpoint directory or a folder of seed-<k> checkpoints "
        "(default: the shipped policies/<method>/)",
    )
    p.add_argument(
        "--seeds", help="training seeds of the folder to export, e.g. 0-4 or 0,2 (default: all)"
    )
    p.add_argument(
        "--force", action="store_true",
        help="replace a file in DIR even if it is not a policy written by export",
    )  # fmt: skip
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(
        func=cmd_export, interrupted="the files written so far are complete; the rest were not"
    )


def cmd_export(args: argparse.Namespace) -> int:
    # start-up cost: the exporter imports torch and onnx, the method registry the planner
    # (numba), none of which `d3dwa --help` needs
    from d3dwa_bullet.learning.agents.onnx_export import check_exportable, export_onnx
    from d3dwa_bullet.method_specs import LEARNED, method_observation

    methods = _methods(args.method, args.policy)
    out = Path(args.onnx)
    jobs: list[tuple[str, Path, Path]] = []
    for method in methods:
        for source in _sources(method, args.policy, args.seeds, explicit=args.method is not None):
            check_exportable(source)  # a tabular or broken one stops before any write
            name = file_stem(source.resolve().name)  # "." names the directory it is
            jobs.append((method, source, out / method / f"{name}{ONNX_SUFFIX}"))
    if not jobs:
        raise CheckpointError(
            f"no shipped policy of {', '.join(methods)} to export; train one, or pass "
            "--method and --policy DIR"
        )
    check_out_dir(out, "--onnx", subdirs=methods)
    for _, _, dest in jobs:
        _check_replaceable(dest, args.force)
    rows = []
    for method, source, dest in jobs:
        reader = f"method {method!r}"
        result = export_onnx(
            source,
            dest,
            method=method,
            expected_actions=LEARNED[method],
            expected_observation=(method_observation(method), reader),
        )
        row = {
            "file": str(result.file), "method": method, "policy": str(source),
            "observation": result.observation, "actions": result.n_actions,
            "bytes": result.bytes, "max_abs_dq": result.max_abs_dq, "max_abs_q": result.max_abs_q,
            "agreement": result.agreement, "checked": result.checked,
        }  # fmt: skip
        rows.append(row)
        if not args.json:
            agree = round(result.agreement * result.checked)
            print(
                f"wrote {result.file} ({method} from {source}, {result.observation} observation, "
                f"{result.n_actions} actions, {result.bytes} bytes): max |Q_onnx - Q_torch| "
                f"{result.max_abs_dq:.2g} (|Q| up to {result.max_abs_q:.3g}) on {result.checked} "
                "observations, same greedy "
                f"action on {agree}/{result.checked}",
                flush=True,
            )
    if args.json:
        print(json_text(rows))
    return 0


def _check_replaceable(dest: Path, force: bool) -> None:
    """ConfigError unless dest is new, a policy file export wrote, or (force) any regular
    file: a model or a file of the user's that happens to sit there is not replaced."""
    from d3dwa_bullet.learning.agents.onnx_policy import onnx_metadata  # start-up cost: numpy

    if not os.path.lexists(dest):
        return
    if dest.is_symlink() or not dest.is_file():
        what = "is a symbolic link" if dest.is_symlink() else "exists and is not a regular file"
        raise ConfigError(f"--onnx: {dest} {what}; export writes only its own files: remove it")
    if force:
        return
    try:
        onnx_metadata(dest)
    except CheckpointError:
        raise ConfigError(
            f"--onnx: {dest} exists and is not a policy written by `d3dwa export`; remove it, "
            "choose another DIR, or pass --force to replace it"
        ) from None


def _methods(method: str | None, policy: str | None) -> list[str]:
    """The methods to export: --method checked, or every network method."""
    from d3dwa_bullet.method_specs import (  # start-up cost: numba
        FIXED,
        ONNX_METHODS,
        check_method,
        method_family,
        needs_policy,
    )

    if method is None:
        if policy is not None:
            raise ConfigError(f"--policy {policy} needs --method: which method's policy is it?")
        return list(ONNX_METHODS)
    check_method(method)
    if method in FIXED:
        raise ConfigError(f"--method {method} is a fixed DWA: it has no policy to export")
    if not needs_policy(method):
        raise ConfigError(
            f"--method {method} is a {method_family(method)} method: it has no policy to export"
        )
    if method not in ONNX_METHODS:
        raise ConfigError(
            f"--method {method}: its policy is a Q-table over a discretised state, not a "
            f"network; ONNX export takes {', '.join(ONNX_METHODS)}"
        )
    return [method]


def _sources(method: str, policy: str | None, seeds: str | None, *, explicit: bool) -> list[Path]:
    """The checkpoint directories of one method to export (see module docstring).

    explicit: the user named the method, so a method without policies is an error rather
    than nothing to do."""
    from d3dwa_bullet.controllers import default_policy_path  # start-up cost: numba

    folder = Path(policy) if policy is not None else default_policy_path(method)
    if (folder / "meta.json").exists():
        if seeds is not None:
            raise ConfigError(
                f"--seeds {seeds}: {folder} is one checkpoint, not a folder of seed-<k> ones"
            )
        return [folder]
    found = seed_dirs(folder)
    if not found:
        if not explicit:
            return []
        what = "does not exist" if not folder.exists() else "holds no checkpoint"
        raise CheckpointError(
            f"{folder}: {what} (no meta.json, no seed-<k>/ checkpoints); no policy of "
            f"method {method!r} to export"
        )
    if seeds is None:
        return list(found.values())
    wanted = parse_seeds(seeds)
    missing = [k for k in wanted if k not in found]
    if missing:
        raise ConfigError(
            f"--seeds {seeds}: {folder} has no {', '.join(SEED_DIR.format(k) for k in missing)} "
            f"(it has seeds {', '.join(map(str, found))})"
        )
    return [found[k] for k in wanted]
