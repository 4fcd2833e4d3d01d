"""An engine that fails leaves its deck and log in place and raises an error with the log tail."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from orchestrator.engines import EngineError
from orchestrator.engines.liggghts.adapter import LiggghtsAdapter
from orchestrator.engines.yade.adapter import YadeAdapter
from orchestrator.results import RUN_RECORD
from orchestrator.runner import render_case, run_case

from orchestrator.plan import make_plan
from conftest import free_fall_case, requires_liggghts, requires_yade


def broken_deck_error(engine: str, tmp_path: Path, text: str, broken: str) -> tuple[Path, Path, str]:
    """Render the free fall for `engine`, replace `text` by `broken` in its deck, run the engine on it:
    (deck, run directory, the EngineError's message)."""
    rundir = tmp_path / "run"
    case = free_fall_case(engine)
    deck = render_case(case, tmp_path, rundir)
    deck.write_text(deck.read_text().replace(text, broken))
    adapter = LiggghtsAdapter() if engine == "liggghts" else YadeAdapter()
    with pytest.raises(EngineError) as caught:
        adapter.execute(make_plan(case, tmp_path), rundir)
    return deck, rundir, str(caught.value)


@requires_liggghts
@pytest.mark.engine
def test_corrupt_liggghts_deck_reports_log_tail(tmp_path: Path) -> None:
    deck, rundir, message = broken_deck_error("liggghts", tmp_path, "pair_style      gran", "pair_style      grann")
    assert "ERROR" in message and "grann" in message, message
    assert str(deck) in message
    assert deck.exists() and (rundir / "engine.log").exists()
    assert "grann" in (rundir / "engine.log").read_text()


@requires_yade
@pytest.mark.engine
def test_failing_yade_script_reports_traceback(tmp_path: Path) -> None:
    script, rundir, message = broken_deck_error("yade", tmp_path, "O.dt = DT", "O.dt = DT / undefined_name")
    assert "undefined_name" in message
    assert script.exists() and (rundir / "engine.log").exists()


def test_missing_engine_binary_is_a_clear_error_and_the_run_is_recorded(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    with pytest.raises(EngineError, match=r"'liggghts-not-installed' was not found on PATH; install it with: apt-get"):
        run_case(free_fall_case("liggghts"), tmp_path, rundir, adapter=LiggghtsAdapter(executable="liggghts-not-installed"))
    record = json.loads((rundir / RUN_RECORD).read_text())
    assert record["status"] == "failed"
    assert (rundir / "in.liggghts").exists(), "the deck must survive a failed run"


@requires_liggghts
@pytest.mark.engine
def test_bodies_leaving_the_domain_are_reported(tmp_path: Path) -> None:
    case = free_fall_case("liggghts")
    data = case.model_dump(mode="json")
    data["domain"] = {"lower": [-0.1, -0.1, 0.99], "upper": [0.1, 0.1, 1.1]}  # the sphere falls out
    from orchestrator.case import parse_case

    with pytest.raises(EngineError, match=r"^1 body left the simulation domain \(body 0 at t = "):
        run_case(parse_case(data), tmp_path, tmp_path / "run")
