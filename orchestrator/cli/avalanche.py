"""`demorch avalanche` and `demorch demo`: a brick avalanche study, its report and its table."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import click
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from orchestrator.case import CaseError
from orchestrator.validation import with_engine
from orchestrator.cli.common import console, fail, progress_callback, run_options, study_notes
from orchestrator.engines import ENGINE_NAMES, EngineError
from orchestrator.studies.seeds import member_seeds


def study_table(title: str, report: dict[str, Any]) -> Table:
    """The study's rows (studies.avalanche.table) as a console table."""
    from orchestrator.studies.avalanche.table import study_rows

    table = Table(title=title, header_style="bold")
    for column in ("metric", "value", "reference", "check"):
        table.add_column(column, justify="right" if column == "value" else "left")
    for name, value, reference, verdict in study_rows(report):
        table.add_row(name, f"{value:.4g}", reference, verdict)
    return table


@click.command()
@click.argument("study_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the study's engine.")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Study directory (default runs/NAME-ENGINE).")
@click.option("--packings", type=click.Path(file_okay=False, path_type=Path), help="Where settled packings are kept and reused (default: beside the study directory, in packings/).")
@click.option("--jobs", "-j", type=click.IntRange(1, 1000), default=None, help="A study with seeds: seeds run at once (default: one per core).")
@click.option("--executor", type=click.Choice(["local", "dask"]), default="local", show_default=True, help="A study with seeds: where its seeds run.")
@click.option("--dask-address", help="A study with seeds: scheduler address of an existing Dask cluster.")
def avalanche(study_path: Path, engine: str | None, output: Path | None, packings: Path | None = None, jobs: int | None = None,
              executor: str = "local", dask_address: str | None = None) -> None:
    """Pack bricks (or reuse the same packing), release them down the slope, report deposit and front against the references.
    A study with `seeds:` runs each seed (in parallel, -j) and reports each seed, the mean and the range."""
    from orchestrator.studies.avalanche.report import write_report
    from orchestrator.studies.avalanche.study import KIND, load_study, run_study
    from orchestrator.studies.base import refuse_foreign

    try:
        study = with_engine(load_study(study_path), engine)
        outdir = output or Path("runs") / f"{study.name}-{study.engine.value}"
        if study.seeds is None:
            refuse_foreign(KIND, outdir)  # before the header: a directory of another kind, or in use, is one line
        if study.seeds is not None:
            from orchestrator.cli.ensemble import launch_ensemble

            console.print(f"[bold]{study.name}[/]: {study.brick_count} bricks, {study.packing.kind}, engine {study.engine.value}, "
                          f"{len(member_seeds(study.seed, study.seeds))} seeds → {outdir}")
            return launch_ensemble("avalanche", study_path, study.name, engine, outdir, jobs, executor, dask_address,
                                   packings or outdir.resolve().parent / "packings")
        console.print(f"[bold]{study.name}[/]: {study.brick_count} bricks, {study.packing.kind}, engine {study.engine.value} → {outdir}")
        with Progress(TextColumn("{task.fields[stage]}"), BarColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console) as progress:

            def stage(name: str) -> Callable[[float, float], None]:
                task = progress.add_task("starting", total=1.0, stage=name)
                return progress_callback(progress, task)

            report = run_study(study, outdir, progress=stage, packings=packings, options=run_options())
    except CaseError as error:
        fail(str(error))
    except EngineError as error:
        fail(str(error), code=3)
    packing = report.get("packing", {})
    study_notes(report, outdir)
    if report.get("finished_before"):
        console.print(f"already complete in {outdir / 'run'} (delete that directory to run it again); measured again")
    if packing.get("directory"):
        console.print(f"packing: {'reused' if packing.get('reused') else 'made'} {packing['directory']}")
    for trial in packing.get("trials", []):
        if trial.get("set_aside"):
            console.print(f"[yellow]set aside[/] an earlier packing {trial['directory']} ({trial['set_aside']['why']}): {trial['set_aside']['attic']}")
    if packing.get("warning"):
        console.print(f"[yellow]warning:[/] {packing['warning']}")
    for gap in report.get("brick_gaps", []):
        console.print(f"[yellow]warning:[/] this engine's {study.brick_spec.kind} brick misses the study's brick on brick: {gap}")
    lost = int(report.get("deposit", {}).get("bodies_lost", 0))
    if lost:
        console.print(f"[yellow]warning:[/] {lost} of {packing.get('bricks', '?')} bricks left the boards over an edge during the release "
                      "(counted as lost, in no other figure; longer or wider boards keep them)")
    try:
        page = write_report(outdir, report)
        console.print(study_table(f"{study.name} on {study.engine.value}", report))
    except CaseError as error:
        fail(f"{error} (the run itself is complete: {outdir / 'report.json'})")
    console.print(f"report: {page}")


@click.command()
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Engine (default: LIGGGHTS).")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Study directory.")
@click.option("--packings", type=click.Path(file_okay=False, path_type=Path), help="Where packings are kept and reused.")
@click.pass_context
def demo(context: click.Context, engine: str | None, output: Path | None, packings: Path | None) -> None:
    """A small brick avalanche (cases/avalanche/small.yaml): deposit and front against the references."""
    from orchestrator.studies.avalanche.study import DEMO_STUDY

    context.invoke(avalanche, study_path=DEMO_STUDY, engine=engine, output=output, packings=packings)
