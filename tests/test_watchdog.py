"""An engine that runs away is stopped with its log tail: a log that grows without the simulated time
advancing, a run that makes no progress for the stated time; the log itself is capped."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import pytest

from orchestrator.engines import EngineError, base
from orchestrator.runner import run_case

from conftest import free_fall_case, requires_liggghts


def _progress(line: str) -> float | None:
    return float(line.split()[1]) if line.startswith("T ") else None


def _run(script: str, tmp_path: Path) -> EngineError:
    with pytest.raises(EngineError) as caught:
        base.run_engine([sys.executable, "-c", script], tmp_path, tmp_path / "deck", _progress, 1.0)
    return caught.value


def test_an_engine_writing_without_advancing_is_stopped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(base, "MAX_LOG_WITHOUT_PROGRESS", 2**20)
    started = time.monotonic()
    error = _run("print('T 0.1', flush=True)\nwhile True: print('WARNING: Restart file version does not match', flush=True)", tmp_path)
    assert "without its simulated time advancing" in error.summary and error.tail
    assert time.monotonic() - started < 30
    assert (tmp_path / "engine.log").stat().st_size < 3 * 2**20


def test_an_engine_that_advances_is_left_alone_however_much_it_writes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(base, "MAX_LOG_WITHOUT_PROGRESS", 2**16)
    script = "for i in range(2000):\n    print('T', i * 1e-3, 'x' * 100, flush=True)"
    tail = base.run_engine([sys.executable, "-c", script], tmp_path, tmp_path / "deck", _progress, 1.0)
    assert tail[-1].startswith("T 1.999")


def test_an_engine_that_stalls_is_stopped_after_the_stated_time(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(base.STALL_ENV, "1")
    started = time.monotonic()
    error = _run("import time\nprint('T 0.1', flush=True)\ntime.sleep(60)", tmp_path)
    assert "made no progress for 1 s" in error.summary
    assert time.monotonic() - started < 15


def test_the_log_is_capped_and_says_so(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(base, "MAX_LOG_BYTES", 10_000)
    script = "for i in range(5000):\n    print('T', i * 1e-4, flush=True)\nprint('the last line')"
    tail = base.run_engine([sys.executable, "-c", script], tmp_path, tmp_path / "deck", _progress, 1.0)
    log = (tmp_path / "engine.log").read_text()
    assert len(log) < 11_000 and "log capped at" in log and tail[-1] == "the last line"


@requires_liggghts
@pytest.mark.engine
def test_liggghts_fed_a_zeroed_state_file_is_stopped_not_left_to_fill_the_disk(tmp_path: Path) -> None:
    """LIGGGHTS loops forever on 'Restart file version' warnings when its restart file is zeros (25–55 MB/s
    of log, measured 2026-12-01): the watchdog stops it within seconds and reports the log tail."""
    data = json.loads(free_fall_case("liggghts").model_dump_json())
    run_case(free_fall_case("liggghts").model_copy(update={"save_state": True}), tmp_path, tmp_path / "saved")
    state = tmp_path / "saved" / "state.restart"
    state.write_bytes(bytes(state.stat().st_size))
    from orchestrator.case import parse_case

    started = time.monotonic()
    with pytest.raises(EngineError) as caught:
        run_case(parse_case({**data, "initial_state": "saved/state.restart"}), tmp_path, tmp_path / "from_zeros")
    assert "without its simulated time advancing" in caught.value.summary, caught.value.summary
    assert time.monotonic() - started < 120
    assert (tmp_path / "from_zeros" / "engine.log").stat().st_size <= base.MAX_LOG_BYTES + 2**20
