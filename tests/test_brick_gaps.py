"""Where an engine's avalanche brick misses the study's brick on brick, the study says so: the gaps
come from the engine's parity gaps (capabilities.brick_gaps), and `demorch doctor`, the avalanche
command and the report's page print them. No engine runs here."""

from __future__ import annotations

from pathlib import Path

from orchestrator.capabilities import ENGINES, brick_gaps
from orchestrator.studies.avalanche.report import write_html


def test_brick_gaps_are_the_brick_on_brick_parity_gaps() -> None:
    for name, entry in ENGINES.items():
        expected = [f"{case}: {why}" for case, why in entry.parity_gaps if case.startswith("brick on brick")]
        assert list(brick_gaps(name)) == expected
    assert len(brick_gaps("yade")) == 6  # five placements at 40.2° and the acceleration at 47°
    assert brick_gaps("cocd") == ()


def test_the_report_page_shows_each_gap_escaped(tmp_path: Path) -> None:
    page = write_html(tmp_path, "t", [], [], ["brick on brick, aligned, 40.2°: slides <5 mm> & more"])
    text = page.read_text()
    assert '<p class="warning">brick on brick, aligned, 40.2°: slides &lt;5 mm&gt; &amp; more</p>' in text
    assert "warning" not in write_html(tmp_path, "t", [], []).read_text().split("</style>")[1]
