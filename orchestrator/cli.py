"""`demorch`: render decks, run cases, check the installation, summarise results."""

from __future__ import annotations

import datetime as dt
import json
import os
import sys
from pathlib import Path
from typing import Any, Callable

import click
import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from . import metrics
from .case import CaseError, load_case
from .engines import ENGINE_NAMES, MPI_ENV, EngineError, get_adapter
from .results import read_results
from .runner import RESULTS, render_case, run_case, with_engine

console = Console(stderr=False)
errors = Console(stderr=True)

REPO_ROOT = Path(__file__).resolve().parent.parent
DEMO_STUDY = REPO_ROOT / "cases" / "avalanche" / "small.yaml"


def _fail(message: str, code: int = 2) -> None:
    errors.print(f"[bold red]error:[/] {message}", markup=True, highlight=False, soft_wrap=True)
    sys.exit(code)


def _default_rundir(case_name: str, engine: str) -> Path:
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("runs") / f"{case_name}-{engine}-{stamp}"


def _progress_callback(progress: Progress, task: Any) -> Callable[[float, float], None]:
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


def _run(case_path: Path, engine: str | None, output: Path | None, timeout: float | None) -> dict[str, Any]:
    try:
        case = with_engine(load_case(case_path), engine)
        rundir = output or _default_rundir(case.name, case.engine.value)
        if (rundir / RESULTS).exists():
            _fail(f"{rundir} already holds a completed run; choose another -o (nothing was overwritten)")
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
            record = run_case(case, case_path.parent, rundir, progress=_progress_callback(progress, task), timeout=timeout)
    except CaseError as error:
        _fail(str(error))
    except EngineError as error:
        _fail(str(error), code=3)
    console.print(metrics_table(f"{case.name} on {record['engine']} ({record['wall_time_s']:.2f} s wall)", record["metrics"]))
    console.print(f"results: {rundir / RESULTS}")
    return record


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="dem-orchestrator")
@click.option("--mpi", type=click.IntRange(1, 256), default=None, metavar="N",
              help=f"Run each LIGGGHTS engine as `mpirun -np N` (same as {MPI_ENV}=N; cases and results do not change).")
def main(mpi: int | None) -> None:
    """Run LIGGGHTS and YADE from one validated case file."""
    if mpi is not None:
        os.environ[MPI_ENV] = str(mpi)


@main.command()
@click.argument("case_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the case's engine.")
@click.option("--output", "-o", type=click.Path(path_type=Path), required=True, help="Directory for the deck.")
def render(case_path: Path, engine: str | None, output: Path) -> None:
    """Write the engine deck for CASE_PATH without running it."""
    try:
        case = with_engine(load_case(case_path), engine)
        deck = render_case(case, case_path.parent, output)
    except CaseError as error:
        _fail(str(error))
    console.print(f"deck written: {deck}")


@main.command()
@click.argument("case_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the case's engine.")
@click.option("--output", "-o", type=click.Path(path_type=Path), help="Run directory (default runs/NAME-ENGINE-TIME).")
@click.option("--timeout", type=float, default=None, help="Stop the engine after this many seconds.")
def run(case_path: Path, engine: str | None, output: Path | None, timeout: float | None) -> None:
    """Run CASE_PATH and collect results.h5 and run.json."""
    _run(case_path, engine, output, timeout)


def write_study_report(outdir: Path, report: dict[str, Any], slope_deg: float) -> Path:
    """Plots, snapshots, VTK and index.html for a study directory; returns the page."""
    from . import report as pictures
    from .avalanche_study import load_reference

    trajectory = read_results(outdir / "run" / RESULTS)
    figures = outdir / "report"
    figures.mkdir(exist_ok=True)
    pictures.plot_deposit(trajectory, figures / "deposit.png", slope_deg)
    pictures.plot_front(report, figures / "front.png")
    snapshots = pictures.plot_snapshots(trajectory, figures, slope_deg=slope_deg)
    pictures.export_vtk(trajectory, figures, every=max(1, trajectory.n_frames // 20))
    rows = pictures.comparison_rows(report, load_reference())
    return pictures.write_html(figures, outdir.name, rows, [figures / "deposit.png", figures / "front.png", *snapshots])


def study_table(title: str, report: dict[str, Any]) -> Table:
    from .avalanche_study import load_reference
    from .report import comparison_rows

    table = Table(title=title, header_style="bold")
    for column in ("metric", "value", "reference", "check"):
        table.add_column(column, justify="right" if column == "value" else "left")
    for name, value, reference, verdict in comparison_rows(report, load_reference()):
        table.add_row(name, f"{value:.4g}", reference, verdict)
    return table


@main.command()
@click.argument("study_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the study's engine.")
@click.option("--output", "-o", type=click.Path(path_type=Path), help="Study directory (default runs/NAME-ENGINE).")
@click.option("--packings", type=click.Path(file_okay=False, path_type=Path), help="Where settled packings are kept and reused (default: beside the study directory, in packings/).")
def avalanche(study_path: Path, engine: str | None, output: Path | None, packings: Path | None = None) -> None:
    """Pack bricks (or reuse the same packing), release them down the slope, report deposit and front against the references."""
    from .avalanche_study import load_study, run_study, with_engine

    try:
        study = with_engine(load_study(study_path), engine)
        outdir = output or Path("runs") / f"{study.name}-{study.engine.value}"
        console.print(f"[bold]{study.name}[/]: {study.brick_count} bricks, {study.packing.kind}, engine {study.engine.value} → {outdir}")
        with Progress(TextColumn("{task.fields[stage]}"), BarColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console) as progress:

            def stage(name: str) -> Callable[[float, float], None]:
                task = progress.add_task("starting", total=1.0, stage=name)
                return _progress_callback(progress, task)

            report = run_study(study, outdir, progress=stage, packings=packings)
    except CaseError as error:
        _fail(str(error))
    except EngineError as error:
        _fail(str(error), code=3)
    packing = report.get("packing", {})
    if report.get("finished_before"):
        console.print(f"already complete in {outdir / 'run'} (delete that directory to run it again); measured again")
    if packing.get("directory"):
        console.print(f"packing: {'reused' if packing.get('reused') else 'made'} {packing['directory']}")
    try:
        page = write_study_report(outdir, report, study.geometry.slope_deg)
        console.print(study_table(f"{study.name} on {study.engine.value}", report))
    except CaseError as error:
        _fail(f"{error} (the run itself is complete: {outdir / 'report.json'})")
    console.print(f"report: {page}")


@main.command()
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Engine (default: LIGGGHTS).")
@click.option("--output", "-o", type=click.Path(path_type=Path), help="Study directory.")
@click.option("--packings", type=click.Path(file_okay=False, path_type=Path), help="Where packings are kept and reused.")
@click.pass_context
def demo(context: click.Context, engine: str | None, output: Path | None, packings: Path | None) -> None:
    """A small brick avalanche (cases/avalanche/small.yaml): deposit and front against the references."""
    context.invoke(avalanche, study_path=DEMO_STUDY, engine=engine, output=output, packings=packings)


@main.command()
@click.argument("rundir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the metrics as JSON.")
def post(rundir: Path, as_json: bool) -> None:
    """Print summary metrics of a finished run (or avalanche study) directory."""
    if (rundir / "report.json").exists():
        report = json.loads((rundir / "report.json").read_text())
        try:
            page = write_study_report(rundir, report, report["study"]["geometry"]["slope_deg"])
            if as_json:
                console.print_json(json.dumps({"deposit": report["deposit"], "packing": report.get("packing")}))
            else:
                console.print(study_table(rundir.name, report))
                console.print(f"report: {page}")
        except CaseError as error:
            _fail(str(error))
        return
    path = rundir / RESULTS
    if not path.exists():
        record = rundir / "run.json"
        status = json.loads(record.read_text()).get("status", "unknown") if record.exists() else "unknown"
        _fail(f"{rundir} has no {RESULTS} (run status: {status})")
    trajectory = read_results(path)
    values = metrics.summary(trajectory)
    if as_json:
        console.print_json(json.dumps(values))
    else:
        console.print(metrics_table(f"{rundir} ({trajectory.attrs.get('engine', '?')})", values))


@main.group()
def campaign() -> None:
    """Sweeps, designs and calibrations over a base case."""


@campaign.command("run")
@click.argument("campaign_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--output", "-o", type=click.Path(path_type=Path), help="Campaign directory (default runs/campaigns/NAME).")
@click.option("--jobs", "-j", type=int, default=None, help="Parallel engine processes (default: one per core).")
@click.option("--executor", type=click.Choice(["local", "dask"]), default="local", show_default=True)
@click.option("--dask-address", help="Scheduler address of an existing Dask cluster (e.g. started by dask-jobqueue).")
@click.option("--rerun-failed", is_flag=True, help="Run failed runs again (their attempt moves to the attic).")
def campaign_run(campaign_file: Path, output: Path | None, jobs: int | None, executor: str, dask_address: str | None, rerun_failed: bool) -> None:
    """Run every pending point of CAMPAIGN_FILE; completed runs are skipped, so relaunching resumes."""
    import os

    from .campaign.execute import run_campaign
    from .campaign.spec import load_campaign

    try:
        spec, _ = load_campaign(campaign_file)
    except CaseError as error:
        _fail(str(error))
    directory = output or Path("runs") / "campaigns" / spec.name
    workers = jobs or os.cpu_count() or 1
    failures: list[str] = []
    with Progress(TextColumn("[bold]{task.fields[name]}[/]"), BarColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console) as progress:
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
            if summary and summary["status"] != "completed":
                failures.append(f"{summary['run_id']}: {summary.get('error', '')}")

        try:
            counts = run_campaign(campaign_file, directory, workers, executor, rerun_failed, dask_address, on_update=update)
        except CaseError as error:
            _fail(str(error))
    for line in failures:
        errors.print(f"[red]failed[/] {line}", markup=True, highlight=False)
    console.print(f"{directory}: {counts.done} run, {counts.skipped} already there, {counts.failed} failed; index: {directory / 'index.parquet'}")
    if counts.failed:
        sys.exit(3)


@campaign.command("calibrate")
@click.argument("calibration_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--output", "-o", type=click.Path(path_type=Path), help="Calibration directory (default runs/calibrations/NAME).")
def campaign_calibrate(calibration_file: Path, output: Path | None) -> None:
    """Fit contact parameters to measured launches (E2 corner error); resumable, history kept."""
    from .campaign.calibrate import calibrate, load_calibration

    try:
        spec_name = Path(calibration_file).stem
        directory = output or Path("runs") / "calibrations" / spec_name
        with console.status("calibrating (each evaluation is a real engine run)"):
            result = calibrate(load_calibration(calibration_file, directory))
    except CaseError as error:
        _fail(str(error))
    console.print_json(json.dumps(result))
    console.print(f"history: {directory / 'history.jsonl'}  plot: {directory / 'convergence.png'}")


@campaign.command("status")
@click.argument("campaign_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
def campaign_status(campaign_dir: Path) -> None:
    """Counts of runs per status."""
    from .campaign.store import build_index

    table = build_index(campaign_dir)
    counts = table["status"].value_counts().to_dict() if not table.empty else {}
    console.print(" ".join(f"{k}: {v}" for k, v in sorted(counts.items())) or "no runs")


@campaign.command("table")
@click.argument("campaign_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--csv", "csv_path", type=click.Path(path_type=Path), help="Also write the index as CSV.")
def campaign_table(campaign_dir: Path, csv_path: Path | None) -> None:
    """Print the index: parameters, status, wall time and metrics of every run."""
    from .campaign.store import build_index

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
    from .campaign.plots import response_surface
    from .campaign.store import build_index

    table = build_index(campaign_dir)
    path = output or campaign_dir / f"{metric}.png"
    try:
        response_surface(table, x_name, y_name, metric, path)
    except KeyError as error:
        _fail(f"no column {error} in the index; parameters are 'param.*', metrics 'metric.*'")
    console.print(f"plot: {path}")


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
    try:
        from .contact_build import plugin_status

        status = plugin_status()
        built = bool(status.get("built"))
        details = str(status.get("path") or "not built yet: run `demorch build-contact`")
        table.add_row("bilinear contact plugin", "[green]built[/]" if built else "[yellow]not built[/]", details)
    except ImportError:
        table.add_row("bilinear contact plugin", "[yellow]unavailable[/]", "this version has no plugin builder")
    from .avalanche_study import PACKAGED_REFERENCE, reference_path

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
    from .bricks import BrickClump

    if min(size) <= 0.0:
        _fail(f"--size: every dimension must be > 0 m (got {size})")
    for layout in layouts:
        if not all(1 <= n <= 64 for n in layout):
            _fail(f"--layout: each count must be in [1, 64] (got {layout})")
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
    """Build (or find in the cache) the LIGGGHTS bilinear contact-law plugin."""
    from .contact_build import ContactBuildError, ensure_plugin, plugin_status

    try:
        path = ensure_plugin(force=force, progress=lambda message: console.print(message))
    except ContactBuildError as error:
        _fail(str(error), code=4)
    console.print(f"plugin: {path}")
    console.print_json(json.dumps(plugin_status(), default=str))


def _register_collapse() -> None:
    from .cli_collapse import collapse

    main.add_command(collapse)


_register_collapse()

if __name__ == "__main__":
    main()
