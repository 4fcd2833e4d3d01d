"""`demorch paraview`: a run's bodies as surfaces, and its contacts, as ParaView time series
(orchestrator.post.paraview)."""

from __future__ import annotations

from pathlib import Path

import click
from rich.progress import BarColumn, Progress, TextColumn

from orchestrator.cli.common import DAMAGE, EXIT_DAMAGED, console, damaged, errors, fail, results_path, writable_rundir
from orchestrator.post.paraview import KINDS, write_series
from orchestrator.results import CASE_COPY, read_results, safe_output_path
from orchestrator.rundir import saved_case


@click.command()
@click.argument("rundir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--stride", type=click.IntRange(min=1), default=1, show_default=True, metavar="K",
              help="Write every K-th frame (and the last).")
@click.option("--out", "outdir", type=click.Path(file_okay=False, path_type=Path),
              help="Directory for the series (default: RUNDIR/paraview).")
@click.option("--resolution", type=click.IntRange(3, 64), default=None, metavar="N",
              help="Latitudes of every surface mesh (default: 8 for spheres and a clump's spheres, 12 for superquadrics; "
                   "4 writes about a quarter of what 8 does).")
def paraview(rundir: Path, stride: int, outdir: Path | None, resolution: int | None) -> None:
    """Every body's surface per frame (bodies.pvd: velocity per vertex, body and kind per triangle)
    and, when the run recorded contacts, the contacts as lines (contacts.pvd: normal force per
    line), for ParaView. Takes a run or a study directory; prints the .pvd paths."""
    path = results_path(rundir)
    try:
        case = saved_case(path.parent)
    except (OSError, ValueError) as error:
        damaged(path.parent, f"its {CASE_COPY} cannot be read", error)
    try:
        trajectory = read_results(path)
        trajectory.validate()
    except DAMAGE as error:
        damaged(rundir, "damaged results", error)
    outdir = outdir or safe_output_path(rundir, "paraview")  # a link there would lead the series out of the run directory
    writable_rundir(outdir, "--out")
    try:
        with Progress(TextColumn("writing frames"), BarColumn(), TextColumn("{task.completed}/{task.total}"), console=errors, transient=True) as bar:
            task = bar.add_task("frames", total=None)
            series = write_series(case, trajectory, outdir, stride, None if resolution is None else dict.fromkeys(KINDS, resolution),
                                  progress=lambda done, total: bar.update(task, completed=done, total=total))
    except ValueError as error:  # the results and their case disagree
        fail(f"{rundir}: {error}; rerun the case", code=EXIT_DAMAGED)
    except OSError as error:
        fail(f"--out: cannot write in {outdir} ({error.strerror or error}); choose a writable directory with room")
    counted = ", ".join(f"{count} {kind}{'' if count == 1 else 's'}" for kind, count in series.kinds.items())
    console.print(f"bodies: {series.bodies} ({len(series.frames)} frames of {counted})", highlight=False, soft_wrap=True)
    if series.contacts is not None:
        console.print(f"contacts: {series.contacts}", highlight=False, soft_wrap=True)
