"""Content-addressed runs made once and reused: settled packings, prepared columns.

A preparation run (bricks settled in their box, a column rained behind its gate) is expensive and
feeds many later runs. It is stored under root/<key>/, the key being the hash of everything that
shapes it (case_key), so any study with the same preparation inputs finds it, in any process.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
from pathlib import Path
from typing import Callable

from .case import Case
from .engines import EngineError
from .runner import run_case


def case_key(case: Case) -> str:
    """Content address of a case: the case, and what turns that case into engine steps.

    The step schedule, the engine's templates and the engine's version are in the key with the case,
    so a run made by other code or another engine build is never taken for this one.
    """
    from . import physics
    from .engines import get_adapter
    from .render import template_hash

    plan = physics.schedule(case)
    stamp = {
        "case": case.model_dump(mode="json"),
        "schedule": [plan.dt, plan.output_every, plan.frames, plan.total_steps],
        "templates": template_hash(case.engine.value),
        "engine_version": get_adapter(case.engine.value).info().version,
    }
    return hashlib.sha256(json.dumps(stamp, sort_keys=True, separators=(",", ":")).encode()).hexdigest()[:16]


def ensure_run(
    case: Case,
    root: Path,
    what: str,
    state_file: Callable[[Path], Path | None] = lambda directory: None,
    progress: Callable[[float, float], None] | None = None,
    timeout: float | None = None,
) -> tuple[Path, bool]:
    """Run `case` once under root/<case_key>/ and reuse it afterwards. Returns (directory, reused).

    A lock file serialises processes that need the same run (campaign workers, say): the first runs
    it, the others wait and reuse it. A run is reused only when it completed and the state file it
    must leave (`state_file(directory)`, if any) exists; a failed or interrupted attempt is moved to
    root/attic. `what` names the run in errors ("the packing run failed: …").
    """
    from .campaign import store

    key = case_key(case)
    directory = root / key
    root.mkdir(parents=True, exist_ok=True)
    with open(root / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        required = state_file(directory)
        if store.status(directory) == "completed" and (required is None or required.is_file()):
            return directory, True
        if directory.exists():
            store.retire(directory, root)
        try:
            run_case(case, root, directory, progress=progress, timeout=timeout)
        except EngineError as error:
            raise EngineError(f"the {what} run failed: {error.summary}", error.deck, error.log, error.tail) from None
    return directory, False
