"""Move citations of the old single page of design notes (design.md, in docs/) to the page of
docs/design/ that now holds their anchor (docs/design/README.md#pages).

    python -m tools.design_citations            # list what would change, change nothing
    python -m tools.design_citations --write    # rewrite the files in place

Every anchor of the old page kept its name on its new page, so the page is found by looking
the anchor up among the ``<a id="...">`` of docs/design/*.md. Handled: the path from the
repository's root (docs/ then design.md#x, in code and pages) and the relative ones of pages
(design.md#x from docs/, ../design.md#x from docs/pilots/). A bare citation of the old page
becomes the index, docs/design/README.md. An anchor no page holds is reported and left as it
is (exit status 1), for a person to place. This file and its test are never rewritten.
"""

from __future__ import annotations

import re
import subprocess
from collections.abc import Sequence
from pathlib import Path

from tools.entry import ToolParser, tool_main

ROOT = Path(__file__).resolve().parents[1]
_ID = re.compile(r'<a\s+id="([^"]+)"')
_OLD = re.compile(r"(?<![\w/.-])((?:\.\./)*(?:docs/)?)design\.md(?:#([\w-]+))?")


def anchor_pages(folder: Path) -> dict[str, str]:
    """Anchor -> page name (``planner.md``) over the explicit ids of folder/*.md."""
    found: dict[str, str] = {}
    for page in sorted(folder.glob("*.md")):
        for anchor in _ID.findall(page.read_text(encoding="utf-8")):
            found.setdefault(anchor, page.name)
    return found


def rewrite(text: str, pages: dict[str, str]) -> tuple[str, list[str]]:
    """text with every old citation moved; and the anchors no page holds, in order."""
    unknown: list[str] = []

    def one(match: re.Match[str]) -> str:
        prefix, anchor = match.group(1), match.group(2)
        if anchor is None:
            return f"{prefix}design/README.md"
        if anchor not in pages:
            unknown.append(anchor)
            return match.group(0)
        return f"{prefix}design/{pages[anchor]}#{anchor}"

    return _OLD.sub(one, text), unknown


def tracked_files(root: Path) -> list[Path]:
    """The text files git tracks under root that mention design.md."""
    listed = subprocess.run(
        ["git", "grep", "-lI", "design\\.md"], cwd=root, capture_output=True, text=True
    ).stdout.split()
    own = {Path(__file__).resolve(), root / "tests" / "tools" / "test_design_citations.py"}
    return [root / name for name in listed if (root / name).resolve() not in own]


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="design_citations", description=__doc__.split("\n")[0])
    parser.add_argument("files", nargs="*", type=Path, help="files to fix (default: the tree)")
    parser.add_argument("--write", action="store_true", help="rewrite the files in place")
    args = parser.parse_args(argv)
    pages = anchor_pages(ROOT / "docs" / "design")
    status = 0
    for path in args.files or tracked_files(ROOT):
        text = path.read_text(encoding="utf-8")
        new, unknown = rewrite(text, pages)
        for anchor in unknown:
            print(f"{path}: #{anchor} is on no page of docs/design/: left as it is")
            status = 1
        if new != text:
            print(f"{path}: {'rewritten' if args.write else 'would change'}")
            if args.write:
                path.write_text(new, encoding="utf-8")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
