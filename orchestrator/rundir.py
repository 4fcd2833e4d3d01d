"""One run directory: its identity, its saved inputs, its record, its status and its lock.

A run's id hashes everything that decides its results, signac's way (a job is its canonical state
point, hashed, checked on load): the inputs' fields that differ from their defaults (a validated
case, or a study) with the schema version, the content of every file the case names (meshes, the
initial state), and the engine build (the engine's version as it reports it, the code and
templates that write its deck, the compiled contact plugin). The same inputs on the same build give
the same id; an edited mesh, brick or template gives another. Layout of a run directory:

    case.json   the validated inputs, canonical JSON (a case, or a study for a study run)
    run.json    the record: run_id, build, files (the named files' digests), status (running |
                completed | failed), timings, metrics; written by `write_record` only
    .lock       held (fcntl) by the process working in the directory: a run is `running` while
                its lock is held, and nothing else (no PID file) decides it
    results.h5  the frames (case runs; a study run's record points at its release's)

Reading a run back checks case.json against the recorded id, and the recorded build against the
current one: a run whose inputs or build changed is `stale`, never `completed`. A content-addressed
directory (a campaign point, a shared packing: named by its run id) must also hold the run of that
id, and a completed run's outputs are sealed (`sealed`: the sha256 of its results and saved state,
verified on reuse): a run whose files were edited or damaged since it completed is `stale` too.
One rule, `why_stale`, says why a stored run may not stand for today's inputs.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import errno
import fcntl
import hashlib
import json
import os
import shutil
import stat
from collections.abc import Callable, Iterator
from functools import lru_cache
from pathlib import Path
from typing import Any

import h5py
from pydantic import BaseModel

from orchestrator.case import Case, CaseError, MeshWall
from orchestrator.results import CAMPAIGN_RECORD, CASE_COPY, RESULTS, RUN_RECORD, read_json  # noqa: F401  (read_json, CAMPAIGN_RECORD re-exported)

LOCK = ".lock"
JOBS = "jobs"  # a batch scheduler's files for the run (job script, job logs, job record: orchestrator.slurm)
KEPT = (LOCK, JOBS)  # what stays in the directory when an attempt is retired: they belong to the directory, not to one attempt
ATTIC = "attic"
STATUSES = ("pending", "running", "completed", "failed", "stale", "incomplete")


def write_json_atomic(path: Path, data: dict[str, Any]) -> None:
    """Write JSON through a temporary file and a rename: a reader never sees half a file."""
    write_text_atomic(path, json.dumps(data, indent=2, sort_keys=True) + "\n")


def write_text_atomic(path: Path, text: str) -> None:
    """Write text through a temporary file and a rename: a reader never sees half a file, and a
    full disk leaves the old file (the temporary one is removed)."""
    temporary = path.with_name(path.name + ".tmp")
    try:
        temporary.write_text(text)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def now() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


# -- identity -----------------------------------------------------------------------------------
# The identity leaves out every field equal to its default, so adding a field with a default keeps
# every id. Changing what an existing default *is* must change ids: bump this, and record the new
# defaults (tests/identity_defaults.json, written by running tests/test_identity.py; a test fails
# when a recorded default changed without a new version).
SCHEMA_VERSION = 2


Build = dict[str, Any]  # an engine build's stamp (engines.build_stamp): engine, version, code and plugin hashes
Builds = Callable[[str], Build]  # engine name → today's build stamp (engines.build_stamp)


def canonical_inputs(inputs: BaseModel) -> dict[str, Any]:
    """Every field, defaults included: what case.json keeps for a reader."""
    return inputs.model_dump(mode="json")


def identity_inputs(inputs: BaseModel) -> dict[str, Any]:
    """The fields a run id covers: those that differ from their defaults."""
    return inputs.model_dump(mode="json", exclude_defaults=True)


def named_files(inputs: BaseModel) -> list[str]:
    """The files a case names (mesh walls, the initial state), as written in it; a study names none."""
    if not isinstance(inputs, Case):
        return []
    meshes = [wall.file for wall in inputs.walls if isinstance(wall, MeshWall)]
    return meshes + ([inputs.initial_state] if inputs.initial_state else [])


def file_digests(inputs: BaseModel, case_dir: Path | None) -> dict[str, str]:
    """name → sha256 of the content of each file the inputs name (relative to case_dir, else the
    working directory); 'missing' or 'not a regular file' when it cannot be read as one."""
    root = case_dir if case_dir is not None else Path(".")
    return {name: _file_digest(root / name) for name in named_files(inputs)}


def _file_digest(path: Path) -> str:
    try:
        info = path.stat()
    except OSError:
        return "missing"
    if not stat.S_ISREG(info.st_mode):  # a FIFO or a device is never read (it could hang or never end)
        return "not a regular file"
    return _content_digest(str(path.resolve()), info.st_size, info.st_mtime_ns)


@lru_cache(maxsize=256)
def _content_digest(path: str, size: int, mtime_ns: int) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def run_id(inputs: BaseModel, build: Build, case_dir: Path | None = None, files: dict[str, str] | None = None) -> str:
    """The one run id: 16 hex digits of sha256 over the inputs' non-default fields, the schema version,
    the content of every file they name (`files`, else read now from case_dir) and the engine build
    that runs them (engines.build_stamp of the inputs' engine)."""
    stamp: dict[str, Any] = {
        "schema": SCHEMA_VERSION,
        "inputs": identity_inputs(inputs),
        "files": files if files is not None else file_digests(inputs, case_dir),
        "build": build,
    }
    return hashlib.sha256(json.dumps(stamp, sort_keys=True, separators=(",", ":")).encode()).hexdigest()[:16]


def save_inputs(directory: Path, inputs: BaseModel) -> None:
    """Keep the validated inputs beside the run (readers take masses and the schedule from them)."""
    (directory / CASE_COPY).write_text(json.dumps(canonical_inputs(inputs), indent=2) + "\n")


def saved_case(directory: Path) -> Case:
    """The case a run directory was made from (case.json)."""
    return Case.model_validate_json((directory / CASE_COPY).read_text())


def write_record(directory: Path, record: dict[str, Any]) -> None:
    """The one writer of run.json: atomically, with a status a reader knows (STATUSES)."""
    if record.get("status") not in STATUSES:
        raise ValueError(f"run.json: status {record.get('status')!r} is not one of {STATUSES}")
    write_json_atomic(directory / RUN_RECORD, record)


def read_record(directory: Path) -> dict[str, Any] | None:
    """The one reader of run.json: the record of the run in `directory`, or None when there is none
    (or it does not read as a JSON mapping)."""
    return read_json(directory / RUN_RECORD)


def record_failure(directory: Path, kind: str, summary: str, tail: tuple[str, ...] | list[str]) -> None:
    """run.json of a run that failed before its runner recorded anything (its inputs refused, a
    study's stage failed): the kind, the one-line error and the engine log's tail."""
    write_record(directory, {"status": "failed", "kind": kind, "error": summary, "log_tail": list(tail)})


# -- locking ------------------------------------------------------------------------------------
class Busy(RuntimeError):
    """Another process holds the run directory's lock."""


class Unlockable(CaseError):
    """The run directory cannot be made or locked (read-only, or a file in its place): the message says which."""


@contextlib.contextmanager
def locked(directory: Path, wait: bool = True) -> Iterator[None]:
    """Hold the directory's lock (created with the directory). wait=False raises Busy when held;
    Unlockable when the directory or its lock file cannot be made."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
        handle = open(directory / LOCK, "a")
    except OSError as error:
        if directory.exists() and not directory.is_dir():
            raise Unlockable(f"{directory} is a file where the run's directory should be: move it away") from None
        raise Unlockable(f"{directory} cannot be written ({error.strerror or error}): a run directory needs its lock file there") from None
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except OSError as error:
            if error.errno in (errno.EAGAIN, errno.EACCES):
                raise Busy(f"{directory} is in use by another process") from None
            raise
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def is_locked(directory: Path) -> bool:
    """True while some process holds the directory's lock (a live run)."""
    path = directory / LOCK
    if not path.exists():
        return False
    with open(path, "a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            return True
        fcntl.flock(handle, fcntl.LOCK_UN)
    return False


# -- status -------------------------------------------------------------------------------------
def results_readable(path: Path) -> bool:
    try:
        with h5py.File(path, "r") as store:
            return "frames/position" in store
    except (OSError, KeyError, ValueError):
        return False


def status(directory: Path, inputs_model: type[BaseModel] = Case, *, builds: Builds | None, held: bool = False,
           expected_id: str | None = None) -> str:
    """pending | running | completed | failed | stale | incomplete.

    running: a process holds the lock. completed: the record says so, the results read back and
    `why_stale` finds nothing (its case.json hashes to its id, its build is today's per `builds`, its sealed
    outputs are intact, and its id is `expected_id` when the directory stands for one); a completed
    run that fails those checks is stale. incomplete: its process died before it finished. held: the
    caller holds the lock (so do not probe it). builds: engine → today's build (engines.build_stamp);
    None leaves the build unchecked.
    """
    if not held and is_locked(directory):
        return "running"
    if not holds_attempt(directory):
        return "pending"
    record = read_record(directory)
    if record is None:
        return "incomplete"
    if record.get("status") == "failed":
        return "failed"
    if record.get("status") != "completed" or not results_readable(directory / str(record.get("results", RESULTS))):
        return "incomplete"
    return "completed" if why_stale(directory, record, inputs_model, builds, expected_id) is None else "stale"


def why_stale(directory: Path, record: dict[str, Any], inputs_model: type[BaseModel] = Case, builds: Builds | None = None,
              expected_id: str | None = None) -> str | None:
    """None when the completed run in `directory` may stand for its inputs today; else why not, in a
    few words: its saved inputs do not hash to its recorded id with its recorded build, its id is
    not `expected_id` (the id its directory stands for), its results were never sealed, a sealed output changed, or its build is not
    today's (`builds`: engine → today's build stamp; None: not checked)."""
    build = record.get("build")
    if "run_id" not in record or not isinstance(build, dict):
        return "its record has no run id or build"
    if expected_id is not None and record["run_id"] != expected_id:
        return f"it holds the run {record['run_id']}, not the {expected_id} its directory stands for"
    try:
        inputs = inputs_model.model_validate_json((directory / CASE_COPY).read_text())
    except (ValueError, OSError):
        return f"its {CASE_COPY} does not read back"
    files = record.get("files", {})
    if not isinstance(files, dict) or run_id(inputs, build, files=files) != record["run_id"]:
        return f"its {CASE_COPY} does not hash to its run id"
    sealed = record.get("sealed")
    if not isinstance(sealed, dict) or str(record.get("results", RESULTS)) not in sealed:  # a missing seal is a stale record, not a trusted one
        return "its results were never sealed"
    broken = [name for name, value in sealed.items() if _file_digest(directory / name) != value]
    if broken:
        return f"{', '.join(broken)} changed since it was sealed"
    if builds is not None and build != builds(str(build.get("engine", ""))):
        return "it was made by another build"
    return None


def seal_outputs(directory: Path, names: list[str]) -> dict[str, str]:
    """name → sha256 of each output a completed run keeps (its results, its saved state): the record's
    `sealed`, checked by `why_stale` before the run is reused."""
    return {name: _file_digest(directory / name) for name in names}


def holds_attempt(directory: Path) -> bool:
    """Whether the directory holds anything an attempt left (more than what is KEPT)."""
    return directory.exists() and any(entry.name not in KEPT for entry in directory.iterdir())


def retire(directory: Path, root: Path, only: tuple[str, ...] | None = None) -> Path:
    """Move what a dead, failed or stale attempt left to root/attic/<name>-<time> (nothing computed is
    deleted), so the directory can run again. The lock file and the jobs (KEPT) stay: call it under the
    lock. only: move just these entries (those present), e.g. a study's products beside a campaign's record."""
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S-%f")
    target = root / ATTIC / f"{directory.name}-{stamp}"
    try:
        target.mkdir(parents=True)
    except OSError as error:
        raise CaseError(f"{root / ATTIC}: cannot keep what is set aside there ({error.strerror or error}); "
                        "make it a writable directory (or move what stands in its place)") from None
    for entry in directory.iterdir():
        if entry.name not in KEPT and (only is None or entry.name in only):
            shutil.move(str(entry), target / entry.name)
    return target
