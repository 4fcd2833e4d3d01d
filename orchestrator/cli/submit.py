"""`demorch submit` (one run as a SLURM job, continued job after job), `demorch status` (a run
directory and its jobs) and `demorch slurm-job` (what a submitted job runs)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import click
from rich.table import Table

from orchestrator import rundir
from orchestrator.capabilities import capabilities
from orchestrator.case import CaseError, load_case
from orchestrator.cli.common import console, errors, fail, run_options, warn, writable_rundir
from orchestrator.engines import ENGINE_NAMES, build_stamp
from orchestrator.engines.options import MAX_PROCESSES
from orchestrator.plan import make_plan
from orchestrator.results import CAMPAIGN_RECORD, CASE_COPY, RELEASE_DIR, REPORT, RESULTS, RUN_RECORD, STUDY_RECORD
from orchestrator.slurm import record
from orchestrator.slurm.commands import SlurmError, is_live, job_state, sbatch
from orchestrator.slurm.job import run_command, run_job
from orchestrator.slurm.script import MAX_RESTARTS, JobRequest
from orchestrator.validation import with_engine


def _absolute(path: Path) -> Path:
    """`path` from the root, `..` folded, links kept (a shared file system's own name for it)."""
    return Path(os.path.abspath(path))


@click.command("submit")
@click.argument("case_path", type=click.Path(path_type=Path))
@click.option("--ntasks", "-n", type=click.IntRange(1, MAX_PROCESSES), required=True,
              help="SLURM tasks: the run's MPI processes (engines that split a run over MPI; 1 for the others).")
@click.option("--time", "-t", "walltime", required=True,
              help="Each job's wall-time limit, [D-]HH:MM:SS, at least 00:10:00; an unfinished run continues in the next job.")
@click.option("--nodes", "-N", type=click.IntRange(1, MAX_PROCESSES), help="Nodes to spread the tasks over (default: SLURM's choice).")
@click.option("--partition", "-p", help="SLURM partition (letters, digits, _ . , -).")
@click.option("--account", "-A", help="SLURM account (letters, digits, _ . , -).")
@click.option("--max-restarts", type=click.IntRange(0, MAX_RESTARTS), default=10, show_default=True,
              help="Times the job script is submitted again after a job ended at its time limit with the run unfinished.")
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), help="Override the case's engine.")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path),
              help="Run directory, on a file system the nodes share (default runs/NAME-ENGINE-RUNID).")
@click.option("--dry-run", is_flag=True, help="Print the job script; write and submit nothing.")
def submit(case_path: Path, ntasks: int, walltime: str, nodes: int | None, partition: str | None, account: str | None, max_restarts: int,
           engine: str | None, output: Path | None, dry_run: bool) -> None:
    """Run CASE_PATH as SLURM jobs: write the job script into the run directory and submit it with
    sbatch. A job stops the run shortly before its time limit and submits the script again; the
    next job continues from the newest checkpoint. Set the checkpoint interval with
    `demorch --checkpoint-interval S submit …`."""
    try:
        case = with_engine(load_case(case_path), engine)
        plan = make_plan(case, case_path.parent)  # the pre-flight checks: a bad case is one line, before anything is submitted
        if ntasks > 1 and not capabilities(case.engine).mpi:
            raise CaseError(f"--ntasks={ntasks}: {case.engine.value} runs a case on one process; allowed: 1")
        directory = _absolute(output or Path("runs") / f"{case.name}-{case.engine.value}-{rundir.run_id(case, build_stamp(case.engine.value), case_dir=case_path.parent)}")
        request = JobRequest(_absolute(case_path), case.engine.value, directory, case.name, ntasks, walltime, nodes, partition, account,
                             max_restarts, run_options().checkpoint_interval)
        text = request.text()
    except CaseError as error:
        fail(str(error))
    if capabilities(case.engine).mpi and ntasks > max(1, len(plan.bodies)):  # the run uses at most one process per body
        bodies = len(plan.bodies)
        warn(f"--ntasks={ntasks}: the case has {bodies} bod{'y' if bodies == 1 else 'ies'}, so its run uses {max(1, bodies)} MPI "
             f"process{'es' if bodies > 1 else ''}; the job books every task all the same")
    if dry_run:
        click.echo(text, nl=False)
        return
    _refuse_a_second_chain(directory)
    writable_rundir(directory)
    script = request.write()
    record.settle(directory, max_restarts=max_restarts)
    try:
        job_id = sbatch(script)
    except SlurmError as error:
        fail(f"{error} (the job script is {script})", code=3)
    record.update(directory, job_id, restart=0, submitted=rundir.now())
    console.print(f"submitted job {job_id}: {directory} (logs in {record.jobs_dir(directory)}; `demorch status {directory}`)",
                  highlight=False, soft_wrap=True)


def _refuse_a_second_chain(directory: Path) -> None:
    """Fail (nothing submitted) when the run is complete, runs here, or has a job queued or running."""
    if (directory / RESULTS).exists():
        fail(f"{directory} already holds a completed run; choose another -o (nothing was submitted)")
    if rundir.is_locked(directory):
        fail(f"--output: {directory} is in use by a run (its lock is held); nothing was submitted")
    last = record.last_job(directory)
    if last is not None and "outcome" not in last:
        state = job_state(str(last.get("job_id")))
        if is_live(state):
            fail(f"job {last.get('job_id')} of {directory} is {state}; wait for it or `scancel` it (nothing was submitted)")


@click.command("status")
@click.argument("directory", metavar="RUN_DIR", type=click.Path(exists=True, file_okay=False, path_type=Path))
def status(directory: Path) -> None:
    """The state of a run directory: its status and segments, and the SLURM jobs that ran it (a study's
    or a campaign's directory: what it is and the command that tells more)."""
    other = _not_a_run(directory)
    if other:
        console.print(f"{directory}: {other}", highlight=False, soft_wrap=True)
        return
    run = rundir.read_record(directory) or {}
    segments = run.get("segments") if isinstance(run.get("segments"), list) else []
    line = f"{directory}: {rundir.status(directory, builds=build_stamp)}"
    if len(segments) > 1:
        line += f", {len(segments)} segments (simulated time computed twice: {float(run.get('simulated_time_lost_s', 0.0)):.4g} s)"
    console.print(line, highlight=False, soft_wrap=True)
    jobs = record.read(directory)
    if not jobs["jobs"]:
        return
    table = Table(title=f"SLURM jobs (restarts: {jobs['jobs'][-1].get('restart', 0)} of {jobs.get('max_restarts', '?')})", header_style="bold")
    for column in ("job", "restart", "submitted (UTC)", "ended (UTC)", "outcome", "next"):
        table.add_column(column, no_wrap=True)
    for job in jobs["jobs"]:
        outcome = job.get("outcome") or job_state(str(job.get("job_id")))  # not ended: ask the scheduler
        times = (str(job.get(key, "")).replace("T", " ")[:19] for key in ("submitted", "ended"))  # 2026-12-02 00:14:37
        table.add_row(str(job.get("job_id", "")), str(job.get("restart", "")), *times, outcome, str(job.get("next", "")))
    console.print(table)
    if jobs["jobs"][-1].get("note"):
        console.print(f"last job: {jobs['jobs'][-1]['note']}", highlight=False, soft_wrap=True)


def _not_a_run(directory: Path) -> str | None:
    """What `directory` holds when it is not a run's directory (a study, a campaign or a study over
    seeds, or nothing a run left), or None for a run's."""
    if (directory / CAMPAIGN_RECORD).exists():
        return f"a campaign or a study over seeds; `demorch campaign status {directory}` counts its runs, `demorch post {directory}` prints its tables"
    study = rundir.read_json(directory / STUDY_RECORD)
    if study is not None and str((rundir.read_record(directory) or {}).get("kind", "")) != str(study.get("kind")):
        if rundir.is_locked(directory):
            state = "running"
        elif (directory / REPORT).exists():
            state = "completed" if rundir.status(directory / RELEASE_DIR, builds=build_stamp) == "completed" else "its release is stale: run it again"
        else:
            state = f"not finished (its release: {rundir.status(directory / RELEASE_DIR, builds=build_stamp)})"
        return f"{study.get('kind', 'a')} study, {state}; `demorch post {directory}` prints its report"
    if not any((directory / name).exists() for name in (RUN_RECORD, CASE_COPY, rundir.JOBS)):  # a submitted run has its jobs first
        return "not a run's directory (no run.json or case.json): nothing ran here"
    return None


@click.command("slurm-job")
@click.argument("case_path", type=click.Path(path_type=Path))
@click.option("--engine", "-e", type=click.Choice(ENGINE_NAMES), required=True, help="The engine that runs the case.")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), required=True, help="The run directory.")
@click.option("--max-restarts", type=click.IntRange(0, MAX_RESTARTS), default=10, show_default=True, help="As for `demorch submit`.")
def slurm_job(case_path: Path, engine: str, output: Path, max_restarts: int) -> None:
    """What a job script of `demorch submit` runs: the case in its run directory (continued from its
    newest checkpoint), stopped on USR1 before the time limit and submitted again while unfinished."""
    try:
        plan = make_plan(with_engine(load_case(case_path), engine), case_path.parent)
        command = run_command(case_path, engine, output, run_options())
    except CaseError as error:
        fail(str(error))
    outcome = run_job(command, plan, output, max_restarts)
    (console if outcome.code == 0 else errors).print(f"slurm-job: {outcome.message}", highlight=False, soft_wrap=True)
    sys.exit(outcome.code)
