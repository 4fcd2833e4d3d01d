"""`demorch parity`: the engine parity matrix (orchestrator.parity), as a table and as Markdown."""

from __future__ import annotations

import tempfile
from pathlib import Path

import click
from rich.table import Table

from orchestrator.cli.common import EXIT_ENGINE, console, fail, writable_rundir
from orchestrator.rundir import write_text_atomic
from orchestrator.engines import ENGINE_NAMES, EngineError, get_adapter


@click.command()
@click.option("--engine", "-e", "engines", type=click.Choice(ENGINE_NAMES), multiple=True,
              help="Engines to compare (repeatable; default: every installed engine).")
@click.option("--markdown", type=click.Path(dir_okay=False, path_type=Path), help="Also write the table as Markdown here (e.g. docs/parity.md).")
@click.option("--workdir", type=click.Path(file_okay=False, path_type=Path), help="Keep the micro-runs here (default: a temporary directory).")
def parity(engines: tuple[str, ...], markdown: Path | None, workdir: Path | None) -> None:
    """Run every micro-case of the parity matrix on each engine that supports it (about a minute):
    restitution on walls, meshes and clumps, spin in free flight, friction, leaving the domain.
    Exit 3 when a case misses that is not a known gap of its engine."""
    from orchestrator import parity as matrix

    if markdown is not None:  # before the run, not after it: a folder missing or not writable is one line now
        if markdown.is_dir():
            fail(f"--markdown: {markdown} is a folder; give a file name (e.g. {markdown / 'parity.md'})")
        if not markdown.parent.is_dir():
            fail(f"--markdown: the folder {markdown.parent} does not exist; make it first, or give a path in an existing folder")
        writable_rundir(markdown.parent, "--markdown")
    infos = {name: get_adapter(name).info() for name in (engines or ENGINE_NAMES)}
    chosen = tuple(name for name, info in infos.items() if info.executable)
    if not chosen:
        fail(f"none of {', '.join(infos)} is installed (`demorch doctor` says what is missing)")
    table = Table(title="engine parity", header_style="bold")
    for column in ("case", "engine", "quantity", "expected", "measured", ""):
        table.add_column(column)

    def show(outcome: matrix.Outcome) -> None:
        case = matrix.CASES[outcome.case]
        verdict = "[green]ok[/]" if outcome.passed else ("[yellow]known gap[/]" if outcome.known_gap else "[red]MISS[/]")
        table.add_row(case.name, outcome.engine, case.quantity, f"{case.expected:g}", f"{outcome.measured:.4g}", verdict)

    try:
        with tempfile.TemporaryDirectory(prefix="demorch-parity-") as scratch, console.status("running the micro-cases"):
            outcomes = matrix.run_matrix(chosen, workdir or Path(scratch), on_outcome=show)
    except EngineError as error:
        fail(str(error), code=EXIT_ENGINE)
    console.print(table)
    if markdown:
        write_text_atomic(markdown, matrix.markdown(outcomes, chosen, {name: infos[name].version or "" for name in chosen}))
        console.print(f"table: {markdown}")
    misses = [o for o in outcomes if not o.passed and not o.known_gap]
    if misses:
        fail(f"{len(misses)} unexpected misses: " + "; ".join(f"{o.case} on {o.engine}" for o in misses), code=EXIT_ENGINE)
