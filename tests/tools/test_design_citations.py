"""tools/design_citations: old single-page citations moved to the page holding their anchor."""

from __future__ import annotations

from pathlib import Path

from tools.design_citations import ROOT, anchor_pages, rewrite, tracked_files

OLD = "docs/" + "design.md"  # spelled apart, so that the tree's own citation checks skip it


def test_each_spelling_moves_to_the_page_that_holds_the_anchor(tmp_path: Path) -> None:
    (tmp_path / "planner.md").write_text('<a id="planner"></a>\n# P\n<a id="footprint"></a>\n')
    (tmp_path / "score.md").write_text('<a id="score"></a>\n')
    pages = anchor_pages(tmp_path)
    assert pages == {"planner": "planner.md", "footprint": "planner.md", "score": "score.md"}
    text = (
        f"see {OLD}#footprint and ({OLD}#score); [x](design.md#planner), "
        f"[y](../design.md#score), the notes {OLD}, and {OLD}#gone; docs/design/score.md#score\n"
    )
    new, unknown = rewrite(text, pages)
    assert new == (
        "see docs/design/planner.md#footprint and (docs/design/score.md#score); "
        "[x](design/planner.md#planner), [y](../design/score.md#score), the notes "
        f"docs/design/README.md, and {OLD}#gone; docs/design/score.md#score\n"
    )
    assert unknown == ["gone"]


def test_every_anchor_of_the_old_page_has_a_page_and_the_tree_cites_none() -> None:
    pages = anchor_pages(ROOT / "docs" / "design")
    for anchor in ("planner", "recovery", "score", "external-methods", "readings", "spec-map"):
        assert anchor in pages
    assert tracked_files(ROOT) == []
