"""`demorch avalanche` and `demorch demo`: a brick avalanche study, its report and its table."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any, Callable

import click
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from orchestrator.case import CaseError
from orchestrator.validation import with_engine
from orchestrator.cli.common import REPO_ROOT, console, fail, progress_callback, run_options
from orchestrator.engines import ENGINE_NAMES, EngineError
from orchestrator.results import RELEASE_DIR, read_results
from orchestrator.runner import RESULTS

DEMO_STUDY = REPO_ROOT / "cases" / "avalanche" / "small.yaml"


def write_study_report(outdir: Path, report: dict[str, Any], slope_deg: float) -> Path:
    """Plots, snapshots, VTK and index.html for a study directory; returns the page."""
    from orchestrator.results import safe_output_path
    from orchestrator.studies.avalanche import report as pictures
    from orchestrator.studies.avalanche.study import KIND
    from orchestrator.studies.reference import load_reference

    trajectory = read_results(outdir / RELEASE_DIR / RESULTS)
    figures = safe_output_path(outdir, "report")  # a link named report would take the figures out of the study directory
    figures.mkdir(exist_ok=True)
    for entry in list(figures.iterdir()):  # the writers below open their files by name: no link there may lead them out
        safe_output_path(figures, entry.name)
    brick = KIND.parse(report["study"], str(outdir / "report.json")).brick_spec.build()  # the kind the run used
    pictures.plot_deposit(trajectory, brick, figures / "deposit.png", slope_deg)
    pictures.plot_front(report, figures / "front.png")
    snapshots = pictures.plot_snapshots(trajectory, figures, slope_deg=slope_deg)
    pictures.export_vtk(trajectory, figures, every=max(1, trajectory.n_frames // 20))
    chains = [figures / "force_chains.png"] if trajectory.contacts is not None else []
    if chains:
        pictures.plot_force_chains(trajectory, chains[0])
    rows = pictures.comparison_rows(report, load_reference(), demo_ranges(report))
    return pictures.write_html(figures, outdir.name, rows, [figures / "deposit.png", *chains, figures / "front.png", *snapshots])


def demo_ranges(report: dict[str, Any]) -> dict[str, Any] | None:
    """The study's code's ranges for the demo (validation record) when `report` is the demo's set-up
    (its geometry and volume), else None."""
    from orchestrator.studies.validation_page import demo_reference

    study = report.get("study", {})
    return demo_reference() if (study.get("geometry"), study.get("packing", {}).get("volume")) == _demo_set_up() else None


@functools.lru_cache(maxsize=1)
def _demo_set_up() -> tuple[dict[str, Any], float]:
    """The demo's geometry (as a report records it) and packing volume, read once."""
    from orchestrator.studies.avalanche.study import load_study

    demo = load_study(DEMO_STUDY)
    return demo.geometry.model_dump(mode="json"), demo.packing.volume


def study_table(title: str, report: dict[str, Any]) -> Table:
    from orchestrator.studies.reference import load_reference
    from orchestrator.studies.avalanche.report import comparison_rows

    table = Table(title=title, header_style="bold")
    for column in ("metric", "value", "reference", "check"):
        table.add_column(column, justify="right" if column == "value" else "left")
    for name, value, reference, verdict in comparison_rows(report, load_reference(), demo_ranges(report)):
        table.add_row(name, f"{value:.4g}", reference, verdict)
    return table


@click.command()
@click.argument("study_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the study's engine.")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Study directory (default runs/NAME-ENGINE).")
@click.option("--packings", type=click.Path(file_okay=False, path_type=Path), help="Where settled packings are kept and reused (default: beside the study directory, in packings/).")
def avalanche(study_path: Path, engine: str | None, output: Path | None, packings: Path | None = None) -> None:
    """Pack bricks (or reuse the same packing), release them down the slope, report deposit and front against the references."""
    from orchestrator.studies.avalanche.study import load_study, run_study

    try:
        study = with_engine(load_study(study_path), engine)
        outdir = output or Path("runs") / f"{study.name}-{study.engine.value}"
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
    if report.get("set_aside"):
        console.print(f"[yellow]set aside[/] what {outdir} held before ({report['set_aside']['why']}): {report['set_aside']['attic']}")
    if report.get("finished_before"):
        console.print(f"already complete in {outdir / 'run'} (delete that directory to run it again); measured again")
    if packing.get("directory"):
        console.print(f"packing: {'reused' if packing.get('reused') else 'made'} {packing['directory']}")
    for trial in packing.get("trials", []):
        if trial.get("set_aside"):
            console.print(f"[yellow]set aside[/] an earlier packing {trial['directory']} ({trial['set_aside']['why']}): {trial['set_aside']['attic']}")
    if packing.get("warning"):
        console.print(f"[yellow]warning:[/] {packing['warning']}")
    lost = int(report.get("deposit", {}).get("bodies_lost", 0))
    if lost:
        console.print(f"[yellow]warning:[/] {lost} of {packing.get('bricks', '?')} bricks left the boards over an edge during the release "
                      "(counted as lost, in no other figure; longer or wider boards keep them)")
    try:
        page = write_study_report(outdir, report, study.geometry.slope_deg)
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
    context.invoke(avalanche, study_path=DEMO_STUDY, engine=engine, output=output, packings=packings)
