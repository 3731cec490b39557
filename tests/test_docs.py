"""The documents: every relative link in README.md and docs/**/*.md resolves, so does every
``docs/<page>.md#anchor`` the code and configs cite, the README stays a short front door and
docs/results.md a current page, not a history, and every Markdown page keeps its lines within
the page width (docs/design/metrics.md#page-width).

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

from d3dwa_bullet.evaluation.page_width import PAGE_WIDTH

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
_PAGE_PATH = re.compile(r"\b((?:docs|randomization)/[\w./-]*\.md)\b")

_FENCE = re.compile(r"^\s*(```|~~~)")
_INLINE_CODE = re.compile(r"`[^`]*`")
_LINK = re.compile(r"\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_ANCHOR_ID = re.compile(r"<a\s+(?:id|name)=\"([^\"]+)\"")
_HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")
_EXTERNAL = ("http://", "https://", "mailto:")
# Pilot records stay as they were written; they are not pages kept to the house width.
PAGES_EXEMPT = (ROOT / "docs" / "pilots",)
# The README's two install-and-run commands ("Main job", "Tests") are copied as they are, so a
# line inside a ```bash block of README.md that starts with this may be wider than the page.
README_COMMAND = "python3 -m venv"


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


def missing_pages(path: Path, root: Path = ROOT) -> list[str]:
    """The ``docs/<page>.md`` paths a source or config file names, with or without an anchor,
    that are not files under ``root`` (a page moved or deleted, say the design notes' split)."""
    named = sorted(set(_PAGE_PATH.findall(path.read_text(encoding="utf-8"))))
    return [f"{page}: no such file {root / page}" for page in named if not (root / page).is_file()]


def citing_files(root: Path = ROOT) -> list[Path]:
    """The source, config and script files that may cite a document, this file excepted."""
    return [
        p
        for top in CITING
        if (root / top).is_dir()
        for p in sorted((root / top).rglob("*"))
        if p.suffix in CITING_SUFFIXES and p.resolve() != Path(__file__).resolve()
    ]


def _ignored_top_folders(root: Path) -> set[str]:
    """The top-level folders .gitignore names as ``/name/`` (run and results outputs)."""
    ignore = root / ".gitignore"
    lines = ignore.read_text(encoding="utf-8").splitlines() if ignore.is_file() else []
    return {s.strip("/") for s in lines if s.startswith("/") and s.endswith("/")}


def markdown_pages(root: Path = ROOT) -> list[Path]:
    """Every Markdown page of the repository: its ``*.md`` files outside hidden folders, build
    and cache folders, the output folders .gitignore names, and docs/pilots/."""
    skip_top = _ignored_top_folders(root)
    exempt = [root / e.relative_to(ROOT) for e in PAGES_EXEMPT]
    # Outputs are skipped before the walk: a run folder may hold many thousand files.
    tops = [p for p in sorted(root.iterdir()) if p.name not in skip_top]
    pages = []
    for top in tops:
        for path in [top] if top.is_file() else sorted(top.rglob("*.md")):
            parts = path.relative_to(root).parts
            hidden = any(p.startswith(".") or p in ("__pycache__", "build") for p in parts)
            if path.suffix != ".md" or hidden or any(p.endswith(".egg-info") for p in parts):
                continue
            if not any(path.is_relative_to(e) for e in exempt):
                pages.append(path)
    return pages


def over_wide_lines(path: Path, readme: bool = False) -> list[str]:
    """The lines of a Markdown page wider than PAGE_WIDTH, as 'line N: W characters'. With
    ``readme``, a line inside a ```bash block starting with README_COMMAND is a command, not
    prose, and is let through."""
    bad, fence = [], None
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if _FENCE.match(line):
            fence = line.strip()[3:].strip() if fence is None else None
            continue
        command = readme and fence == "bash" and line.startswith(README_COMMAND)
        if len(line) > PAGE_WIDTH and not command:
            bad.append(f"line {n}: {len(line)} characters")
    return bad


_RULE = re.compile(r"^\|(\s*:?-+:?\s*\|)+$")


def tables_without_rule(path: Path) -> list[str]:
    """The Markdown tables of a page, outside code, whose header line is not followed by a
    delimiter row (``|---|---:|``) of as many columns: without one, a table renders as text."""
    lines = path.read_text(encoding="utf-8").splitlines()
    bad, fenced = [], False
    for n, line in enumerate(lines, 1):
        if _FENCE.match(line):
            fenced = not fenced
        row = line.startswith("|") and line.rstrip().endswith("|")
        starts = row and not (n > 1 and lines[n - 2].startswith("|"))
        if fenced or not starts:
            continue
        rule = lines[n] if n < len(lines) else ""
        cells = _INLINE_CODE.sub("", line).count("|")
        if not _RULE.match(rule.strip()) or rule.count("|") != cells:
            bad.append(f"table at line {n}: no delimiter row under its header")
    return bad


@pytest.mark.parametrize("path", DOCUMENTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_tables_have_a_delimiter_row(path: Path) -> None:
    assert tables_without_rule(path) == []


def test_a_table_without_a_delimiter_row_is_found(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("| a | b |\n|---|---:|\n| 1 | 2 |\n\ntext\n| a | b |\n| 1 | 2 |\n"
                    "\n| a | b |\n|---|\n```\n| code |\n```\n")  # fmt: skip
    assert tables_without_rule(page) == [
        "table at line 6: no delimiter row under its header",
        "table at line 9: no delimiter row under its header",
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


def test_pages_named_in_code_and_configs_exist() -> None:
    files = citing_files()
    assert [f"{p.relative_to(ROOT)}: {m}" for p in files for m in missing_pages(p)] == []


def test_citations_written_out_in_pages_resolve() -> None:
    # A page may cite another as plain text (``docs/design/score.md#score`` in a pilot's record),
    # not as a link; such a citation must name a page and an anchor that exist too.
    pages = [
        *DOCUMENTS,
        *sorted((ROOT / "examples").rglob("*.md")),
        *sorted((ROOT / "tools").rglob("*.md")),
    ]
    bad = [
        f"{p.relative_to(ROOT)}: {b}" for p in pages for b in broken_citations(p) + missing_pages(p)
    ]
    assert bad == []
    assert sum(len(_CITATION.findall(p.read_text(encoding="utf-8"))) for p in pages) >= 10


def test_design_notes_are_split_into_pages() -> None:
    # One page per concern under docs/design/, each within the house's module size, and an index
    # that lists every page (docs/design/README.md#pages).
    folder = ROOT / "docs" / "design"
    pages = sorted(p for p in folder.glob("*.md") if p.name != "README.md")
    assert not (ROOT / "docs" / "design").with_suffix(".md").exists()  # the old single page
    assert len(pages) >= 10
    long = [p.name for p in pages if len(p.read_text(encoding="utf-8").splitlines()) >= 400]
    assert long == []
    index = set(links(folder / "README.md"))
    assert [p.name for p in pages if p.name not in index] == []


def test_missing_pages_are_found(tmp_path: Path) -> None:
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "page.md").write_text("# Page\n")
    src = tmp_path / "mod.py"
    src.write_text('"""See docs/page.md, docs/gone.md and docs/old.md#anchor."""\n')
    assert missing_pages(src, tmp_path) == [
        f"docs/gone.md: no such file {tmp_path / 'docs' / 'gone.md'}",
        f"docs/old.md: no such file {tmp_path / 'docs' / 'old.md'}",
    ]


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
    assert any("design/" in t for t in links(ROOT / "docs" / "results.md"))


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


def test_results_opens_with_one_answer_per_question() -> None:
    # A newcomer finds the current answers to (a), (b) and (c) in the first 30 lines, each saying
    # what it is about, and the page uses no name a reader cannot look up.
    text = (ROOT / "docs" / "results.md").read_text(encoding="utf-8")
    first = "\n".join(text.splitlines()[:30])
    for question in ("a", "b", "c"):
        assert first.count(f'<a id="answer-{question}">') == 1
        assert first.count(f"**({question}) ") == 1
    leads = re.findall(r"\*\*\([abc]\) [^*]+\*\*", first)
    assert len(leads) == 3
    for lead in leads:
        assert re.search(r"the recipe|these policies", lead), lead
    internal = re.compile(
        r"\bissues? \d+|\bpilot [A-Z]\b|\brecipe \d+|\bsessions? \d+", re.IGNORECASE
    )
    assert internal.findall(text) == []


def test_pages_keep_the_page_width() -> None:
    pages = markdown_pages()
    # The scan must see the pages, or it passes vacuously.
    pilots = ROOT / "docs" / "pilots"
    assert {d for d in DOCUMENTS if not d.is_relative_to(pilots)} <= set(pages)
    assert not any(p.is_relative_to(pilots) for p in pages)
    bad = {
        str(p.relative_to(ROOT)): over_wide_lines(p, readme=p == ROOT / "README.md") for p in pages
    }
    assert {page: lines for page, lines in bad.items() if lines} == {}


def test_only_the_readme_commands_are_wider() -> None:
    readme = ROOT / "README.md"
    text = readme.read_text(encoding="utf-8")
    # The exception is the two commands, as long as they are: no third line may use it.
    commands = [line for line in text.splitlines() if line.startswith(README_COMMAND)]
    assert len(commands) == 2
    assert len(over_wide_lines(readme)) == sum(len(c) > PAGE_WIDTH for c in commands)


def test_over_wide_lines_are_found(tmp_path: Path) -> None:
    long = "x" * (PAGE_WIDTH + 1)
    page = tmp_path / "page.md"
    page.write_text(
        f"{'y' * PAGE_WIDTH}\n{long}\n```bash\n{README_COMMAND} {long}\n{long}\n```\n"
        f"{README_COMMAND} {long}\n```\n{README_COMMAND} {long}\n```\n"
    )
    wide = PAGE_WIDTH + 1
    venv = len(README_COMMAND) + 1 + wide
    assert over_wide_lines(page, readme=True) == [
        f"line 2: {wide} characters",
        f"line 5: {wide} characters",
        f"line 7: {venv} characters",
        f"line 9: {venv} characters",
    ]
    assert over_wide_lines(page)[1] == f"line 4: {venv} characters"


def test_markdown_pages_skip_pilots_and_outputs(tmp_path: Path) -> None:
    (tmp_path / ".gitignore").write_text("/runs/\n*.pyc\n")
    kept = ("README.md", "docs/a.md", "t/b.md")
    for rel in (*kept, "docs/pilots/p/plan.md", "runs/x/table.md", ".venv/r.md"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("# page\n")
    found = [p.relative_to(tmp_path).as_posix() for p in markdown_pages(tmp_path)]
    assert found == list(kept)


if __name__ == "__main__":
    failures = [f"{p.relative_to(ROOT)}: {b}" for p in DOCUMENTS for b in broken_links(p)]
    failures += [f"{p.relative_to(ROOT)}: {b}" for p in citing_files() for b in broken_citations(p)]
    print("\n".join(failures) or f"all links resolve in {len(DOCUMENTS)} documents")
    sys.exit(1 if failures else 0)
