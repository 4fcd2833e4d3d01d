"""`demorch collapse …`: column collapses on rigid and erodible beds (run, calibrate, plot a campaign)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

import click
import numpy as np
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from orchestrator.case import CaseError
from orchestrator.validation import with_engine
from orchestrator.cli.common import console, fail, progress_callback, run_options, study_notes
from orchestrator.engines import ENGINE_NAMES, EngineError


@click.group()
def collapse() -> None:
    """Granular column collapses (Martin et al. 2022 set-ups): run, calibrate μ, plot campaigns."""


def collapse_table(title: str, report: dict[str, Any]) -> Table:
    front = report["front"]
    table = Table(title=title, header_style="bold")
    table.add_column("metric")
    table.add_column("value", justify="right")
    rows = [
        ("grains (column / bed / glued)", f"{report['grains']['column']} / {report['grains']['bed']} / {report['grains']['glued']}"),
        ("runout from the gate (m)", f"{report['runout']:.4f}"),
        ("runout / R0 (= ΔL/L0)", f"{report['runout_over_R0']:.3f}"),
        ("front max velocity (m/s) at t, x", f"{front['v_max']:.3f} at {front['t_max']:.2f} s, {front['x_max']:.3f} m"),
        ("slow phase from t, x (mean v)", f"{front['t_slow']:.2f} s, {front['x_slow']:.3f} m ({front['v_slow']:.3f} m/s)" if front["slow_phase"] else "none detected"),
        ("front at rest from t, x", f"{front['t_stop']:.2f} s, {front['x_stop']:.3f} m" if front["at_rest"] else "still moving at the end"),
        ("entrained bed mass (g)", f"{1000 * report['bed']['entrained_mass_final']:.2f}"),
        ("mass lost from the domain", f"{report['grains']['lost']} grains"),
    ]
    if front.get("reached_end"):
        rows.append(("[bold red]warning[/]", "the flow reached the channel's end wall: lengthen channel.length"))
    for name, value in rows:
        table.add_row(name, value)
    return table


def _stages(progress: Progress) -> Callable[[str], Callable[[float, float], None]]:
    def stage(name: str) -> Callable[[float, float], None]:
        return progress_callback(progress, progress.add_task("starting", total=1.0, stage=name))

    return stage


def _progress() -> Progress:
    return Progress(TextColumn("{task.fields[stage]}"), BarColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console)


def write_collapse_report(outdir: Path, report: dict[str, Any]) -> Path:
    """collapse.png (front, velocity, deposit), fields.png (u_x(z), Φ(z) at the stations) and, when
    the interface showed waves, waves.png; returns the first."""
    from orchestrator.studies.collapse.plots import plot_profiles, plot_run, plot_waves

    arrays = dict(np.load(outdir / "profiles.npz"))
    plot_profiles(report, arrays, outdir / "fields.png")
    plot_waves(report, arrays, outdir / "waves.png")
    return plot_run(report, arrays, outdir / "collapse.png")


@collapse.command("run")
@click.argument("study_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the study's engine.")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Study directory (default runs/NAME-ENGINE).")
@click.option("--preparations", type=click.Path(file_okay=False, path_type=Path), help="Where prepared columns are kept and reused.")
@click.option("--jobs", "-j", type=click.IntRange(1, 1000), default=None, help="A study with seeds: seeds run at once (default: one per core).")
@click.option("--executor", type=click.Choice(["local", "dask"]), default="local", show_default=True, help="A study with seeds: where its seeds run.")
@click.option("--dask-address", help="A study with seeds: scheduler address of an existing Dask cluster.")
def run_command(study_path: Path, engine: str | None, output: Path | None, preparations: Path | None, jobs: int | None = None,
                executor: str = "local", dask_address: str | None = None) -> None:
    """Rain the column (or reuse it), release it down the channel, report the front and the bed.
    A study with `seeds:` runs each seed (in parallel, -j) and reports each seed, the mean and the range."""
    from orchestrator.studies.collapse.spec import load_collapse
    from orchestrator.studies.base import refuse_foreign
    from orchestrator.studies.collapse.study import KIND as COLLAPSE_KIND, run_collapse

    try:
        study = with_engine(load_collapse(study_path), engine)
        outdir = output or Path("runs") / f"{study.name}-{study.engine.value}"
        if study.seeds is None:
            refuse_foreign(COLLAPSE_KIND, outdir)  # a directory of another kind, or in use, is one line before anything runs
        if study.seeds is not None:
            from orchestrator.cli.ensemble import launch_ensemble

            return launch_ensemble("collapse", study_path, study.name, engine, outdir, jobs, executor, dask_address,
                                   preparations or outdir.resolve().parent / "preparations")
        with _progress() as progress:
            report = run_collapse(study, outdir, progress=_stages(progress), preparations=preparations, options=run_options())
        figure = write_collapse_report(outdir, report)
    except CaseError as error:
        fail(str(error))
    except EngineError as error:
        fail(str(error), code=3)
    study_notes(report, outdir)
    console.print(collapse_table(f"{study.name} on {study.engine.value}: α = {study.channel.slope_deg:g}°, h_i = {1000 * study.bed.erodible_thickness:g} mm", report))
    console.print(f"report: {outdir / 'report.json'}, figure: {figure}")


@collapse.command("calibrate")
@click.argument("study_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the study's engine.")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Calibration directory (default runs/calibration-NAME-ENGINE).")
@click.option("--mu-range", nargs=2, type=float, default=(0.1, 0.9), show_default=True, help="Bracket of μ to bisect.")
@click.option("--max-runs", type=click.IntRange(1, 50), default=8, show_default=True)
@click.option("--check-engine", type=click.Choice(ENGINE_NAMES), help="Also run the calibrated μ on this engine and compare the runouts.")
def calibrate_command(study_path: Path, engine: str | None, output: Path | None, mu_range: tuple[float, float], max_runs: int, check_engine: str | None) -> None:
    """Find μ that puts the horizontal-collapse runout on the quasi-2D law ΔL/L0 = 1.2 a (± 20 %)."""
    from orchestrator.studies.collapse.spec import load_collapse
    from orchestrator.studies.collapse.calibrate import calibrate_mu, with_mu
    from orchestrator.studies.collapse.study import run_collapse

    try:
        study = with_engine(load_collapse(study_path), engine)
        if study.channel.slope_deg != 0.0:
            raise CaseError(f"channel.slope_deg: the scaling law is for a horizontal collapse; allowed: 0 (got {study.channel.slope_deg})")
        outdir = output or Path("runs") / f"calibration-{study.name}-{study.engine.value}"
        result = calibrate_mu(study, outdir, tuple(mu_range), max_runs=max_runs,
                              on_run=lambda mu, ratio: console.print(f"μ = {mu:.4f}: ΔL/L0 = {ratio:.3f}"), options=run_options())
        if check_engine and check_engine != study.engine.value:
            other = with_engine(with_mu(study, result["mu"]), check_engine)
            report = run_collapse(other, outdir / f"check-{check_engine}", preparations=outdir / "preparations", options=run_options())
            ratio = report["runout_over_R0"]
            result["check"] = {"engine": check_engine, "runout_over_R0": ratio, "relative_difference": ratio / result["runout_over_R0"] - 1.0}
            (outdir / "calibration.json").write_text(json.dumps(result, indent=2) + "\n")
    except CaseError as error:
        fail(str(error))
    except EngineError as error:
        fail(str(error), code=3)
    band = result["band"]
    verdict = "in the band" if result["in_band"] else "OUTSIDE the band"
    console.print(f"[bold]μ = {result['mu']:.4f}[/] on {result['engine']}: ΔL/L0 = {result['runout_over_R0']:.3f}, "
                      f"law 1.2 a = {result['target_runout_over_R0']:.3f}, band [{band[0]:.3f}, {band[1]:.3f}]: {verdict}")
    if "check" in result:
        check = result["check"]
        console.print(f"same μ on {check['engine']}: ΔL/L0 = {check['runout_over_R0']:.3f} ({100 * check['relative_difference']:+.1f} %)")
    console.print(f"record: {outdir / 'calibration.json'}")


@collapse.command("plot")
@click.argument("campaign_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Where the figures go (default CAMPAIGN_DIR).")
def plot_command(campaign_dir: Path, output: Path | None) -> None:
    """Front position (r_f/R0) and velocity against time, one panel per slope, one curve per bed thickness."""
    from orchestrator.studies.collapse.plots import plot_slope_bed

    reports = [json.loads(path.read_text()) for path in sorted(campaign_dir.glob("runs/*/report.json"))]
    if not reports:
        fail(f"{campaign_dir}: no finished collapse runs (runs/*/report.json)")
    target = output or campaign_dir
    target.mkdir(parents=True, exist_ok=True)
    for path in plot_slope_bed(reports, target):
        console.print(f"figure: {path}")


@collapse.command("record")
@click.argument("study_dirs", nargs=-1, required=True, type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--output", "-o", type=click.Path(dir_okay=False, path_type=Path), required=True, help="The record (JSON).")
def record_command(study_dirs: tuple[Path, ...], output: Path) -> None:
    """Record a row of finished collapses (one slope; e.g. a campaign's runs/*) against the erodible-bed
    study: set-up, cost per run, runouts at the study's times, front phases, waves, Kelvin–Helmholtz."""
    from orchestrator.studies.collapse.record import row_record

    missing = [str(d) for d in study_dirs if not (d / "report.json").is_file()]
    if missing:
        fail(f"study_dirs: no report.json in {', '.join(missing)}")
    try:
        record = row_record(list(study_dirs))
    except ValueError as error:
        fail(str(error))
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(json.dumps(record, indent=1) + "\n")
    console.print(f"record: {output}")
