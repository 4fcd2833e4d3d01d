"""`demorch`: render decks, run cases, check the installation, summarise results.

One module per command group: main (this: run, render, post, doctor, brick, build-contact),
avalanche (avalanche, demo), campaign, collapse, paraview, submit (submit, status, slurm-job: SLURM);
common holds what they share.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import click
import numpy as np
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from orchestrator.case import CaseError, load_case
from orchestrator.results import CAMPAIGN_RECORD, read_json
from orchestrator.validation import with_engine
from orchestrator.cli.avalanche import avalanche, demo, study_table
from orchestrator.cli.campaign import campaign
from orchestrator.cli.collapse import collapse
from orchestrator.cli.parity import parity
from orchestrator.cli.paraview import paraview
from orchestrator.cli.validation_page import validation
from orchestrator.cli.schema import schema_command
from orchestrator.cli.submit import slurm_job, status, submit
from orchestrator.cli import common
from orchestrator.cli.common import (DAMAGE, EXIT_ENGINE, EXIT_UNEXPECTED, MAX_TIMEOUT, OneLineErrors, console, damaged, errors, default_rundir, fail,
                                     metrics_table, progress_callback, results_path, run_options, warn, writable_rundir)
from orchestrator.engines import ENGINE_NAMES, ContactBuildError, EngineError, engines_with, get_adapter
from orchestrator.engines.options import CHECKPOINT_ENV, MPI_ENV, RunOptions, check_interval
from orchestrator import preflight
from orchestrator.estimate import check_machine
from orchestrator.plan import RunPlan, make_plan
from orchestrator.post import summary as metrics
from orchestrator.post.lost import NoBodyLeft
from orchestrator.results import REPORT, read_results
from orchestrator.validation import bounded
from orchestrator.results import RESULTS
from orchestrator.runner import refuse_foreign, render_case, resume_point, run_case
from orchestrator.rundir import is_locked as rundir_lock_held
from orchestrator import rundir as rundir_module
from orchestrator.capabilities import brick_gaps, capabilities


def _run(case_path: Path, engine: str | None, output: Path | None, timeout: float | None) -> dict[str, Any]:
    try:
        case = with_engine(load_case(case_path), engine)
        plan = make_plan(case, case_path.parent)  # the pre-flight checks, before the progress bar: a bad case is one line
        options = _options_for(plan)
        rundir = output or default_rundir(case.name, case.engine.value)
        refuse_foreign(rundir)
        if (rundir / RESULTS).exists():
            fail(f"{rundir} already holds a completed run; choose another -o (nothing was overwritten)")
        writable_rundir(rundir)  # first: a read-only place (/proc, say) has no free space either
        large = check_machine(plan.output, rundir)
        if large:
            warn(large)
        if rundir_lock_held(rundir):
            raise rundir_module.Busy(str(rundir))
        resume = resume_point(plan, rundir)
        if resume is not None:
            console.print(f"{rundir}: resuming from the checkpoint at t = {resume.step * plan.schedule.dt:.4g} s "
                          f"(segment {resume.segment}; the run was cut off)")
        with Progress(
            TextColumn(f"[bold]{case.name}[/] on {case.engine.value}"),
            BarColumn(),
            TextColumn("{task.description}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=console,
            transient=False,
        ) as progress:
            task = progress.add_task("starting", total=case.time.duration)
            record = run_case(case, case_path.parent, rundir, progress=progress_callback(progress, task), timeout=timeout, options=options,
                              plan=plan)
    except CaseError as error:
        fail(str(error))
    except rundir_module.Busy:
        fail(f"--output: {rundir} is in use by another run (its lock is held); wait for that run or choose another -o")
    except EngineError as error:
        fail(str(error), code=3)
    console.print(metrics_table(f"{case.name} on {record['engine']} ({record['wall_time_s']:.2f} s wall)", record["metrics"]))
    for warning in record.get("warnings", []):
        warn(warning)
    console.print(f"results: {rundir / RESULTS}")
    return record


def _options_for(plan: RunPlan) -> RunOptions:
    """The command's run options for the plan's case (MPI processes checked, and capped at one per
    body), the case's notes (an output interval rounded to whole steps) printed as one-line warnings."""
    options, capped = run_options().for_bodies(len(plan.bodies))
    for note in preflight.notes(plan.case, plan.schedule) + ([capped] if capped and capabilities(plan.case.engine).mpi else []):
        warn(note)
    return options


def _timeout(value: float | None) -> float | None:
    if value is not None and not 0.0 < value <= MAX_TIMEOUT:  # NaN too
        raise click.BadParameter(f"must be seconds of wall time; allowed range: (0, {MAX_TIMEOUT:g}] (got {value!r})")
    return value


def _interval(value: str | None) -> float | None:
    try:
        return None if value is None else check_interval(value, "--checkpoint-interval")
    except CaseError as error:
        raise click.BadParameter(str(error).split(": ", 1)[1]) from None


@click.group(cls=OneLineErrors, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="dem-orchestrator")
@click.option("--mpi", type=click.IntRange(1, 256), default=None, metavar="N",
              help=f"Run each engine that can split a run over MPI (LIGGGHTS) as `mpirun -np N` (default: ${MPI_ENV}, else 1; "
                   "cases and results do not change).")
@click.option("--checkpoint-interval", default=None, metavar="SECONDS", callback=lambda context, parameter, value: _interval(value),
              help=f"Simulated seconds between checkpoints of each run, 0 for none (default: ${CHECKPOINT_ENV}, else a tenth of the run). "
                   "A run cut off mid-way continues from its last checkpoint when run again.")
@click.pass_context
def main(context: click.Context, mpi: int | None, checkpoint_interval: float | None) -> None:
    """Run LIGGGHTS, YADE and cocd from one validated case file."""
    context.obj = RunOptions(mpi_processes=mpi, checkpoint_interval=checkpoint_interval)


@main.command()
@click.argument("case_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the case's engine.")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), required=True, help="Directory for the deck.")
def render(case_path: Path, engine: str | None, output: Path) -> None:
    """Write the engine deck for CASE_PATH without running it."""
    try:
        case = with_engine(load_case(case_path), engine)
        deck = render_case(case, case_path.parent, output)
    except CaseError as error:
        fail(str(error))
    console.print(f"deck written: {deck}")


@main.command("run")
@click.argument("case_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the case's engine.")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Run directory (default runs/NAME-ENGINE-TIME).")
@click.option("--timeout", type=float, default=None, callback=lambda context, parameter, value: _timeout(value),
              help="Stop the engine after this many seconds of wall time.")
def run_command(case_path: Path, engine: str | None, output: Path | None, timeout: float | None) -> None:
    """Run CASE_PATH and collect results.h5 and run.json."""
    _run(case_path, engine, output, timeout)


@main.command()
@click.argument("rundir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the metrics as JSON.")
def post(rundir: Path, as_json: bool) -> None:
    """Print summary metrics of a finished run (or avalanche study) directory."""
    try:
        _post(rundir, as_json)
    except CaseError as error:
        fail(str(error))
    except NoBodyLeft as error:  # intact results of a run that lost every body: the engine's outcome, not damage
        fail(f"{rundir}: {error}; rerun with a larger `domain:`", code=EXIT_ENGINE)
    except DAMAGE as error:  # a truncated, empty or foreign file where a result should be
        damaged(rundir, "damaged results", error)


def _post_campaign(directory: Path) -> None:
    """A study over seeds or a campaign directory: each point's table over its seeds, written again
    (cli.ensemble), or one line saying where its runs' own reports are."""
    from orchestrator.cli.ensemble import report_ensembles

    name = str((read_json(directory / CAMPAIGN_RECORD) or {}).get("name", directory.name))
    kinds = {str((read_json(run / "run.json") or {}).get("kind", "case")) for run in sorted((directory / "runs").glob("*"))[:50]}
    kind = next(iter(kinds - {"case"}), "case")
    if kind == "case" or not report_ensembles(directory, kind, name, always=True) and not (directory / "ensemble.md").exists():
        fail(f"{directory} is a campaign directory: `demorch campaign table {directory}` lists its runs; `demorch post` one of {directory / 'runs'}/<id>")


def _post(rundir: Path, as_json: bool) -> None:
    if (rundir / CAMPAIGN_RECORD).exists() and not (rundir / REPORT).exists():  # a study over seeds or a campaign
        _post_campaign(rundir)
        return
    if (rundir / REPORT).exists():
        report = json.loads((rundir / REPORT).read_text())
        from orchestrator.studies.avalanche.report import write_report

        page = write_report(rundir, report)
        if as_json:
            console.print_json(json.dumps({"deposit": report["deposit"], "packing": report.get("packing")}))
        else:
            console.print(study_table(rundir.name, report))
            console.print(f"report: {page}")
        return
    trajectory = read_results(results_path(rundir))
    values = metrics.summary(trajectory)
    if as_json:
        console.print_json(json.dumps(values))
    else:
        console.print(metrics_table(f"{rundir} ({trajectory.attrs.get('engine', '?')})", values))


@main.command()
def doctor() -> None:
    """Check engines, the contact-law plugin and the Python side; print what is missing."""
    table = Table(title="dem-orchestrator doctor", header_style="bold")
    table.add_column("component")
    table.add_column("status")
    table.add_column("details")
    healthy = True
    for name in ENGINE_NAMES:
        info = get_adapter(name).info()
        if info.executable:
            table.add_row(name, "[green]ok[/]", f"{info.executable} (version {info.version or 'unknown'})")
        else:
            healthy = False
            table.add_row(name, "[red]missing[/]", f"install: {info.install_hint}")
    for name in engines_with(compiled_law=True):
        status = get_adapter(name).law_plugin_status()
        built = bool(status.get("built"))
        details = str(status.get("path")) if built else "not built yet: run `demorch build-contact`"
        table.add_row(f"bilinear law plugin ({name})", "[green]built[/]" if built else "[yellow]not built[/]", details)
        if "superquadric_built" in status:  # an engine build of its own for one-atom bodies (superquadrics, rounded boxes)
            built = bool(status["superquadric_built"])
            details = str(status["superquadric_executable"]) if built else "not built yet: run `demorch build-contact` (about 6 min)"
            table.add_row(f"superquadric and rounded-box bodies ({name})", "[green]built[/]" if built else "[yellow]not built[/]", details)
    for name in ENGINE_NAMES:  # what each engine's avalanche brick misses against the study's code
        gaps = brick_gaps(name)
        if gaps:
            table.add_row(f"avalanche brick ({name})", f"[yellow]{capabilities(name).preferred_brick}: {len(gaps)} gap(s)[/]", "; ".join(gaps))
    from orchestrator.studies.reference import PACKAGED_REFERENCE, reference_path

    reference = reference_path()
    origin = "packaged copy" if reference == PACKAGED_REFERENCE else "project"
    table.add_row("reference numbers", "[green]found[/]" if reference.is_file() else "[red]missing[/]", f"{reference} ({origin})")
    console.print(table)
    if not healthy:
        sys.exit(1)


@main.command()
@click.option("--layout", "layouts", type=(int, int, int), multiple=True, help="Spheres along length, width, thickness (repeatable). Default: 4 2 1, 8 2 1, 6 3 2, 12 6 2.")
@click.option("--bevel", "bevel_deg", type=click.FloatRange(0.0, 10.0), default=0.0, show_default=True, help="Turn of three faces, degrees (2 for the paper's modified bricks).")
@click.option("--size", type=(float, float, float), default=(0.031, 0.015, 0.008), show_default=True, help="Length, width, thickness (m).")
@click.option("--density", type=click.FloatRange(min=0.0, min_open=True), default=1700.0, show_default=True, help="kg/m³.")
def brick(layouts: tuple[tuple[int, int, int], ...], bevel_deg: float, size: tuple[float, float, float], density: float) -> None:
    """How well each clump resolution fits the brick: spheres, radii, surface gap, mass, inertia."""
    from orchestrator.shapes.clump import BrickClump

    if not all(math.isfinite(v) and 0.0 < v <= 1.0 for v in size):
        fail(f"--size: every dimension must be a number in (0, 1] m (got {size})")
    if not (math.isfinite(density) and density <= 1e5):
        fail(f"--density: must be a number in (0, 1e5] kg/m³ (got {density})")
    for layout in layouts:
        if not all(1 <= n <= 64 for n in layout):
            fail(f"--layout: each count must be in [1, 64] (got {layout})")
    table = Table(title=f"brick {size[0] * 1e3:g} × {size[1] * 1e3:g} × {size[2] * 1e3:g} mm, bevel {bevel_deg:g}°", header_style="bold")
    for column in ("layout", "spheres", "radius (mm)", "max / mean gap to the brick (mm)", "mass (g)", "I_x, I_y, I_z (kg m²)"):
        table.add_column(column)
    for layout in layouts or ((4, 2, 1), (8, 2, 1), (6, 3, 2), (12, 6, 2)):
        clump = BrickClump(*size, density, layout, bevel_deg)
        worst, mean = clump.surface_deviation()
        radii = f"{clump.radii.min() * 1e3:.2f}–{clump.radius * 1e3:.2f}" if np.ptp(clump.radii) > 1e-9 else f"{clump.radius * 1e3:.2f}"
        table.add_row(" × ".join(map(str, layout)), str(clump.n_spheres), radii, f"{worst * 1e3:.2f} / {mean * 1e3:.2f}",
                      f"{clump.mass * 1e3:.3f}", ", ".join(f"{i:.3g}" for i in clump.principal_inertia))
    console.print(table)


@main.command("build-contact")
@click.option("--force", is_flag=True, help="Rebuild even if a cached build exists.")
def build_contact(force: bool) -> None:
    """Build (or find in the cache) the compiled bilinear contact law of every engine that compiles it."""
    for name in engines_with(compiled_law=True):
        adapter = get_adapter(name)
        try:
            path = adapter.law_plugin(force=force, progress=lambda message: console.print(message))
        except ContactBuildError as error:
            fail(str(error), code=4)
        console.print(f"plugin ({name}): {path}")
        console.print_json(json.dumps(adapter.law_plugin_status(), default=str))


for command in (avalanche, demo, campaign, collapse, parity, paraview, validation, schema_command, submit, status, slurm_job):
    main.add_command(command)


def entry() -> None:
    """The `demorch` entry point: every path ends with one line and a documented exit code; an
    unexpected error too (exit 1), with its traceback only under `demorch --debug …`."""
    debug = "--debug" in sys.argv[1:]
    if debug:
        sys.argv.remove("--debug")
        common.DEBUG[0] = True
    try:
        main(standalone_mode=True)
    except Exception as error:  # noqa: BLE001 - the last guard before a user's terminal
        if debug:
            raise
        errors.print(f"[bold red]error:[/] unexpected {type(error).__name__}: {bounded(str(error), 200)} "
                     "(rerun with `demorch --debug …` for the traceback, and report it)", markup=True, highlight=False, soft_wrap=True)
        sys.exit(EXIT_UNEXPECTED)
