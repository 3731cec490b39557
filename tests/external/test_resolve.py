"""Resolving a method from outside the package: names, declarations and their refusals
(docs/design/external-methods.md#external-methods). No simulator runs here."""

from __future__ import annotations

import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

from d3dwa_bullet.errors import ExternalMethodError, UnknownNameError
from d3dwa_bullet.external import protocol
from d3dwa_bullet.external.resolve import (
    external_floors,
    installed_methods,
    resolve,
    with_floors,
)
from d3dwa_bullet.method_specs import check_method, method_family, needs_policy
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.planning.controller import Controller
from tests.support import external_methods

HERE = "tests.support.external_methods"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "follow_the_gap"


def test_a_class_path_is_an_external_method_and_names_stay_checked():
    assert check_method(f"{HERE}:Straight") == f"{HERE}:Straight"
    assert method_family(f"{HERE}:Straight") == "external"
    assert not needs_policy(f"{HERE}:Straight")
    assert method_family("dwa3") == "fixed" and method_family("random@7") == "reference"
    with pytest.raises(UnknownNameError, match="package.module:Name"):
        check_method("no-such-method")


def test_the_builtin_controller_has_the_chooser_surface():
    assert isinstance(
        Controller("x", actions=ACTIONS_FULL, uniform=True), protocol.ParameterChooser
    )
    assert isinstance(external_methods.Straight(), protocol.VelocityPlanner)


def test_resolve_reads_the_declaration_and_names_the_source():
    chooser = resolve(f"{HERE}:HeldRandom")
    assert (chooser.kind, chooser.actions, chooser.hold) == ("chooser", ACTIONS_FULL, 10)
    assert external_floors(chooser) == ("random", "random@10")
    planner = resolve(f"{HERE}:Straight")
    assert planner.kind == "velocity planner" and external_floors(planner) == ()
    # a module no installed distribution owns: its file and the file's SHA-256
    file = Path(external_methods.__file__).resolve()
    assert planner.origin.startswith(f"{HERE}:Straight in {file} (sha256 ")
    assert "(sha256 " in planner.origin and len(planner.origin.split()[-1]) == 65
    assert with_floors(["dwa3", f"{HERE}:HeldRandom", "random"]) == [
        "dwa3", f"{HERE}:HeldRandom", "random", "random@10",
    ]  # fmt: skip


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("no_such_module_xyz:Thing", "module 'no_such_module_xyz' cannot be imported"),
        (f"{HERE}:Missing", "has no 'Missing'"),
        (f"{HERE}:NOT_A_CLASS", "is not a class"),
        (f"{HERE}:Version2", "declares interface_version 2"),
        (f"{HERE}:Both", "exactly one of choose"),
        (f"{HERE}:OddActions", "one of the shipped action sets"),
    ],
)
def test_a_wrong_method_is_refused_in_one_line_naming_it(name, said):
    with pytest.raises(ExternalMethodError, match=said) as err:
        resolve(name)
    assert name in str(err.value) and "\n" not in str(err.value)


def test_raising_at_construction_is_refused():
    with pytest.raises(ExternalMethodError, match="raised at construction: RuntimeError: no lic"):
        resolve(f"{HERE}:RaisesAtConstruction").build()


def _entry_points(monkeypatch, **points: str) -> None:
    found = {n: EntryPoint(n, v, protocol.ENTRY_POINT_GROUP) for n, v in points.items()}
    monkeypatch.setattr("d3dwa_bullet.method_specs.entry_points_named", lambda: found)
    monkeypatch.setattr("d3dwa_bullet.external.resolve.entry_points_named", lambda: found)
    monkeypatch.setattr("d3dwa_bullet.method_specs._EXTERNAL_SEEN", set())


def test_an_entry_point_resolves_and_a_builtin_name_is_never_shadowed(monkeypatch):
    _entry_points(monkeypatch, straight=f"{HERE}:Straight", dwa3=f"{HERE}:Straight")
    assert check_method("straight") == "straight"
    assert resolve("straight").kind == "velocity planner"
    assert method_family("dwa3") == "fixed"  # the built-in, whatever is installed
    with pytest.raises(ExternalMethodError, match="built-in method's name"):
        resolve("dwa3")
    listed = {r["name"]: r for r in installed_methods()}
    assert listed["dwa3"]["kind"] == "refused" and listed["straight"]["kind"] == "velocity planner"


def test_a_missing_entry_point_module_is_refused(monkeypatch):
    _entry_points(monkeypatch, gone="not_installed_pkg.planner:Planner")
    with pytest.raises(ExternalMethodError, match="entry point 'not_installed_pkg.planner:Pl"):
        resolve("gone")


def test_the_example_resolves_from_its_folder(monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLES))
    method = resolve("follow_the_gap.planner:FollowTheGap")
    assert method.kind == "velocity planner"
    sys.modules.pop("follow_the_gap.planner", None)
    sys.modules.pop("follow_the_gap", None)


def test_two_packages_registering_one_name_are_refused_never_the_last_taken(monkeypatch):
    found = [
        EntryPoint("twice", f"{HERE}:Straight", protocol.ENTRY_POINT_GROUP),
        EntryPoint("twice", f"{HERE}:Zero", protocol.ENTRY_POINT_GROUP),
    ]
    monkeypatch.setattr("d3dwa_bullet.method_names.installed_entry_points", lambda: found)
    monkeypatch.setattr("d3dwa_bullet.method_specs._EXTERNAL_SEEN", set())
    assert check_method("twice") == "twice"  # a name, known: refused when it is loaded
    with pytest.raises(ExternalMethodError, match="2 installed packages register") as err:
        resolve("twice")
    said = str(err.value)
    assert f"{HERE}:Straight" in said and f"{HERE}:Zero" in said and "\n" not in said
    listed = [r for r in installed_methods() if r["name"] == "twice"]
    assert [r["kind"] for r in listed] == ["refused"]


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("tests.support.exits_on_import:Planner", r"cannot be imported: called sys.exit\(0\)"),
        (f"{HERE}:ExitsAtConstruction", r"raised at construction: called sys.exit\(0\)"),
        (f"{HERE}:ExitsSevenAtConstruction", r"raised at construction: called sys.exit\(7\)"),
    ],
)
def test_a_method_that_calls_sys_exit_is_refused_not_obeyed(name, said):
    with pytest.raises(ExternalMethodError, match=said) as err:
        resolve(name).build()
    assert name in str(err.value) and "\n" not in str(err.value)


def test_a_module_off_the_import_path_gets_the_hint_in_one_line():
    with pytest.raises(ExternalMethodError) as err:
        resolve("nowhere_pkg.mod:Thing")
    said = str(err.value)
    assert "ModuleNotFoundError" in said and "\n" not in said
    assert "'nowhere_pkg' on its import path" in said and "PYTHONPATH" in said
    assert "pip install" in said


def test_a_module_found_whose_own_import_fails_gets_no_path_hint():
    with pytest.raises(ExternalMethodError) as err:
        resolve("tests.support.exits_on_import:Planner")
    assert "PYTHONPATH" not in str(err.value)
