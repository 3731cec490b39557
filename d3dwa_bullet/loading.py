"""The one place YAML, JSON and XML are parsed: bounded in size, depth and expansion.

Every YAML or JSON file the project reads (worlds, generator styles, map_server YAML, noise
profiles, training configs, checkpoint ``meta.json`` / ``config.json`` /
``training_state.json``, run summaries, results ``meta.json``, ``metrics.jsonl``) goes
through :func:`load_yaml`, :func:`load_json` or :func:`load_json_lines`; text the program
holds already goes through :func:`parse_yaml` / :func:`parse_json`. XML (Gazebo SDF worlds)
goes through :func:`load_xml`. The caller's schema checks come after. What is refused, each
with the caller's error class and one line (a parser's message too) that names the file:

- a file that is not a regular file (``/dev/zero``, a FIFO) or is over its size limit
  (:data:`~d3dwa_bullet.limits.MAX_DOCUMENT_BYTES`), before it is read
  (:func:`d3dwa_bullet.io.read_text`);
- mappings and lists nested deeper than :data:`~d3dwa_bullet.limits.MAX_NESTING_DEPTH`,
  XML elements deeper than :data:`~d3dwa_bullet.limits.MAX_XML_DEPTH` (counted as the parser
  meets them, before a tree is built that a reader would recurse through);
- YAML aliases (``*name``) that add more than
  :data:`~d3dwa_bullet.limits.MAX_ALIAS_NODES` nodes: an alias repeats its anchor's node,
  so nine lines of aliases make a billion items (the "billion laughs"). The few aliases
  ``yaml.safe_dump`` writes for a list used twice load as before;
- a mapping that gives one key twice (YAML keeps the last silently; a JSON object likewise),
  keys compared by value within the mapping whatever the layout (block, or flow style on one
  line or several), named with its line and column; ``<<: *base`` may repeat a base's keys;
- YAML tags beyond the safe ones (``!!python/object`` ...), as ``yaml.safe_load`` does.

``tests/test_loading.py`` fails if any other module calls ``yaml.safe_load``,
``yaml.load``, ``json.loads`` or ``json.load``.
"""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from typing import Any

import yaml

from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.io import read_text
from d3dwa_bullet.limits import (
    MAX_ALIAS_NODES,
    MAX_DOCUMENT_BYTES,
    MAX_NESTING_DEPTH,
    MAX_TEXT_BYTES,
    MAX_XML_DEPTH,
    Limit,
)


class _Refused(yaml.YAMLError):
    """A YAML document this project does not accept (an alias, too deep)."""


class _BoundedLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses aliases adding too many nodes and nesting deeper
    than the limit while it composes the document, before anything is built."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0
        self._alias_nodes = 0
        self._sizes: dict[int, int] = {}  # id(node) -> nodes in it, aliases expanded
        self._checked: set[int] = set()  # id(node) of the mappings checked for repeated keys

    def _size(self, node: yaml.Node) -> int:
        key = id(node)
        if key not in self._sizes:  # memoised: a shared node is measured once
            if isinstance(node, yaml.MappingNode):
                children = [n for pair in node.value for n in pair]
            else:
                children = node.value if isinstance(node, yaml.SequenceNode) else []
            self._sizes[key] = 1 + sum(self._size(child) for child in children)
        return self._sizes[key]

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            node = super().compose_node(parent, index)
            self._alias_nodes += self._size(node)
            if self._alias_nodes > MAX_ALIAS_NODES.value:
                raise _Refused(
                    f"line {event.start_mark.line + 1}: alias *{event.anchor} brings the nodes "
                    f"that aliases repeat past {MAX_ALIAS_NODES.value} ({MAX_ALIAS_NODES.why}; "
                    "a few lines of aliases can expand to billions of items)"
                )
            return node
        nested = self.check_event(yaml.SequenceStartEvent, yaml.MappingStartEvent)
        self._depth += nested
        try:
            if self._depth > MAX_NESTING_DEPTH.value:
                raise _Refused(
                    f"line {self.peek_event().start_mark.line + 1}: nested more than "
                    f"{MAX_NESTING_DEPTH.value} levels deep ({MAX_NESTING_DEPTH.why})"
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= nested

    def flatten_mapping(self, node: yaml.MappingNode) -> None:
        """Refuse a key the mapping gives twice, then let ``<<: *base`` pull the base's keys in.

        Keys are compared by value within the mapping, whatever the layout: block style, a
        flow mapping on one line (``{a: 1, a: 2}``, JSON) or over several. Checked once per
        node, before merging mutates it: ``<<`` may repeat a base's keys (the explicit key
        overrides), and a base merged elsewhere already holds its own base's keys."""
        if id(node) not in self._checked:
            self._checked.add(id(node))
            self._refuse_repeats(node)
        super().flatten_mapping(node)

    def _refuse_repeats(self, node: yaml.MappingNode) -> None:
        """YAML would keep the last of two equal keys silently, so a field repeated in a
        config would change the run without a word."""
        seen: dict[Any, str] = {}  # key -> where it was first given
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            mark = key_node.start_mark
            where = f"line {mark.line + 1}, column {mark.column + 1}"
            try:
                first = seen.get(key)
            except TypeError:  # an unhashable key: the constructor refuses it after
                continue
            if first is None:
                seen[key] = where
            else:
                raise _Refused(
                    f"{where}: key {_shown_key(key)} is given twice in one mapping "
                    f"(first on {first}); YAML would keep the last one silently"
                )


def _shown_key(key: Any) -> str:
    text = repr(key)
    return text if len(text) <= 60 else f"{text[:57]}..."


def yaml_problem(err: yaml.YAMLError) -> str:
    """A parser's message on one line: where, what, and what it was inside. PyYAML's own
    ``str`` spans several lines, with the source line and a caret under the column."""
    if not isinstance(err, yaml.MarkedYAMLError):
        return " ".join(str(err).split())
    parts = []
    if err.problem_mark is not None:
        parts.append(f"line {err.problem_mark.line + 1}, column {err.problem_mark.column + 1}:")
    parts.append(err.problem or "not YAML")
    if err.context:
        inside = f"({err.context}"
        if err.context_mark is not None:
            mark = err.context_mark
            inside += f" at line {mark.line + 1}, column {mark.column + 1}"
        parts.append(inside + ")")
    return " ".join(" ".join(parts).split())


def parse_yaml(text: str, error: type[D3DWAError], source: str) -> Any:
    """The content of one YAML document (None when empty); ``error`` naming ``source``."""
    loader = _BoundedLoader(text)
    try:
        return loader.get_single_data()
    except yaml.YAMLError as err:
        raise error(f"{source}: not valid YAML: {yaml_problem(err)}") from err
    except RecursionError as err:  # a deep nest the depth check did not reach (a scalar)
        raise error(f"{source}: not valid YAML: nested too deeply") from err
    finally:
        loader.dispose()


def load_yaml(
    path: str | os.PathLike[str], error: type[D3DWAError], what: str = "YAML file"
) -> Any:
    """The content of a YAML file (None when empty); ``error`` naming the file for a file
    that cannot be read, is too large, is not YAML, or nests or aliases beyond the limits."""
    return parse_yaml(read_text(path, error, what, MAX_DOCUMENT_BYTES), error, str(path))


def _check_depth(value: Any, error: type[D3DWAError], source: str) -> Any:
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict | list):
            if depth > MAX_NESTING_DEPTH.value:
                raise error(
                    f"{source}: nested more than {MAX_NESTING_DEPTH.value} levels deep "
                    f"({MAX_NESTING_DEPTH.why})"
                )
            children = item.values() if isinstance(item, dict) else item
            stack.extend((child, depth + 1) for child in children)
    return value


class _DuplicateKey(ValueError):
    """A JSON object naming one key twice."""


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(
                f"key {_shown_key(key)} is given twice in one object; JSON readers would keep "
                "the last one silently"
            )
        out[key] = value
    return out


def _repeat_where(text: str | bytes) -> str:
    """'line L, column C: ' of the key a JSON document repeats, or '' where it cannot be told.
    ``json`` gives the object's pairs without their place; JSON is flow-style YAML, so the
    YAML loader (which compares keys the same way) finds it, on this error path only."""
    try:
        parse_yaml(text.decode() if isinstance(text, bytes) else text, D3DWAError, "")
    except D3DWAError as err:
        found = str(err).partition("not valid YAML: ")[2]
        return found.partition(": key ")[0] + ": " if ": key " in found else ""
    except UnicodeDecodeError:
        return ""
    return ""


def parse_json(text: str | bytes, error: type[D3DWAError], source: str) -> Any:
    """The content of one JSON document; ``error`` naming ``source`` when it is not JSON
    or nests deeper than the limit."""
    try:
        value = json.loads(text, object_pairs_hook=_unique_keys)
    except _DuplicateKey as err:
        raise error(f"{source}: not valid JSON ({_repeat_where(text)}{err})") from err
    except RecursionError as err:
        raise error(
            f"{source}: nested more than {MAX_NESTING_DEPTH.value} levels deep "
            f"({MAX_NESTING_DEPTH.why})"
        ) from err
    except ValueError as err:  # JSONDecodeError, an integer of too many digits
        raise error(f"{source}: not valid JSON ({err})") from err
    return _check_depth(value, error, source)


def load_json(
    path: str | os.PathLike[str],
    error: type[D3DWAError],
    what: str = "JSON file",
    limit: Limit = MAX_DOCUMENT_BYTES,
) -> Any:
    """The content of a JSON file; ``error`` naming the file for a file that cannot be
    read, is larger than ``limit`` bytes, is not JSON or nests beyond the limit."""
    return parse_json(read_text(path, error, what, limit), error, str(path))


def load_json_lines(
    path: str | os.PathLike[str], error: type[D3DWAError], what: str = "JSON-lines file"
) -> list[Any]:
    """One value per non-blank line of a JSON-lines log (``metrics.jsonl``); a log may be
    larger than a document (:data:`~d3dwa_bullet.limits.MAX_TEXT_BYTES`)."""
    text = read_text(path, error, what, MAX_TEXT_BYTES)
    return [
        parse_json(line, error, f"{path}, line {n}")
        for n, line in enumerate(text.splitlines(), 1)
        if line.strip()
    ]


def parse_xml(text: str, error: type[D3DWAError], source: str) -> ET.Element:
    """The root element of an XML document; ``error`` naming ``source`` when it is not
    well-formed or nests elements deeper than the limit."""
    parser = ET.XMLPullParser(events=("start", "end"))
    depth = 0
    root: ET.Element | None = None
    step = 1 << 16  # fed in pieces: the depth is checked as the tree grows, not after

    def check_events() -> None:
        nonlocal depth, root
        for event, elem in parser.read_events():
            depth += 1 if event == "start" else -1
            root = elem if root is None else root
            if depth > MAX_XML_DEPTH.value:
                raise error(
                    f"{source}: <{elem.tag}> is nested more than {MAX_XML_DEPTH.value} "
                    f"elements deep ({MAX_XML_DEPTH.why})"
                )

    try:
        for start in range(0, len(text), step):
            parser.feed(text[start : start + step])
            check_events()
        parser.close()  # ParseError for a document cut short or without an element
        check_events()
    except ET.ParseError as err:
        raise error(f"{source}: not well-formed XML: {err}") from err
    assert root is not None
    return root


def load_xml(
    path: str | os.PathLike[str], error: type[D3DWAError], what: str = "XML file"
) -> ET.Element:
    """The root element of an XML file; ``error`` naming the file for a file that cannot be
    read, is not a regular file, is too large, is not XML or nests beyond the limit."""
    return parse_xml(read_text(path, error, what, MAX_DOCUMENT_BYTES), error, str(path))
