"""One run: validate → write the deck → execute the engine → collect results.h5 → run.json.

run.json is rewritten at each stage (atomically), so a run directory always says how far it got.
Nothing in it is ever deleted: a failed run keeps its deck, its log and whatever frames it wrote.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import time
from pathlib import Path
from typing import Any

from . import __version__, metrics
from .case import Case, Engine
from .engines import EngineError, get_adapter
from .engines.base import ProgressCallback
from .render import template_hash
from .results import write_results

RUN_RECORD = "run.json"
RESULTS = "results.h5"


def write_json_atomic(path: Path, data: dict[str, Any]) -> None:
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    os.replace(temporary, path)


def _now() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


def with_engine(case: Case, engine: str | None) -> Case:
    return case if engine is None else case.model_copy(update={"engine": Engine(engine)})


def render_case(case: Case, case_dir: Path, rundir: Path) -> Path:
    """Write the deck (and its data files) only; returns the deck path."""
    rundir.mkdir(parents=True, exist_ok=True)
    return get_adapter(case.engine.value).write_input(case, case_dir, rundir)


def run_case(
    case: Case,
    case_dir: Path,
    rundir: Path,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> dict[str, Any]:
    """Run a validated case in rundir and return the run record (also saved as run.json).

    Raises EngineError (after recording the failure in run.json) when the engine fails.
    """
    adapter = get_adapter(case.engine.value)
    deck = render_case(case, case_dir, rundir)
    info = adapter.info()
    record: dict[str, Any] = {
        "orchestrator_version": __version__,
        "case": case.model_dump(mode="json"),
        "engine": info.name,
        "engine_version": info.version,
        "template_hash": template_hash(info.name),
        "deck": deck.name,
        "status": "running",
        "started": _now(),
    }
    record_path = rundir / RUN_RECORD
    write_json_atomic(record_path, record)
    started = time.perf_counter()
    try:
        adapter.execute(rundir, progress=progress, timeout=timeout)
        trajectory = adapter.read_output(rundir)
    except EngineError as error:
        record.update(status="failed", error=error.summary, log_tail=error.tail, wall_time_s=time.perf_counter() - started)
        write_json_atomic(record_path, record)
        raise
    engine_seconds = time.perf_counter() - started
    trajectory.attrs.update(engine=info.name, engine_version=info.version or "unknown", case_name=case.name)
    write_results(rundir / RESULTS, trajectory)
    record.update(
        status="completed",
        finished=_now(),
        wall_time_s=time.perf_counter() - started,
        engine_wall_time_s=engine_seconds,
        frames=trajectory.n_frames,
        bodies=trajectory.n_bodies,
        metrics=metrics.summary(trajectory),
    )
    write_json_atomic(record_path, record)
    return record
