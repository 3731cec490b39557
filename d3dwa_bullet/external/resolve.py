"""A method's name -> the class from outside the package that implements it, checked against
the interface it declares (docs/design/external-methods.md#external-methods).

``package.module:Name`` imports the module and takes the class; any other name that is not
built in is looked up among the installed entry points of ``d3dwa_bullet.methods``. Where it
came from is kept: the module and its distribution's version, or, for a module no installed
distribution owns, its file and the file's SHA-256. Everything that can go wrong (no such
module, class or entry point; a module that raises on import; another interface version; a
class with neither call or both; a declaration out of range) is refused in one line naming
the method: :class:`~d3dwa_bullet.errors.ExternalMethodError`.
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import math
import numbers
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import D3DWAError, ExternalMethodError
from d3dwa_bullet.external.protocol import INTERFACE_VERSION
from d3dwa_bullet.limits import MAX_DECISION_STEPS, is_decision_period
from d3dwa_bullet.method_names import (
    ENTRY_POINT_GROUP,
    entry_point_clashes,
    entry_points_named,
    is_import_path,
    is_model_file,
)
from d3dwa_bullet.method_specs import HOLD_MARK, REFERENCE, is_builtin, method_family
from d3dwa_bullet.params import OBSERVATION_KINDS
from d3dwa_bullet.planning.actions import ActionSet

#: The two kinds, by the call each implements.
KINDS = {"choose": "chooser", "command": "velocity planner"}
#: What a method's own code may end in and be refused for: any exception, and ``sys.exit``
#: (SystemExit), which would otherwise end the command with the method's status and no line (a
#: broken method read as a run that succeeded). Ctrl-C (KeyboardInterrupt) stays the user's
#: (docs/design/cli-output.md#methods-from-outside-the-package).
METHOD_FAULTS: tuple[type[BaseException], ...] = (Exception, SystemExit)


@dataclass(frozen=True)
class ExternalMethod:
    """A resolved method from outside the package: its class and what it declared."""

    name: str
    kind: str
    """``chooser`` or ``velocity planner``."""
    cls: type
    module: str
    origin: str
    """Where it came from, for results: ``module:Name (distribution version)``, or ``module:Name
    in FILE (sha256 HEX)`` for a module no installed distribution owns."""
    actions: ActionSet | None = None
    """A chooser's action set (None for a velocity planner: it has none)."""
    hold: int = 1
    """A chooser's decision period, control steps."""
    observation: str = "paper"
    budget_s: float | None = None
    """The time one call may take in ``drive``, s (its class's ``budget_s``; None: the
    control period); a call over it stops the robot."""

    def build(self) -> Any:
        """A new instance; ExternalMethodError if the constructor raises."""
        try:
            return self.cls()
        except METHOD_FAULTS as err:  # the method's own code: whatever it raises is refused
            raise ExternalMethodError(
                f"method {self.name!r}: raised at construction: {_said(err)}"
            ) from err


def _said(err: BaseException) -> str:
    if isinstance(err, SystemExit):
        return f"called sys.exit({err.code!r})"
    text = " ".join(str(err).split())
    return f"{type(err).__name__}: {text[:200]}" if text else type(err).__name__


def resolve(name: str) -> ExternalMethod:
    """The checked class of an external method's name (module docstring)."""
    if is_builtin(name):
        raise ExternalMethodError(
            f"method {name!r} is a built-in method's name: built-ins are never shadowed"
        )
    if is_model_file(name):
        return _model_file(name)
    if is_import_path(name):
        cls, module = _import_class(name), name.partition(":")[0]
        origin = _origin(name, None)
    else:
        points = entry_points_named()
        if name not in points:
            raise ExternalMethodError(
                f"method {name!r}: no such entry point in {ENTRY_POINT_GROUP} (and not "
                "package.module:Name); see `d3dwa methods`"
            )
        clash = entry_point_clashes().get(name)
        if clash:
            raise ExternalMethodError(
                f"method {name!r}: {len(clash)} installed packages register this name in "
                f"{ENTRY_POINT_GROUP} ({'; '.join(clash)}): uninstall all but one, or name the "
                "class as package.module:Name"
            )
        ep = points[name]
        try:
            cls = ep.load()
        except METHOD_FAULTS as err:  # the method's own module: whatever it raises is refused
            raise ExternalMethodError(
                f"method {name!r}: entry point {ep.value!r} cannot be loaded: {_said(err)}"
            ) from err
        module = ep.value.partition(":")[0]
        origin = _origin(ep.value, getattr(ep, "dist", None))
    return _declared(name, cls, module, origin)


def _model_file(name: str) -> ExternalMethod:
    """An ONNX file exported by ``d3dwa export``: its action set, decision period and
    observation from its own metadata (checked by the shipped loader's bounds), never
    guessed; ExternalMethodError if it is missing or does not load."""
    # the optional robot extra (onnxruntime), needed only when a file names the method
    from d3dwa_bullet.learning.agents.onnx_policy import onnx_metadata

    path = Path(name)
    if not path.is_file():
        raise ExternalMethodError(f"method {name!r}: no such file")
    try:
        meta = onnx_metadata(path)
    except D3DWAError as err:
        raise ExternalMethodError(f"method {name!r}: {err}") from err
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    return ExternalMethod(
        name, "chooser", type(None), "", f"{path.resolve()} (sha256 {digest})",
        meta["actions"], meta["decision_steps"], meta["observation"]["kind"],
    )  # fmt: skip


def _import_class(name: str) -> type:
    module_name, _, attr = name.partition(":")
    try:
        module = importlib.import_module(module_name)
    except METHOD_FAULTS as err:  # a missing module, or one whose import raises or exits
        raise ExternalMethodError(
            f"method {name!r}: module {module_name!r} cannot be imported: {_said(err)}"
            f"{_path_hint(module_name, err)}"
        ) from err
    obj: Any = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ExternalMethodError(f"method {name!r}: module {module_name!r} has no {attr!r}")
        obj = getattr(obj, part)
    return obj


def _path_hint(module_name: str, err: BaseException) -> str:
    """Where Python looked, when the method's own module (or its package) is not found: the
    usual cause is running from another folder than the one holding it."""
    missing = getattr(err, "name", None) if isinstance(err, ModuleNotFoundError) else None
    if not missing or not (module_name == missing or module_name.startswith(missing + ".")):
        return ""  # found, but it raised, or a module it imports is missing: said as is
    top = module_name.partition(".")[0]
    return (
        f" (Python looks for {top!r} on its import path: run from the folder that holds it, "
        "add that folder to PYTHONPATH, or pip install its package)"
    )


def _origin(spec: str, dist: Any) -> str:
    """``module:Name (distribution version)``, else ``module:Name in file (sha256 HEX)``."""
    module = spec.partition(":")[0]
    if dist is None:
        top = module.partition(".")[0]
        names = metadata.packages_distributions().get(top, [])
        dist_name = names[0] if names else None
    else:
        dist_name = dist.metadata["Name"]
    if dist_name is not None:
        try:
            return f"{spec} ({dist_name} {metadata.version(dist_name)})"
        except metadata.PackageNotFoundError:
            pass
    file = getattr(importlib.import_module(module), "__file__", None)
    if file is None:
        return spec
    digest = hashlib.sha256(Path(file).read_bytes()).hexdigest()
    return f"{spec} in {Path(file).resolve()} (sha256 {digest})"


def _declared(name: str, cls: Any, module: str, origin: str) -> ExternalMethod:
    """The method's declaration, checked: a class of this interface version with one call."""
    if not inspect.isclass(cls):
        raise ExternalMethodError(
            f"method {name!r}: {type(cls).__name__} {cls!r:.60} is not a class"
        )
    version = getattr(cls, "interface_version", None)
    if version != INTERFACE_VERSION:
        raise ExternalMethodError(
            f"method {name!r}: class {cls.__name__} declares interface_version {version!r}; "
            f"this testbed implements {INTERFACE_VERSION}"
        )
    calls = [c for c in KINDS if callable(getattr(cls, c, None))]
    if len(calls) != 1 or not callable(getattr(cls, "reset", None)):
        raise ExternalMethodError(
            f"method {name!r}: class {cls.__name__} must have reset() and exactly one of "
            f"choose() (a parameter chooser) or command() (a velocity planner); it has "
            f"{', '.join(c for c in ('reset', *KINDS) if callable(getattr(cls, c, None))) or 'none'}"
        )
    kind = KINDS[calls[0]]
    budget = _budget(name, cls)
    if kind == "velocity planner":
        return ExternalMethod(name, kind, cls, module, origin, budget_s=budget)
    actions = getattr(cls, "actions", None)
    if not any(actions == a for a in REFERENCE.values()):
        sizes = " or ".join(str(a.size) for a in REFERENCE.values())
        raise ExternalMethodError(
            f"method {name!r}: a chooser's actions must be one of the shipped action sets "
            f"({sizes} actions, d3dwa_bullet.planning.actions), so its floors exist; got "
            f"{type(actions).__name__}"
        )
    hold = getattr(cls, "hold", 1)
    if not is_decision_period(hold):
        raise ExternalMethodError(
            f"method {name!r}: hold {hold!r:.40} is not a decision period (a whole number "
            f"of control steps in [1, {MAX_DECISION_STEPS.value}])"
        )
    observation = getattr(cls, "observation", "paper")
    if observation not in OBSERVATION_KINDS:
        raise ExternalMethodError(
            f"method {name!r}: observation {observation!r:.40} is not one of "
            f"{', '.join(OBSERVATION_KINDS)}"
        )
    return ExternalMethod(name, kind, cls, module, origin, actions, hold, observation, budget)


def _budget(name: str, cls: Any) -> float | None:
    """The class's ``budget_s`` (None when it declares none), a number of seconds > 0."""
    budget = getattr(cls, "budget_s", None)
    if budget is None:
        return None
    real = isinstance(budget, numbers.Real) and not isinstance(budget, bool)
    if not real or not 0 < float(budget) < math.inf:
        raise ExternalMethodError(
            f"method {name!r}: budget_s {budget!r:.40} is not a number of seconds > 0"
        )
    return float(budget)


def external_floors(method: ExternalMethod) -> tuple[str, ...]:
    """A chooser's floors: the uniform chooser over its action set, every control step and
    held for its decision period (one name when that period is 1); none for a velocity
    planner (it has no action set: DWA III is its reference)."""
    if method.actions is None:
        return ()
    base = next(r for r, a in REFERENCE.items() if a == method.actions)
    return (base,) if method.hold == 1 else (base, f"{base}{HOLD_MARK}{method.hold}")


def installed_methods() -> list[dict[str, str]]:
    """Every entry point of the group: name, kind and origin, or ``refused`` with the reason
    (a built-in's name, a module that cannot be loaded, a wrong declaration)."""
    out = []
    for name, ep in sorted(entry_points_named().items()):
        row = {"name": name, "entry_point": ep.value}
        try:
            method = resolve(name)
        except ExternalMethodError as err:
            row |= {"kind": "refused", "origin": str(err)}
        else:
            row |= {"kind": method.kind, "origin": method.origin}
        out.append(row)
    return out


def method_origins(methods: list[str] | tuple[str, ...]) -> dict[str, str]:
    """{method: origin} of the external methods among methods (resolved: refused if one
    cannot be), for a results directory's meta.json."""
    return {m: resolve(m).origin for m in methods if method_family(m) == "external"}


def with_floors(methods: list[str]) -> list[str]:
    """methods, followed by the floors of each external chooser among them that are not
    listed yet (:func:`external_floors`): a chooser's table always shows its floors."""
    out = list(methods)
    for m in methods:
        if method_family(m) == "external":
            out += [f for f in external_floors(resolve(m)) if f not in out]
    return out
