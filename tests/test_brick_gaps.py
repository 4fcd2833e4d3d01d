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


def test_a_fallback_brick_brings_its_own_gaps() -> None:
    """LIGGGHTS' preferred rounded box has none; the superquadric a linear-law study falls back to
    slides in two placements below atan μ, and the study says so."""
    from orchestrator.studies.avalanche.spec import AvalancheStudy

    assert brick_gaps("liggghts") == () == brick_gaps("liggghts", "rounded_box")
    linear = AvalancheStudy.model_validate({"name": "x", "engine": "liggghts", "contacts": {"law": "linear"}})
    gaps = brick_gaps("liggghts", linear.brick_spec.kind)
    assert [gap.split(":")[0] for gap in gaps] == ["brick on brick, aligned_y, 40.2°", "brick on brick, offset_x_3.9mm, 40.2°"]
    assert brick_gaps("liggghts", "clump") == ()


def test_the_report_page_shows_each_gap_escaped(tmp_path: Path) -> None:
    page = write_html(tmp_path, "t", [], [], ["brick on brick, aligned, 40.2°: slides <5 mm> & more"])
    text = page.read_text()
    assert '<p class="warning">brick on brick, aligned, 40.2°: slides &lt;5 mm&gt; &amp; more</p>' in text
    assert "warning" not in write_html(tmp_path, "t", [], []).read_text().split("</style>")[1]
