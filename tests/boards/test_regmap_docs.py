"""The register tables in docs/boards/ are the register maps, and the writer keeps them so."""

from __future__ import annotations

from pathlib import Path

import pytest

from fw1394.boards.regdocs import RegisterDocError, main, render, tables

DOCS = Path(__file__).resolve().parents[2] / "docs" / "boards"


@pytest.mark.parametrize(("doc", "count"), [("qla1.md", 5), ("snake2010.md", 2)])
def test_the_documented_tables_are_the_maps(doc: str, count: int) -> None:
    text = (DOCS / doc).read_text(encoding="utf-8")
    assert tables(text) == count
    assert render(text) == text, f"rewrite with: python -m fw1394.boards.regdocs docs/boards/{doc}"


def test_a_table_that_drifts_from_its_map_is_caught_and_rewritten(tmp_path: Path) -> None:
    text = (DOCS / "qla1.md").read_text(encoding="utf-8")
    drifted = text.replace("| 0x4 | HARDWARE_VERSION | ro |", "| 0x5 | HARDWARE_VERSION | rw |")
    assert drifted != text and render(drifted) == text
    path = tmp_path / "qla1.md"
    path.write_text(drifted, encoding="utf-8")
    assert main([str(path)]) == 0
    assert path.read_text(encoding="utf-8") == text


def test_a_table_naming_an_unknown_group_is_an_error() -> None:
    with pytest.raises(RegisterDocError, match="no register group"):
        render("<!-- registers qla1 nowhere Idx -->\n<!-- end registers -->")
    with pytest.raises(RegisterDocError, match="unknown board kind"):
        render("<!-- registers nosuch board Idx -->\n<!-- end registers -->")
