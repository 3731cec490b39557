"""What an exported ONNX policy says about itself: its ``metadata_props`` (string keys
``d3dwa.*``, ``METADATA_KEYS``), written by the exporter (``metadata_props``) and read back
and checked by every runner (``read_metadata``): method, observation kind and layout, action
set, decision period, recovery layer and scan filter (``policy_terms``), source and format
version."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents.policy_terms import (
    DEFAULT_DECISION_STEPS,
    DEFAULT_RECOVERY,
    DEFAULT_SCAN_FILTER,
    decision_period,
    trained_recovery,
    trained_scan_filter,
)
from d3dwa_bullet.loading import parse_json
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import LAYOUTS, observation_layout

ONNX_FORMAT_VERSION = 2
"""Version of the metadata written here for a policy trained without a scan filter. Version 2
added the decision period and the recovery layer: a runner from before them reads only
version 1, so it refuses a new file in one line instead of driving a held policy every step."""
FILTERED_FORMAT_VERSION = 3
"""Version written for a policy trained behind a scan filter (version 3 added the filter): a
runner from before it refuses such a file in one line instead of driving it on raw scans,
while files without a filter stay readable by version-2 runners."""
READ_VERSIONS = (1, 2, 3)
"""Versions this runner reads; a file lacks the OPTIONAL_FIELDS its version predates."""
INPUT_NAME = "obs"
OUTPUT_NAME = "q"
METADATA_KEYS = {
    "format_version": "d3dwa.format_version",  # ONNX_FORMAT_VERSION, decimal
    "method": "d3dwa.method",  # the method it was exported for: d3dwa, d3dwa-dr, ...
    "observation_kind": "d3dwa.observation.kind",  # paper | progress | history
    "observation_layout": "d3dwa.observation.layout",  # JSON list of entry names
    "obs_dim": "d3dwa.observation.dim",  # decimal, == len(layout)
    "actions": "d3dwa.actions",  # JSON of ActionSet.to_dict()
    "source": "d3dwa.source",  # JSON: the checkpoint's digest, steps, config, run
    "decision_steps": "d3dwa.decision_steps",  # decimal: control steps each action is held
    "recovery": "d3dwa.recovery",  # the recovery layer it trained inside: none | nav2
    "scan_filter": "d3dwa.scan_filter",  # the scan filter it trained behind: none | median | ...
}
"""Field -> metadata_props key of an exported policy."""
OPTIONAL_FIELDS = {
    "decision_steps": str(DEFAULT_DECISION_STEPS),
    "recovery": DEFAULT_RECOVERY,
    "scan_filter": DEFAULT_SCAN_FILTER,
}
"""Fields older exports lack -> the value their absence means (the paper's agent)."""
ADDED_IN = {"decision_steps": 2, "recovery": 2, "scan_filter": 3}
"""The format version that added each optional field: a file of that version or later must
hold it."""


def metadata_props(
    method: str,
    kind: str,
    actions: ActionSet,
    source: Mapping[str, Any],
    decision_steps: int = DEFAULT_DECISION_STEPS,
    recovery: str = DEFAULT_RECOVERY,
    scan_filter: str = DEFAULT_SCAN_FILTER,
) -> dict[str, str]:
    """The metadata_props of a policy for ``method`` reading observation ``kind``, trained
    with ``decision_steps`` inside ``recovery`` behind ``scan_filter`` (the exporter's half of
    the description ``read_metadata`` checks)."""
    layout = observation_layout(kind)
    filtered = scan_filter != DEFAULT_SCAN_FILTER
    props = {
        METADATA_KEYS["format_version"]: str(
            FILTERED_FORMAT_VERSION if filtered else ONNX_FORMAT_VERSION
        ),
        METADATA_KEYS["method"]: method,
        METADATA_KEYS["observation_kind"]: kind,
        METADATA_KEYS["observation_layout"]: json.dumps(list(layout)),
        METADATA_KEYS["obs_dim"]: str(len(layout)),
        METADATA_KEYS["actions"]: json.dumps(actions.to_dict(), sort_keys=True),
        METADATA_KEYS["source"]: json.dumps(dict(source), sort_keys=True, allow_nan=False),
        METADATA_KEYS["decision_steps"]: str(decision_steps),
        METADATA_KEYS["recovery"]: recovery,
    }
    if filtered:
        props[METADATA_KEYS["scan_filter"]] = scan_filter
    return props


def read_metadata(props: Mapping[str, str], where: str) -> dict[str, Any]:
    """Parse and check metadata_props: {format_version, method, observation: {kind, layout,
    dim}, actions: ActionSet, source, decision_steps: int, recovery: str, scan_filter: str}
    (the last three OPTIONAL_FIELDS). CheckpointError naming ``where``, the key and a bad value."""
    version_key = METADATA_KEYS["format_version"]
    if version_key not in props:
        ours = sorted(k for k in props if k.startswith("d3dwa."))
        raise CheckpointError(
            f"{where}: not a d3dwa policy: its metadata has no {version_key!r}"
            + (f" (only {ours})" if ours else "")
            + "; export one with `d3dwa export --onnx DIR`"
        )
    versions = {str(v): v for v in READ_VERSIONS}
    if props[version_key] not in versions:
        raise CheckpointError(
            f"{where}: metadata {version_key} is {props[version_key]!r}, this code reads "
            f"versions {', '.join(versions)}"
        )
    version = versions[props[version_key]]
    optional = {k for k in OPTIONAL_FIELDS if ADDED_IN[k] > version}
    missing = [v for k, v in METADATA_KEYS.items() if k not in optional and v not in props]
    if missing:
        raise CheckpointError(f"{where}: metadata lacks {missing}")

    def parsed(field: str) -> Any:
        key = METADATA_KEYS[field]
        return parse_json(props[key], CheckpointError, f"{where}: metadata {key}")

    kind = props[METADATA_KEYS["observation_kind"]]
    if kind not in LAYOUTS:
        raise CheckpointError(
            f"{where}: metadata {METADATA_KEYS['observation_kind']} is {kind!r}, expected one "
            f"of {sorted(LAYOUTS)}"
        )
    layout = parsed("observation_layout")
    dim = props[METADATA_KEYS["obs_dim"]]
    if layout != list(LAYOUTS[kind]) or dim != str(len(LAYOUTS[kind])):
        raise CheckpointError(
            f"{where}: metadata says the {kind!r} observation but gives layout {layout} "
            f"(dim {dim}); that kind is {list(LAYOUTS[kind])} (dim {len(LAYOUTS[kind])})"
        )
    description = parsed("actions")
    try:
        if not isinstance(description, dict):
            raise ConfigError(f"expected a JSON object, got {description!r}")
        actions = ActionSet.from_dict(description)
    except ConfigError as err:
        raise CheckpointError(f"{where}: metadata {METADATA_KEYS['actions']}: {err}") from err
    source = parsed("source")
    steps_key, recovery_key = METADATA_KEYS["decision_steps"], METADATA_KEYS["recovery"]
    steps = props.get(steps_key, OPTIONAL_FIELDS["decision_steps"])
    recovery = props.get(recovery_key, OPTIONAL_FIELDS["recovery"])
    filter_key = METADATA_KEYS["scan_filter"]
    behind = props.get(filter_key, OPTIONAL_FIELDS["scan_filter"])
    return {
        "format_version": version,
        "method": props[METADATA_KEYS["method"]],
        "observation": {"kind": kind, "layout": layout, "dim": len(layout)},
        "actions": actions,
        "source": source if isinstance(source, dict) else {},
        "decision_steps": decision_period(steps, f"{where}: metadata {steps_key}"),
        "recovery": trained_recovery(recovery, f"{where}: metadata {recovery_key}"),
        "scan_filter": trained_scan_filter(behind, f"{where}: metadata {filter_key}"),
    }
