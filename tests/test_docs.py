"""The documents: every relative link in README.md and docs/**/*.md resolves, so does every
``docs/<page>.md#anchor`` the code and configs cite, the README stays a short front door and
docs/results.md a current page, not a history.

A link resolves when its target file or folder exists, relative to the document; a
``#anchor`` into a Markdown file must name an explicit ``<a id="...">`` in it or one of its
headings (GitHub's heading slugs). Links inside fenced code blocks and inline code are not
links. Run ``python tests/test_docs.py`` to print the broken links instead of asserting.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README_MAX_LINES = 160
RESULTS_MAX_LINES = 400  # the current page; superseded generations go to docs/history.md
DOCUMENTS = (
    ROOT / "README.md",
    *sorted((ROOT / "docs").rglob("*.md")),
    ROOT / "randomization" / "README.md",
)
# Where code, configs and scripts cite a document by its path from the repository root.
CITING = (
    "d3dwa_bullet",
    "randomization",
    "transfer",
    "tools",
    "scripts",
    "tests",
    "configs",
    "docs",
)
CITING_SUFFIXES = (".py", ".yaml", ".yml")
_CITATION = re.compile(r"\b((?:docs|randomization)/[\w./-]*\.md)#([\w-]+)")

_FENCE = re.compile(r"^\s*(```|~~~)")
_INLINE_CODE = re.compile(r"`[^`]*`")
_LINK = re.compile(r"\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_ANCHOR_ID = re.compile(r"<a\s+(?:id|name)=\"([^\"]+)\"")
_HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")
_EXTERNAL = ("http://", "https://", "mailto:")


def prose_lines(text: str, inline_code: bool = False) -> list[str]:
    """The lines of a Markdown text outside fenced code blocks, inline code removed
    unless ``inline_code`` (a heading's slug keeps the words inside backticks)."""
    out, fenced = [], False
    for line in text.splitlines():
        if _FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            out.append(line if inline_code else _INLINE_CODE.sub("", line))
    return out


def heading_slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"<[^>]+>", "", heading).replace("`", "").strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every anchor a link may name in a Markdown file: explicit ids and heading slugs."""
    text = path.read_text(encoding="utf-8")
    found = set(_ANCHOR_ID.findall(text))
    for line in prose_lines(text, inline_code=True):
        match = _HEADING.match(line)
        if match:
            found.add(heading_slug(match.group(1)))
    return found


def links(path: Path) -> list[str]:
    """The link targets of a Markdown file, in order, outside code."""
    # Joined, so a link whose text wraps over two lines is still one link.
    return _LINK.findall("\n".join(prose_lines(path.read_text(encoding="utf-8"))))


def broken_links(path: Path) -> list[str]:
    """The relative links of ``path`` that do not resolve, as 'target: reason'."""
    bad = []
    for target in links(path):
        if target.startswith(_EXTERNAL):
            continue
        file_part, _, anchor = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        if not dest.exists():
            bad.append(f"{target}: no such file or folder {dest}")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            bad.append(f"{target}: no anchor #{anchor} in {dest.name}")
    return bad


def broken_citations(path: Path, root: Path = ROOT) -> list[str]:
    """The ``docs/<page>.md#anchor`` citations in a source or config file that do not resolve
    from ``root``, as 'target: reason'."""
    bad = []
    for page, anchor in _CITATION.findall(path.read_text(encoding="utf-8")):
        dest = root / page
        if not dest.is_file():
            bad.append(f"{page}#{anchor}: no such file {dest}")
        elif anchor not in anchors(dest):
            bad.append(f"{page}#{anchor}: no anchor #{anchor} in {dest.name}")
    return bad


def citing_files(root: Path = ROOT) -> list[Path]:
    """The source, config and script files that may cite a document, this file excepted."""
    return [
        p
        for top in CITING
        if (root / top).is_dir()
        for p in sorted((root / top).rglob("*"))
        if p.suffix in CITING_SUFFIXES and p.resolve() != Path(__file__).resolve()
    ]


@pytest.mark.parametrize("path", DOCUMENTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(path: Path) -> None:
    assert path.exists(), f"{path} is missing"
    assert broken_links(path) == []


def test_citations_in_code_and_configs_resolve() -> None:
    files = citing_files()
    bad = [f"{p.relative_to(ROOT)}: {b}" for p in files for b in broken_citations(p)]
    assert bad == []
    # The scan must see citations, or it passes vacuously.
    assert sum(len(_CITATION.findall(p.read_text(encoding="utf-8"))) for p in files) >= 10


def test_broken_citations_are_found(tmp_path: Path) -> None:
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "page.md").write_text('<a id="here"></a>\n# A Heading\n')
    src = tmp_path / "mod.py"
    src.write_text(
        '"""See docs/page.md#here and docs/page.md#a-heading, not docs/page.md#gone\n'
        'nor docs/none.md#x."""\n'
    )
    assert broken_citations(src, tmp_path) == [
        "docs/page.md#gone: no anchor #gone in page.md",
        f"docs/none.md#x: no such file {tmp_path / 'docs' / 'none.md'}",
    ]


def test_every_document_links_somewhere() -> None:
    # The link parser itself must find links, or the test above passes vacuously.
    assert len(links(ROOT / "README.md")) >= 5
    assert any("design.md#" in t for t in links(ROOT / "docs" / "results.md"))


def test_broken_links_are_found(tmp_path: Path) -> None:
    (tmp_path / "other.md").write_text('<a id="here"></a>\n# A Title, with `code`\n')
    doc = tmp_path / "doc.md"
    doc.write_text(
        "[ok](other.md) [ok](other.md#here) [ok](other.md#a-title-with-code) [ok](#top)\n"
        "# Top\n[gone](missing.md) [gone,\nwrapped](other.md#nowhere) [web](https://example.org/x)\n"
        "```\n[in code](also_missing.md)\n```\n`[inline](inline_missing.md)`\n"
    )
    assert broken_links(doc) == [
        f"missing.md: no such file or folder {tmp_path / 'missing.md'}",
        "other.md#nowhere: no anchor #nowhere in other.md",
    ]


def test_readme_is_a_short_front_door() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines"


def test_results_is_the_current_page() -> None:
    lines = (ROOT / "docs" / "results.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) < RESULTS_MAX_LINES, f"docs/results.md has {len(lines)} lines"
    assert (ROOT / "docs" / "history.md").is_file()


if __name__ == "__main__":
    failures = [f"{p.relative_to(ROOT)}: {b}" for p in DOCUMENTS for b in broken_links(p)]
    failures += [f"{p.relative_to(ROOT)}: {b}" for p in citing_files() for b in broken_citations(p)]
    print("\n".join(failures) or f"all links resolve in {len(DOCUMENTS)} documents")
    sys.exit(1 if failures else 0)
