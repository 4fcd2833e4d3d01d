"""`demorch campaign …`: run, follow, tabulate and plot parameter campaigns; calibrate."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path
from typing import Any, Callable

import click
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from orchestrator.case import CaseError
from orchestrator.cli.common import console, errors, fail, run_options

MAX_JOBS = 100_000  # runs at once (a campaign holds at most 100 000 points: campaign.spec.MAX_POINTS)


@click.group()
def campaign() -> None:
    """Sweeps, designs and calibrations over a base case."""


@campaign.command("run")
@click.argument("campaign_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Campaign directory (default runs/campaigns/NAME).")
@click.option("--jobs", "-j", type=click.IntRange(1, MAX_JOBS), default=None,
              help="Parallel engine processes (default: one per core), at most one per point to run.")
@click.option("--executor", type=click.Choice(["local", "dask"]), default="local", show_default=True)
@click.option("--dask-address", help="Scheduler address of an existing Dask cluster (e.g. started by dask-jobqueue).")
@click.option("--rerun-failed", is_flag=True, help="Run failed runs again (their attempt moves to the attic).")
def campaign_run(campaign_file: Path, output: Path | None, jobs: int | None, executor: str, dask_address: str | None, rerun_failed: bool) -> None:
    """Run every pending point of CAMPAIGN_FILE; completed runs are skipped, so relaunching resumes."""
    _launch(campaign_file, output, jobs, executor, dask_address, rerun_failed)


@campaign.command("slurm")
@click.argument("campaign_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Campaign directory, on a file system the nodes share (default runs/campaigns/NAME).")
@click.option("--walltime", required=True, help="Each job's wall-time limit, [D-]HH:MM:SS; a run cut off at a job's end continues in the next job from its checkpoint.")
@click.option("--jobs", "-j", type=click.IntRange(1, 10_000), required=True, help="Jobs queued or running at once (one run each; at most one per point to run).")
@click.option("--processes", type=click.IntRange(1, 256), default=1, show_default=True, help="CPUs per job: the MPI processes of a run (LIGGGHTS).")
@click.option("--memory", default="4GB", show_default=True, help="Memory per job.")
@click.option("--partition", help="SLURM partition (-p).")
@click.option("--account", help="SLURM account (-A).")
@click.option("--directive", "directives", multiple=True, help="More #SBATCH directives, e.g. --directive=--exclusive (repeatable).")
@click.option("--max-cuts", type=click.IntRange(1, 100_000), default=100, show_default=True, help="Times a run may be cut off by a job's end before it counts as failed.")
@click.option("--dry-run", is_flag=True, help="Print the job script and submit nothing.")
@click.option("--rerun-failed", is_flag=True, help="Run failed runs again (their attempt moves to the attic).")
@click.pass_context
def campaign_slurm(context: click.Context, campaign_file: Path, output: Path | None, walltime: str, jobs: int, processes: int, memory: str,
                   partition: str | None, account: str | None, directives: tuple[str, ...], max_cuts: int, dry_run: bool, rerun_failed: bool) -> None:
    """Run CAMPAIGN_FILE on SLURM through dask-jobqueue: JOBS jobs at a time, each one worker running one
    run; the scheduler runs here (keep this command alive, e.g. in tmux on the login node). Set the
    checkpoint interval with `demorch --checkpoint-interval S campaign slurm …`."""
    from orchestrator.campaign.slurm import SlurmJobs, job_script, start_cluster

    spec = SlurmJobs(walltime, jobs, processes, memory, partition, account, directives, run_options().checkpoint_interval, max_cuts)
    try:
        spec.check()
    except CaseError as error:
        fail(str(error))
    if dry_run:
        click.echo(job_script(spec))
        return

    def start(workers: int) -> Any:  # once the points to run are known: at most one job per point
        cluster = start_cluster(dataclasses.replace(spec, jobs=workers))
        console.print(f"SLURM jobs: {workers} × {processes} CPUs, {walltime} each; scheduler {cluster.scheduler_address}")
        return cluster

    _launch(campaign_file, output, jobs, "dask", None, rerun_failed, start)


def _launch(campaign_file: Path, output: Path | None, jobs: int | None, executor: str, dask_address: str | None, rerun_failed: bool,
            dask_cluster: Callable[[int], Any] | None = None) -> None:
    import os

    from orchestrator.campaign.execute import run_campaign
    from orchestrator.campaign.spec import load_campaign

    try:
        spec, base = load_campaign(campaign_file)
    except CaseError as error:
        fail(str(error))
    directory = output or Path("runs") / "campaigns" / spec.name
    workers = jobs or os.cpu_count() or 1
    failures: list[str] = []
    not_run: list[str] = []  # skipped for a reason other than being there already (running elsewhere, inputs changed)
    with Progress(TextColumn("[bold]{task.fields[name]}[/]"), BarColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console,
                  transient=True) as progress:  # the tally line below stays; an error stays one line
        task = progress.add_task("planning", total=None, name=spec.name)

        def update(counts: Any, summary: dict[str, Any] | None) -> None:
            eta = counts.eta_s()
            progress.update(
                task,
                total=counts.total,
                completed=counts.skipped + counts.done + counts.failed,
                description=f"done {counts.done}  running {counts.running}  failed {counts.failed}  remaining {counts.remaining}"
                + (f"  skipped {counts.skipped}" if counts.skipped else "")
                + (f"  ETA {eta:.0f} s" if eta is not None else ""),
            )
            if summary and summary["status"] == "failed":
                failures.append(f"{summary['run_id']}: {summary.get('error', '')}")
            elif summary and summary["status"] == "skipped" and summary.get("reason") not in ("completed", "failed", None):  # an earlier failure is counted below
                not_run.append(f"{summary['run_id']}: {summary['reason']}")

        try:
            counts = run_campaign(campaign_file, directory, workers, executor, rerun_failed, dask_address, on_update=update, options=run_options(),
                                  dask_cluster=dask_cluster)
        except CaseError as error:
            fail(str(error))
    for line in failures:
        errors.print(f"[red]failed[/] {line}", markup=True, highlight=False)
    for line in not_run:
        errors.print(f"[yellow]not run[/] {line}", markup=True, highlight=False)
    console.print(f"{directory}: {counts.done} run, {counts.skipped - len(not_run)} already there, "
                  + (f"{len(not_run)} not run (above), " if not_run else "") + f"{counts.failed} failed; index: {directory / 'index.parquet'}")
    from orchestrator.campaign.store import build_index

    index = build_index(directory)
    from orchestrator.campaign.spec import base_kind
    from orchestrator.cli.ensemble import report_ensembles

    report_ensembles(directory, base_kind(spec, base), spec.name)  # points run over several seeds: each seed, the mean, the range
    remaining = int((index["status"] == "failed").sum()) if not index.empty else 0
    if remaining:  # this launch's failures, and those of earlier launches it skipped
        errors.print(f"[red]{remaining} failed runs remain[/] (`demorch campaign table {directory}`; run them again with --rerun-failed)",
                     markup=True, highlight=False)
        sys.exit(3)


@campaign.command("calibrate")
@click.argument("calibration_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Calibration directory (default runs/calibrations/NAME).")
def campaign_calibrate(calibration_file: Path, output: Path | None) -> None:
    """Fit contact parameters to measured launches (E2 corner error); resumable, history kept."""
    from orchestrator.campaign.calibrate import calibrate, load_calibration

    try:
        spec_name = Path(calibration_file).stem
        directory = output or Path("runs") / "calibrations" / spec_name
        with console.status("calibrating (each evaluation is a real engine run)"):
            result = calibrate(load_calibration(calibration_file, directory))
    except CaseError as error:
        fail(str(error))
    console.print_json(json.dumps(result))
    console.print(f"history: {directory / 'history.jsonl'}  plot: {directory / 'convergence.png'}")


@campaign.command("status")
@click.argument("campaign_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
def campaign_status(campaign_dir: Path) -> None:
    """Counts of runs per status."""
    from orchestrator.campaign.store import build_index

    table = build_index(campaign_dir)
    counts = table["status"].value_counts().to_dict() if not table.empty else {}
    console.print(" ".join(f"{k}: {v}" for k, v in sorted(counts.items())) or "no runs")


@campaign.command("table")
@click.argument("campaign_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--csv", "csv_path", type=click.Path(path_type=Path), help="Also write the index as CSV.")
def campaign_table(campaign_dir: Path, csv_path: Path | None) -> None:
    """Print the index: parameters, status, wall time and metrics of every run."""
    from orchestrator.campaign.store import build_index

    table = build_index(campaign_dir)
    if csv_path:
        table.to_csv(csv_path, index=False)
    console.print(table.to_string(max_rows=200, max_colwidth=24))


@campaign.command("plot")
@click.argument("campaign_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--x", "x_name", required=True, help="Swept parameter for the x axis, e.g. contacts.1.en2")
@click.option("--y", "y_name", required=True, help="Swept parameter for the y axis.")
@click.option("--metric", required=True, help="Metric to contour, e.g. com_travel_x_m")
@click.option("--output", "-o", type=click.Path(path_type=Path), help="PNG path (default CAMPAIGN_DIR/METRIC.png).")
def campaign_plot(campaign_dir: Path, x_name: str, y_name: str, metric: str, output: Path | None) -> None:
    """Contour map of a metric over two swept parameters (a response surface, like the 2012 Fig. 7)."""
    from orchestrator.campaign.plots import response_surface
    from orchestrator.campaign.store import build_index

    table = build_index(campaign_dir)
    path = output or campaign_dir / f"{metric}.png"
    try:
        response_surface(table, x_name, y_name, metric, path)
    except KeyError as error:
        fail(f"no column {error} in the index; parameters are 'param.*', metrics 'metric.*'")
    console.print(f"plot: {path}")
