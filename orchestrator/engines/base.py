"""What every engine adapter provides, and the shared way of running an engine process.

An adapter writes its input into a run directory, executes the engine there (log streamed to
`engine.log`, progress reported as simulated time), and reads the output back as a Trajectory.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import threading
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Protocol

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from orchestrator.engines.options import RunOptions
    from orchestrator.plan import RunPlan
from orchestrator.results import Trajectory

LOG_NAME = "engine.log"
MAX_LOG_BYTES = 256 * 2**20  # an engine log is capped here (the tail and the failure scan still read everything)
MAX_LOG_WITHOUT_PROGRESS = 64 * 2**20  # bytes of log without the simulated time advancing: a runaway engine
STALL_ENV = "DEMORCH_STALL_S"
STALL_S = 1800.0  # s without the simulated time advancing before an engine is stopped (the slowest output seen: about a minute)
TAIL_LINES = 25
CONTEXT_BEFORE, CONTEXT_AFTER = 8, 12  # lines kept around an engine's first error line

ProgressCallback = Callable[[float, float], None]  # (simulated time, end time)


class EngineError(RuntimeError):
    """An engine failed. The message carries the deck path and the tail of the engine log."""

    def __init__(self, summary: str, deck: Path | None = None, log: Path | None = None, tail: list[str] | None = None):
        self.summary = summary
        self.deck = deck
        self.log = log
        self.tail = tail or []
        parts = [summary]
        if deck is not None:
            parts.append(f"deck: {deck}")
        if log is not None:
            parts.append(f"log:  {log}")
        if self.tail:
            parts.append("last lines of the engine log:\n" + "\n".join(f"  | {line}" for line in self.tail))
        super().__init__("\n".join(parts))


class ContactBuildError(RuntimeError):
    """A compiled contact law could not be built; the message holds the compiler's output tail."""


@dataclass(frozen=True)
class EngineInfo:
    name: str
    executable: str | None
    version: str | None
    install_hint: str


class EngineAdapter(Protocol):
    """An engine behind one stateless interface: every per-run input arrives as a RunPlan
    (orchestrator.plan) and a directory; the adapter itself holds only how the engine runs (its
    executable, MPI processes, checkpoint interval: the RunOptions), so one instance serves any
    number of runs, in any order."""

    name: str
    # The engine's checkpoint files are checkpoint.<step>.<ext> (engines.checkpoint); None: it writes none.
    checkpoint_ext: str | None

    @classmethod
    def from_options(cls, options: RunOptions) -> "EngineAdapter":
        """The adapter set up with the run options (MPI processes, say)."""
        ...

    def info(self) -> EngineInfo: ...

    def build_inputs(self) -> dict[str, str]:
        """Hashes of what turns a case into engine steps besides the engine itself: the deck templates
        and the code that writes and reads them (`inputs`), a compiled plugin (`plugin`). Part of every run id."""
        ...

    def warnings(self, plan: RunPlan) -> tuple[str, ...]:
        """What the engine cannot do exactly for this plan's case (recorded in run.json)."""
        ...

    def write_input(self, plan: RunPlan, rundir: Path) -> Path:
        """Render the deck (and its data files) of the plan's segment into rundir; return the deck path."""
        ...

    def execute(self, plan: RunPlan, rundir: Path, progress: ProgressCallback | None = None, timeout: float | None = None) -> None:
        """Run the deck of the plan's segment (written by write_input); its log is that segment's."""
        ...

    def read_output(self, plan: RunPlan, rundir: Path) -> Trajectory:
        """Every frame of every segment, once (engines.checkpoint.merge)."""
        ...

    def last_frame_step(self, plan: RunPlan, rundir: Path) -> int | None:
        """The step of the newest frame written by any segment (None: none yet)."""
        ...

    def usable_checkpoints(self, plan: RunPlan, rundir: Path) -> list[tuple[int, Path]]:
        """(step, path) of the sealed checkpoints a cut-off run may continue from, oldest first
        (engines.checkpoint; whether each still matches its seal is checked by the caller)."""
        ...

    def engine_summary(self, plan: RunPlan, rundir: Path) -> dict[str, object]:
        """What the engine reports of a finished run beyond its frames (run.json's `engine_summary`; {}: nothing)."""
        ...


class AdapterDefaults:
    """What most adapters share: the run options kept for checkpoints, the code that makes the deck
    as build inputs, no warnings."""

    name: str
    checkpoint_ext: str | None = None
    options: RunOptions | None = None  # None: the defaults (environment, else a checkpoint per tenth of the run)

    @classmethod
    def from_options(cls, options: RunOptions) -> "AdapterDefaults":
        adapter = cls()
        adapter.options = options
        return adapter

    def warnings(self, plan: RunPlan) -> tuple[str, ...]:
        return ()

    def engine_summary(self, plan: RunPlan, rundir: Path) -> dict[str, object]:
        return {}

    def checkpoint_steps(self, plan: RunPlan) -> int | None:
        """Steps between checkpoints for this plan (None: none), from the run options."""
        from orchestrator.engines.options import RunOptions

        if self.checkpoint_ext is None:
            return None
        schedule = plan.schedule
        return (self.options or RunOptions()).checkpoint_steps(plan.case.time.duration, schedule.dt, schedule.output_every,
                                                               schedule.total_steps)

    def usable_checkpoints(self, plan: RunPlan, rundir: Path) -> list[tuple[int, Path]]:
        """(step, path) of the sealed checkpoints a cut-off run may continue from, oldest first."""
        from orchestrator.engines import checkpoint

        return checkpoint.usable(rundir, self.checkpoint_ext or "")

    @staticmethod
    def log_name(plan: RunPlan) -> str:
        """The engine log of the plan's segment: engine.log, engine.1.log, …"""
        from orchestrator.engines.checkpoint import segment_name

        return segment_name(LOG_NAME, plan.segment)

    def build_inputs(self) -> dict[str, str]:
        from orchestrator.engines.templating import template_hash

        return {"inputs": template_hash(self.name)}


def log_tail(path: Path, size: int = 16384) -> list[str]:
    """The lines of the last `size` bytes of an engine log ([] when there is none): read from the end,
    however long the log."""
    if not path.is_file():
        return []
    with path.open("rb") as handle:
        handle.seek(max(0, path.stat().st_size - size))
        return handle.read().decode("utf-8", "replace").splitlines()


def die_with_parent() -> None:
    """Ask Linux to SIGKILL this process when its parent dies, so no engine outlives a killed campaign."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, 9)  # PR_SET_PDEATHSIG, SIGKILL
    except (OSError, AttributeError):
        pass  # not Linux: engines may outlive a killed orchestrator


def require_executable(name: str, install_hint: str) -> str:
    path = shutil.which(name)
    if path is None:
        raise EngineError(f"the engine executable {name!r} was not found on PATH; install it with: {install_hint}")
    return path


class _LogScan:
    """Reads an engine's output line by line: the tail, the first failure line with the lines around
    it, the simulated time for progress, and how much it wrote since the simulation last advanced."""

    def __init__(self, markers: tuple[str, ...], parse_progress: Callable[[str], float | None],
                 progress: ProgressCallback | None, end_time: float):
        self.markers, self.parse_progress, self.progress, self.end_time = markers, parse_progress, progress, end_time
        self.tail: deque[str] = deque(maxlen=TAIL_LINES)
        self.failure: str | None = None
        self.context: list[str] | None = None  # the lines around the first failure line
        self.simulated = -math.inf
        self.advanced_at = time.monotonic()
        self.bytes_since_advance = 0

    def feed(self, line: str) -> None:
        self.bytes_since_advance += len(line) + 1
        self.tail.append(line)
        stripped = line.lstrip()
        if self.failure is None and any(stripped.startswith(marker) for marker in self.markers):
            self.failure = stripped
            self.context = list(self.tail)[-CONTEXT_BEFORE:]  # what led to it; the lines after it follow
        elif self.context is not None and len(self.context) < CONTEXT_BEFORE + CONTEXT_AFTER:
            self.context.append(line)
        simulated = self.parse_progress(line)
        if simulated is not None:
            if not math.isfinite(simulated):
                self.failure = self.failure or f"non-finite value in engine output: {stripped}"
                return
            if simulated > self.simulated:
                self.simulated, self.advanced_at, self.bytes_since_advance = simulated, time.monotonic(), 0
            if self.progress is not None:
                self.progress(simulated, self.end_time)


class _Watchdog:
    """Stops an engine that runs away: one that writes more than MAX_LOG_WITHOUT_PROGRESS bytes of log
    without its simulated time advancing (an engine looping on a warning fills a disk in minutes), or
    whose simulated time has not advanced for `stall` seconds. The reason is kept for the error."""

    def __init__(self, scan: _LogScan, process: subprocess.Popen, stall: float | None):
        self.scan, self.process, self.stall = scan, process, stall
        self.reason: str | None = None
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True) if stall else None
        if self._thread is not None:
            self._thread.start()

    def check_output(self) -> None:
        """Called for each line read."""
        if self.reason is None and self.scan.bytes_since_advance > MAX_LOG_WITHOUT_PROGRESS:
            self._stop(f"wrote {self.scan.bytes_since_advance / 2**20:.0f} MiB of log without its simulated time advancing and was stopped")

    def _watch(self) -> None:
        while not self._done.wait(min(5.0, self.stall)):
            if time.monotonic() - self.scan.advanced_at > self.stall:
                self._stop(f"made no progress for {self.stall:.0f} s (${STALL_ENV}) and was stopped")
                return

    def _stop(self, reason: str) -> None:
        self.reason = reason
        self.process.kill()

    def close(self) -> None:
        self._done.set()


def stall_seconds() -> float | None:
    """${STALL_ENV}: seconds without progress after which an engine is stopped (0: never); default STALL_S."""
    value = os.environ.get(STALL_ENV, "").strip()
    try:
        seconds = float(value) if value else STALL_S
    except ValueError:
        seconds = STALL_S
    return seconds if math.isfinite(seconds) and seconds > 0 else None


def run_engine(
    command: list[str],
    rundir: Path,
    deck: Path,
    parse_progress: Callable[[str], float | None],
    end_time: float,
    progress: ProgressCallback | None = None,
    env: dict[str, str] | None = None,
    timeout: float | None = None,
    failure_markers: tuple[str, ...] = ("ERROR",),
    log_name: str = LOG_NAME,
) -> list[str]:
    """Run an engine, streaming its output to engine.log; raise EngineError on any sign of failure.

    Failure: non-zero exit, a line starting with one of `failure_markers`, or a progress value
    that is not finite. Returns the log tail for callers that check more (lost bodies, say).
    """
    log_path = rundir / log_name
    scan = _LogScan(failure_markers, parse_progress, progress, end_time)
    timed_out = threading.Event()
    with open(log_path, "w", encoding="utf-8") as log:
        log.write(f"# command: {' '.join(command)}\n")
        log.flush()
        try:
            process = subprocess.Popen(command, cwd=rundir, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                       text=True, errors="replace", env=env, bufsize=1, preexec_fn=die_with_parent)
        except OSError as error:
            raise EngineError(f"could not start {command[0]}: {error.strerror}", deck, log_path) from None
        assert process.stdout is not None
        timer = threading.Timer(timeout, lambda: (timed_out.set(), process.kill())) if timeout else None
        if timer is not None:
            timer.start()
        watchdog = _Watchdog(scan, process, stall_seconds())
        written = 0
        for line in process.stdout:
            if written < MAX_LOG_BYTES:  # the log is capped; the scan (tail, failure, progress) still sees every line
                log.write(line if written + len(line) < MAX_LOG_BYTES else f"# log capped at {MAX_LOG_BYTES // 2**20} MiB here\n")
                written += len(line)
            scan.feed(line.rstrip("\n"))
            watchdog.check_output()
        returncode = process.wait()
        watchdog.close()
        if timer is not None:
            timer.cancel()
    # A failed run's tail shows the lines around what went wrong, not the engine's closing statistics.
    _raise_on_failure(scan.failure or watchdog.reason, timeout if timed_out.is_set() else None, returncode, command, deck, log_path,
                      scan.context or list(scan.tail))
    return list(scan.tail)


def _raise_on_failure(failure: str | None, timed_out_after: float | None, returncode: int, command: list[str], deck: Path,
                      log_path: Path, tail: list[str]) -> None:
    if timed_out_after is not None:
        failure = f"timed out after {timed_out_after:.0f} s and was stopped"
    if failure is None and returncode != 0:
        failure = f"{Path(command[0]).name} exited with status {returncode}"
    if failure is not None:
        raise EngineError(f"engine run failed: {failure}", deck, log_path, tail)
