"""What every `demorch` command shares: the consoles, the error exit, progress bars, tables."""

from __future__ import annotations

import datetime as dt
import errno
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable, NoReturn

import click
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from orchestrator.engines import RunOptions
from orchestrator.results import RELEASE_DIR, RESULTS
from orchestrator.rundir import Busy, read_record
from orchestrator.validation import bounded

def run_options() -> RunOptions:
    """How engines run (`demorch --mpi N`), kept by the main command for its subcommands."""
    context = click.get_current_context(silent=True)
    options = context.find_root().obj if context is not None else None
    return options if isinstance(options, RunOptions) else RunOptions()


# Exit codes (docs/troubleshooting.md): 2 invalid input, 3 engine failure, 4 plugin build failure,
# 5 damaged results, 1 anything unexpected (`demorch --debug …` shows its traceback).
EXIT_INVALID, EXIT_ENGINE, EXIT_BUILD, EXIT_DAMAGED, EXIT_UNEXPECTED = 2, 3, 4, 5, 1
# What reading a damaged result raises: truncated or random HDF5 (OSError), missing datasets or keys
# (KeyError), garbage JSON or arrays of the wrong shape (ValueError), the wrong types (TypeError).
DAMAGE = (OSError, KeyError, ValueError, TypeError, IndexError, AttributeError)

console = Console(stderr=False)
errors = Console(stderr=True)

REPO_ROOT = Path(__file__).resolve().parents[2]


# Conditions of the machine a user can fix (a place not writable, no space, a name too long, a
# folder missing): one line naming the path and what to do, exit 2; anything else stays unexpected.
_FIXES = {
    errno.ENAMETOOLONG: "a file name there is longer than the file system allows (255 bytes a name): choose a shorter one",
    errno.EROFS: "that file system is read-only: choose a writable place",
    errno.EACCES: "not permitted there: choose a place you can write",
    errno.EPERM: "not permitted there: choose a place you can write",
    errno.ENOSPC: "no space left there: free some or choose another place (what finished is kept)",
    errno.EDQUOT: "the disk quota is exhausted there: free some or choose another place (what finished is kept)",
    errno.ENOENT: "no such file or folder: make the folder first, or give an existing path",
    errno.ENOTDIR: "a part of that path is a file, not a folder: choose another path",
}


def os_condition(error: OSError) -> str | None:
    """One line for an OS error a user can fix (_FIXES), or None."""
    fix = _FIXES.get(error.errno or -1)
    if fix is None:
        return None
    where = error.filename if error.filename is not None else "a file"
    return f"{bounded(str(where), 160)}: {error.strerror or fix.split(':')[0]}; {fix}"


DEBUG = [False]  # `demorch --debug …`: tracebacks instead of one line (set by the entry point)


class OneLineErrors(click.Group):
    """A command group whose usage errors (unknown option, bad choice, missing argument) print one
    line, `error: …`, like every other error, instead of click's usage block; exit code 2."""

    def main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
        if not standalone_mode:
            return super().main(*args, standalone_mode=False, **kwargs)
        try:
            code = super().main(*args, standalone_mode=False, **kwargs)
        except click.exceptions.Abort:
            fail("interrupted", code=EXIT_UNEXPECTED)
        except Busy as error:  # a study's or a release's run directory held by another demorch: usage, not a fault
            fail(f"{error}; wait for that run or use another -o")
        except OSError as error:  # a condition of the machine the user can fix: one line; anything else stays unexpected
            line = os_condition(error)
            if line is None or DEBUG[0]:
                raise
            fail(line)
        except click.ClickException as error:
            where = f" (see `{error.ctx.command_path} --help`)" if getattr(error, "ctx", None) is not None else ""
            fail(f"{error.format_message()}{where}", code=error.exit_code)
        sys.exit(code if isinstance(code, int) else 0)


def fail(message: str, code: int = 2) -> NoReturn:
    errors.print(f"[bold red]error:[/] {message}", markup=True, highlight=False, soft_wrap=True)
    sys.exit(code)


def damaged(where: Path, what: str, error: Exception) -> NoReturn:
    """Fail with one line (exit 5): `where: what (the error, bounded); rerun the case`."""
    fail(f"{where}: {what} ({bounded(f'{type(error).__name__}: {error}', 200)}); rerun the case", code=EXIT_DAMAGED)


def warn(message: str) -> None:
    """One line on stderr: what a valid input gets that differs from what it asked."""
    errors.print(f"[yellow]warning:[/] {message}", markup=True, highlight=False, soft_wrap=True)


MAX_TIMEOUT = 1e7  # s of wall time, about 16 weeks


def writable_rundir(directory: Path, option: str = "--output") -> None:
    """Create the output directory `directory` (given as `option`) and check that files can be written
    in it, or fail with one line (exit 2): a read-only file system or directory is the user's to fix,
    before any engine."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory):
            pass
    except OSError as error:
        fail(f"{option}: cannot write in {directory} ({error.strerror or error}); choose a writable directory")


def results_path(directory: Path) -> Path:
    """results.h5 of a run directory, or of a study directory's release (its run/); without one, fail
    with one line (exit 2) naming the run's recorded status."""
    for candidate in (directory, directory / RELEASE_DIR):
        if (candidate / RESULTS).exists():
            return candidate / RESULTS
    record = read_record(directory) or {}
    fail(f"{directory} has no {RESULTS} (run status: {bounded(str(record.get('status', 'unknown')), 40)})")


def default_rundir(case_name: str, engine: str) -> Path:
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("runs") / f"{case_name}-{engine}-{stamp}"


def study_notes(report: dict[str, Any], outdir: Path) -> None:
    """What a study's report says of how it ran, one line each: what was set aside, and the stages
    that continued from a checkpoint of a run cut off earlier."""
    if report.get("set_aside"):
        console.print(f"[yellow]set aside[/] what {outdir} held before ({report['set_aside']['why']}): {report['set_aside']['attic']}")
    for stage, resumed in report.get("resumed", {}).items():
        console.print(f"{stage}: continued from the checkpoint of a run cut off earlier ({resumed['segments']} segments; "
                      f"{resumed['simulated_time_lost_s']:.3g} s of simulated time computed twice)")


def progress_callback(progress: Progress, task: Any) -> Callable[[float, float], None]:
    def update(simulated: float, end: float) -> None:
        progress.update(task, completed=simulated, total=end, description=f"t = {simulated:.4g} / {end:.4g} s")

    return update


def metrics_table(title: str, values: dict[str, float]) -> Table:
    table = Table(title=title, show_header=True, header_style="bold")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, value in values.items():
        table.add_row(key, f"{value:.6g}")
    return table
