"""The bounded loader: huge, endless, deep and alias-bomb files end in one typed error, fast;
and no module parses YAML or JSON except through it (issue 24)."""

from __future__ import annotations

import ast
import os
import time
from pathlib import Path

import pytest
import yaml

from d3dwa_bullet.errors import ConfigError, ProfileError, WorldFormatError
from d3dwa_bullet.io import read_text
from d3dwa_bullet.limits import MAX_DOCUMENT_BYTES, MAX_NESTING_DEPTH, MAX_XML_DEPTH
from d3dwa_bullet.loading import (
    load_json,
    load_json_lines,
    load_xml,
    load_yaml,
    parse_json,
    parse_xml,
    parse_yaml,
)
from tests.support.hang_guard import within

ROOT = Path(__file__).resolve().parents[1]
SCANNED = ("d3dwa_bullet", "randomization", "transfer", "tools", "scripts")
PARSERS = {("yaml", "safe_load"), ("yaml", "load"), ("yaml", "full_load"),
           ("yaml", "unsafe_load"), ("yaml", "safe_load_all"), ("yaml", "load_all"),
           ("json", "loads"), ("json", "load"), ("ET", "parse"), ("ET", "fromstring"),
           ("ET", "iterparse"), ("ET", "XML"), ("ET", "XMLParser"),
           ("ET", "XMLPullParser")}  # fmt: skip
LOADER = "d3dwa_bullet/loading.py"


def alias_bomb(levels: int = 9) -> str:
    """The "billion laughs": each line lists the previous anchor nine times (9^9 items)."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]")
    return "\n".join(lines) + "\n"


def parser_calls(path: Path) -> list[str]:
    """'module.function' for every call of a YAML/JSON parser in a source file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            if (node.value.id, node.attr) in PARSERS:
                found.append(f"{node.value.id}.{node.attr} (line {node.lineno})")
        if isinstance(node, ast.ImportFrom) and node.module in ("yaml", "json"):
            for alias in node.names:
                if (node.module, alias.name) in PARSERS:
                    found.append(f"from {node.module} import {alias.name} (line {node.lineno})")
    return found


def test_only_the_loader_parses_yaml_or_json():
    offenders = {}
    for top in SCANNED:
        for path in sorted((ROOT / top).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel != LOADER and (calls := parser_calls(path)):
                offenders[rel] = calls
    assert offenders == {}, "parse YAML/JSON/XML with d3dwa_bullet.loading instead"
    assert parser_calls(ROOT / LOADER), "the scan must see the loader's own json.loads"


def test_the_scan_would_catch_a_stray_parser(tmp_path):
    stray = tmp_path / "stray.py"
    stray.write_text("import json\nimport yaml\nfrom json import loads\n"
                     "a = yaml.safe_load('x')\nb = json.loads('1')\n")  # fmt: skip
    assert len(parser_calls(stray)) == 3


def test_an_alias_bomb_is_refused_fast_naming_the_file(tmp_path):
    path = tmp_path / "bomb.yaml"
    path.write_text(alias_bomb())
    start = time.perf_counter()
    with pytest.raises(ProfileError, match=r"bomb\.yaml: .*alias \*a\d brings the nodes .* past"):
        load_yaml(path, ProfileError, "profile YAML")
    assert (
        time.perf_counter() - start < 10.0
    )  # a guard (unbounded: 27 s and MemoryError), not a speed figure


def test_the_aliases_yaml_safe_dump_writes_still_load():
    shared = [1.0, 2.0]
    text = yaml.safe_dump({"a": shared, "b": {"c": shared}})
    assert "*id001" in text  # safe_dump repeats a shared list as an alias
    assert parse_yaml(text, ConfigError, "s") == {"a": shared, "b": {"c": shared}}


def test_anchors_without_aliases_and_ordinary_files_load():
    assert parse_yaml("a: &x 1\nb: [1, {c: 2}]\n", ConfigError, "s") == {"a": 1, "b": [1, {"c": 2}]}
    assert parse_yaml("", ConfigError, "s") is None
    assert parse_json('{"a": [1, 2]}', ConfigError, "s") == {"a": [1, 2]}


@pytest.mark.parametrize("kind", ["yaml", "json"])
def test_nesting_past_the_limit_is_refused(kind):
    parse = parse_yaml if kind == "yaml" else parse_json
    depth = int(MAX_NESTING_DEPTH.value)
    assert parse("[" * depth + "]" * depth, ConfigError, "s") == _nested(depth)
    for too_deep in (depth + 1, 100_000):
        with pytest.raises(ConfigError, match=f"s: .*nested more than {depth} levels"):
            parse("[" * too_deep + "]" * too_deep, ConfigError, "s")


def _nested(depth: int) -> list:
    value: list = []
    for _ in range(depth - 1):
        value = [value]
    return value


def test_yaml_block_nesting_is_refused_too():
    text = "".join(" " * (2 * i) + f"k{i}:\n" for i in range(int(MAX_NESTING_DEPTH.value) + 2))
    with pytest.raises(WorldFormatError, match="nested more than"):
        parse_yaml(text + "  " * 40 + "v: 1\n", WorldFormatError, "w.yaml")


def test_unsafe_tags_and_broken_text_are_the_callers_error():
    with pytest.raises(ConfigError, match="s: not valid YAML"):
        parse_yaml("!!python/object/apply:os.system ['true']", ConfigError, "s")
    with pytest.raises(ConfigError, match="s: not valid JSON"):
        parse_json("{nope", ConfigError, "s")
    with pytest.raises(ConfigError, match="s: not valid JSON"):
        parse_json("1" * 5000, ConfigError, "s")  # int digits beyond Python's limit


def test_a_huge_file_is_refused_without_being_read(tmp_path):
    path = tmp_path / "big.json"
    with path.open("wb") as fh:  # sparse: 64 GiB of size, no disk; reading it would not end
        fh.truncate(2**36)
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=r"big\.json: 68719476736 bytes is over the limit of"):
        load_json(path, ConfigError)
    assert time.perf_counter() - start < 10.0  # a guard, not a speed figure
    path.write_text(" " * int(MAX_DOCUMENT_BYTES.value) + "1")  # one byte over
    with pytest.raises(ConfigError, match="over the limit"):
        load_json(path, ConfigError)


@pytest.mark.parametrize("special", ["/dev/zero", "fifo", "dir"])
def test_a_file_that_is_not_regular_is_refused(tmp_path, special):
    if special == "fifo":
        path = tmp_path / "pipe.yaml"
        os.mkfifo(path)  # opening it would block until a writer came
    elif special == "dir":
        path = tmp_path / "folder.yaml"
        path.mkdir()
    else:
        path = Path(special)
    with pytest.raises(WorldFormatError, match="not a regular file"):
        load_yaml(path, WorldFormatError, "world file")


def test_read_text_keeps_text_mode_newlines(tmp_path):
    path = tmp_path / "crlf.csv"
    path.write_bytes(b"a,b\r\n1,2\r3\n")
    assert read_text(path, ConfigError) == "a,b\n1,2\n3\n"


def test_json_lines_name_the_line(tmp_path):
    path = tmp_path / "metrics.jsonl"
    path.write_text('{"step": 1}\n\n{"step": 2}\n[[[\n')
    with pytest.raises(ConfigError, match=r"metrics\.jsonl, line 4: not valid JSON"):
        load_json_lines(path, ConfigError)
    path.write_text('{"step": 1}\n\n{"step": 2}\n')
    assert load_json_lines(path, ConfigError) == [{"step": 1}, {"step": 2}]


def nested_xml(depth: int, tag: str = "a") -> str:
    return f"<{tag}>" * depth + f"</{tag}>" * depth


def test_xml_nesting_up_to_the_limit_parses_and_past_it_is_refused():
    limit = int(MAX_XML_DEPTH.value)
    root = parse_xml(nested_xml(limit), WorldFormatError, "ok.world")
    assert root.tag == "a" and len(list(root.iter())) == limit
    with pytest.raises(WorldFormatError, match=rf"^deep.world: <a> is nested more than {limit} "):
        parse_xml(nested_xml(limit + 1), WorldFormatError, "deep.world")


def test_deep_xml_is_refused_before_the_whole_document_is_parsed():
    start = time.perf_counter()
    with pytest.raises(WorldFormatError, match="nested more than"):
        parse_xml(nested_xml(1_000_000), WorldFormatError, "huge.world")
    assert time.perf_counter() - start < 2.0  # a guard, not a speed figure


@pytest.mark.parametrize("text", ["", "<a><b></a>", "<a>", "not xml"])
def test_broken_xml_is_the_callers_error(text):
    with pytest.raises(WorldFormatError, match="^x.world: not well-formed XML: "):
        parse_xml(text, WorldFormatError, "x.world")


@pytest.mark.parametrize("special", ["/dev/zero", "fifo"])
def test_an_xml_file_that_is_not_regular_is_refused(tmp_path, special):
    path = Path(special)
    if special == "fifo":
        path = tmp_path / "pipe.world"
        os.mkfifo(path)
    with within(30), pytest.raises(WorldFormatError, match="not a regular file"):
        load_xml(path, WorldFormatError, "world file")
