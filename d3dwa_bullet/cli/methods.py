"""``d3dwa methods``: list the built-in methods and the installed ones from outside the
package (entry point group ``d3dwa_bullet.methods``), with where each came from."""

from __future__ import annotations

import argparse

from d3dwa_bullet.cli.output import json_text
from d3dwa_bullet.controllers import default_policy_path
from d3dwa_bullet.external.protocol import ENTRY_POINT_GROUP, INTERFACE_VERSION
from d3dwa_bullet.method_specs import LEARNED, METHODS, method_family, method_label
from d3dwa_bullet.seed_dirs import seed_dirs


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("methods", help="list the built-in methods and the installed external ones")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_methods)


def shipped_policy(method: str) -> str:
    """What ships for a learned method: its policy's training seeds, or that none does yet
    (a policy trained elsewhere is still taken with --policy)."""
    folder = default_policy_path(method)
    seeds = sum((path / "meta.json").is_file() for path in seed_dirs(folder).values())
    single = (folder / "meta.json").is_file()
    if seeds or single:
        return f"shipped policy, {seeds or 1} training seed{'s' if seeds > 1 else ''}"
    return "no shipped policy: train one, or pass --policy DIR"


def cmd_methods(args: argparse.Namespace) -> int:
    # start-up cost: resolving imports each installed method's module, which only this
    # command and a run of an external method need
    from d3dwa_bullet.external.resolve import installed_methods

    rows = [
        {"name": m, "family": method_family(m), "label": method_label(m), "source": "built-in"}
        | ({"policy": shipped_policy(m)} if m in LEARNED else {})
        for m in METHODS
    ]
    rows += [
        {"name": r["name"], "family": "external", "label": r["kind"], "source": r["origin"]}
        for r in installed_methods()
    ]
    if args.json:
        print(json_text(rows))
        return 0
    width = max(len(r["name"]) for r in rows)
    for r in rows:
        policy = f"; {r['policy']}" if "policy" in r else ""
        print(f"{r['name']:<{width}}  {r['family']:<9} {r['label']}  [{r['source']}{policy}]")
    print(f"\nmethods from outside the package: interface version {INTERFACE_VERSION}")
    print(f"  a class as package.module:Name, or installed in the group {ENTRY_POINT_GROUP}")
    print(
        "  an ONNX file written by `d3dwa export` (docs/design/external-methods.md#external-methods)"
    )
    return 0
