"""The facts about the methods every command and table knows, by their stable names
(docs/design/methods.md#methods): names, labels, families, action sets, observation kinds, fixed tuples,
and the reference methods with their decision periods.

Pure facts: no simulator, no torch, no policy file is read here, so every layer (the learning
layer included) may import it. Building a controller from a method, a policy, a checkpoint or
an ONNX file lives above the learning layer, in :mod:`d3dwa_bullet.controllers`.

Three families: ``fixed`` and ``reference`` methods need no policy (one run each, no training
seeds); ``learned`` ones load one per training seed.

A reference method is the uniform chooser over an action set (SPEC 6), drawing a new action
every control step (``random``, ``random-weights``) or keeping each draw for a decision period
of k control steps (``random@k``, ``random-weights@k``; ``random@1`` is ``random``). The
default tables show both floors: every step, and held for the shipped policies' period
(``random@10``: 1 s at 10 Hz, the shipped configs' ``decision_steps: 10``).

A fourth family, ``external``: a name that is not built in but names a method from outside
the package, ``package.module:Name``, an entry point of ``d3dwa_bullet.methods`` or an ONNX
file exported by ``d3dwa export``
(docs/design/external-methods.md#external-methods). Only its name is judged here; loading it is
:mod:`d3dwa_bullet.external.resolve`'s job. Built-in names are looked up first, so they are
never shadowed, and installed entry points are read only for a name that is not built in.
"""

from __future__ import annotations

from d3dwa_bullet.errors import ConfigError, UnknownNameError, did_you_mean
from d3dwa_bullet.limits import MAX_DECISION_STEPS
from d3dwa_bullet.method_names import (
    ENTRY_POINT_GROUP,
    entry_points_named,
    is_import_path,
    is_model_file,
)
from d3dwa_bullet.planning.actions import (
    ACTIONS_FULL,
    ACTIONS_WEIGHTS_ONLY,
    ActionSet,
    PlannerAction,
)

FIXED: dict[str, PlannerAction] = {
    "dwa1": PlannerAction(1.0, 1.0, 2.0, 4.0),
    "dwa2": PlannerAction(1.0, 2.0, 1.0, 4.0),
    "dwa3": PlannerAction(2.0, 1.0, 1.0, 4.0),
}
#: Reference methods and the action set each draws from uniformly: a floor a learned method
#: must clear (docs/design/methods.md#methods). They need no policy. ``random`` is the floor of the
#: 100-action methods, ``random-weights`` of the 25-action ones (SPEC 6: uniform over the
#: method's action set).
REFERENCE: dict[str, ActionSet] = {"random": ACTIONS_FULL, "random-weights": ACTIONS_WEIGHTS_ONLY}
#: Between a reference method's name and its decision period in control steps: ``random@10``.
HOLD_MARK = "@"
#: The decision period of the shipped policies, control steps (their configs' ``decision_steps``;
#: tests/test_method_specs.py checks it against configs/): the held floor of the default tables.
SHIPPED_DECISION_STEPS = 10
#: The reference methods held for the shipped policies' decision period.
HELD_REFERENCE = tuple(f"{r}{HOLD_MARK}{SHIPPED_DECISION_STEPS}" for r in REFERENCE)
#: The suffix of a learned method trained on BARN's ``train`` split (issue 56): ``d3dwa-barn`` is
#: ``d3dwa``'s learner and action set, trained on BARN worlds instead of TS1-TS4 and R-style
#: layouts (configs/d3dwa-barn.yaml; docs/design/training.md#barn-training). Beside the shipped methods,
#: never instead of them; its policies ship under policies/<name>/.
BARN_MARK = "-barn"
#: Learned methods and the action set their policy must have.
LEARNED: dict[str, ActionSet] = {
    "dqdwa": ACTIONS_WEIGHTS_ONLY,
    "d3dwa-weights": ACTIONS_WEIGHTS_ONLY,
    "d3dwa": ACTIONS_FULL,
    "d3dwa-dr": ACTIONS_FULL,
    "d3dwa-history-dr": ACTIONS_FULL,
    f"d3dwa-weights{BARN_MARK}": ACTIONS_WEIGHTS_ONLY,
    f"d3dwa{BARN_MARK}": ACTIONS_FULL,
    f"d3dwa-dr{BARN_MARK}": ACTIONS_FULL,
}
#: The observation kind a learned method's policy reads when it is not the paper's 12-d state
#: (``planning.observation_kinds``). ``d3dwa-history-dr``, beyond the paper and beside
#: ``d3dwa-dr`` (never instead of it), reads the last 1 s of states and its previous action
#: (docs/design/observation.md#history-observation). The progress-aware methods, which shipped nothing,
#: left the registry (issue 41); their kind stays for the env.
OBSERVATIONS: dict[str, str] = {"d3dwa-history-dr": "history"}
#: Learned methods whose policy is a network, so exports to ONNX (dqdwa's is a Q-table).
ONNX_METHODS = tuple(m for m in LEARNED if m != "dqdwa")
#: The methods by name, in table order; a reference method also takes any other decision
#: period (``random@5``), which :func:`check_method` accepts.
METHODS = tuple(FIXED) + tuple(REFERENCE) + HELD_REFERENCE + tuple(LEARNED)


def reference_label(base: str, hold: int) -> str:
    """``Random (uniform over 100 actions)``, with ``, held 10 steps`` for a decision period."""
    held = "" if hold == 1 else f", held {hold} steps"
    return f"Random (uniform over {REFERENCE[base].size} actions{held})"


LABELS = {
    "dwa1": "DWA I (1,1,2)",
    "dwa2": "DWA II (1,2,1)",
    "dwa3": "DWA III (2,1,1)",
    **{r: reference_label(r, 1) for r in REFERENCE},
    **{
        h: reference_label(r, SHIPPED_DECISION_STEPS)
        for r, h in zip(REFERENCE, HELD_REFERENCE, strict=True)
    },
    "dqdwa": "DQDWA",
    "d3dwa-weights": "D3DWA (w/o horizon)",
    "d3dwa": "D3DWA",
    "d3dwa-dr": "D3DWA (randomised)",
    "d3dwa-history-dr": "D3DWA (randomised, 1 s history)",
    "d3dwa-barn": "D3DWA (BARN-trained)",
    "d3dwa-weights-barn": "D3DWA (w/o horizon, BARN-trained)",
    "d3dwa-dr-barn": "D3DWA (randomised, BARN-trained)",
}


def reference_of(name: str) -> tuple[str, int] | None:
    """(reference method, decision period in control steps) of a reference method's name:
    ``random`` -> (``random``, 1), ``random@10`` -> (``random``, 10); None for any other
    method. ConfigError naming the value for a period that is not a whole number in
    [1, MAX_DECISION_STEPS]."""
    base, mark, period = name.partition(HOLD_MARK)
    if base not in REFERENCE:
        return None
    if not mark:
        return base, 1
    digits = period.lstrip("0")
    if not (period.isascii() and period.isdigit()) or not digits or digits != period:
        raise ConfigError(
            f"method {name[:40]!r}: decision period {period[:20]!r} is not a whole number of "
            f"control steps >= 1 (e.g. {base}{HOLD_MARK}{SHIPPED_DECISION_STEPS})"
        )
    if len(digits) > 20:  # over any bound; int() of thousands of digits would raise
        raise ConfigError(
            f"method {name[:40]!r}...: decision period of {len(digits)} digits is over the "
            f"limit of {MAX_DECISION_STEPS.value} control steps"
        )
    MAX_DECISION_STEPS.check(f"method {name!r}: decision period", int(digits), "control steps")
    return base, int(period)


#: External method names already judged in this process (entry points are read once).
_EXTERNAL_SEEN: set[str] = set()


def is_builtin(name: str) -> bool:
    """Whether name is a built-in method (a reference method with any valid period included)."""
    return name in METHODS or reference_of(name) is not None


def check_method(name: str) -> str:
    """name, if it names a method: a built-in one (a reference method with any valid decision
    period included), else ``package.module:Name``, an ONNX file (``*.onnx``) or an installed
    entry point of ``d3dwa_bullet.methods``; UnknownNameError, or ConfigError for a bad decision period,
    otherwise."""
    if name in _EXTERNAL_SEEN or is_builtin(name):
        return name
    if is_import_path(name) or is_model_file(name) or name in entry_points_named():
        _EXTERNAL_SEEN.add(name)
        return name
    raise UnknownNameError(
        f"unknown method {name!r}: {did_you_mean(name, METHODS)}`d3dwa methods` lists them (a class from outside: "
        f"package.module:Name, or an entry point of {ENTRY_POINT_GROUP})"
    )


def method_family(name: str) -> str:
    """``fixed``, ``reference``, ``learned`` or ``external`` (UnknownNameError for an unknown
    method)."""
    check_method(name)
    if name in FIXED:
        return "fixed"
    if name in LEARNED:
        return "learned"
    return "reference" if is_builtin(name) else "external"


def needs_policy(name: str) -> bool:
    """True for a learned method; fixed and reference methods run without a policy."""
    return method_family(name) == "learned"


def method_label(name: str) -> str:
    """The label tables print for a method (its name for a method without one)."""
    if name in LABELS:
        return LABELS[name]
    ref = reference_of(name) if HOLD_MARK in name else None
    return reference_label(*ref) if ref is not None else name


def method_observation(name: str) -> str:
    """The observation kind a method's controller reads (the paper's 12-d state: "paper")."""
    return OBSERVATIONS.get(check_method(name), "paper")


def method_hold(name: str) -> int:
    """Control steps a method's controller keeps each choice: a reference method's decision
    period; 1 for the others (a learned policy's own period is recorded in its files)."""
    ref = reference_of(check_method(name))
    return 1 if ref is None else ref[1]


def barn_twin(name: str) -> str | None:
    """The shipped method a BARN-trained one shares its learner and action set with
    (``d3dwa-barn`` -> ``d3dwa``); None for any other method."""
    if name in LEARNED and name.endswith(BARN_MARK):
        return name.removesuffix(BARN_MARK)
    return None


def floors_of(name: str) -> tuple[str, str]:
    """(every-step floor, held floor) of a learned method: the reference method over its
    action set, drawn every control step and held for the shipped decision period."""
    base = "random" if LEARNED[name] == REFERENCE["random"] else "random-weights"
    return base, f"{base}{HOLD_MARK}{SHIPPED_DECISION_STEPS}"
