"""One long run on SLURM (`demorch submit`, orchestrator.slurm) against a fake scheduler (fake_slurm):
the job script, the submission, bad values refused before anything is submitted, and a run cut at
its jobs' time limits that ends, job after job, as the uninterrupted run."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from orchestrator import rundir
from orchestrator.cli.main import main
from orchestrator.engines import build_stamp, get_adapter
from orchestrator.results import read_results
from orchestrator.slurm import record
from orchestrator.slurm.commands import SlurmError, parse_job_id, submission_environment

from conftest import requires_liggghts
from fake_slurm import FakeSlurm, fake_slurm  # noqa: F401  (the fixture)
from test_exact_resume import _demorch, _newest_sealed, pressed_spheres

EXT = get_adapter("liggghts").checkpoint_ext


@pytest.fixture
def case_file(tmp_path: Path) -> Path:
    """27 spheres pressed in a box (linear law: no plugin), 1 s: about 4 s of LIGGGHTS."""
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(json.loads(pressed_spheres("liggghts", "linear", duration=1.0).model_dump_json())))
    return path


def _submit(*arguments: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["--checkpoint-interval", "0.05", "submit", *arguments])
    return result.exit_code, result.output


def test_the_job_script_asks_for_the_tasks_and_the_time_and_stops_the_run_before_the_limit(case_file: Path, tmp_path: Path,
                                                                                            fake_slurm: FakeSlurm) -> None:
    code, output = _submit(str(case_file), "--ntasks", "4", "--time", "04:00:00", "--partition", "batch", "--account", "proj_1",
                           "-o", str(tmp_path / "run"))
    assert code == 0, output
    script = (tmp_path / "run" / "jobs" / "job.sbatch").read_text()
    logs = tmp_path / "run" / "jobs"
    for line in ("#!/bin/bash", "#SBATCH --job-name=pressed", "#SBATCH --ntasks=4", "#SBATCH --time=04:00:00",
                 "#SBATCH --signal=B:USR1@720",  # 5 % of 4 h before the limit
                 f"#SBATCH --output={logs}/slurm-%j.out", f"#SBATCH --error={logs}/slurm-%j.err",
                 "#SBATCH --partition=batch", "#SBATCH --account=proj_1"):
        assert line in script.splitlines(), line
    command = script.splitlines()[-1]
    assert command.startswith(f"exec {sys.executable} -m orchestrator.cli --mpi 4 --checkpoint-interval 0.05 slurm-job {case_file} ")
    assert f"--output {tmp_path / 'run'} --max-restarts 10" in command
    (job,) = fake_slurm.jobs()
    assert job["arguments"] == ["--parsable"] and job["script"] == str(logs / "job.sbatch")
    assert f"submitted job {job['job_id']}" in output
    jobs = record.read(tmp_path / "run")
    assert jobs["max_restarts"] == 10 and [(job["job_id"], job["restart"]) for job in jobs["jobs"]] == [("1", 0)]


def test_the_default_run_directory_is_named_by_the_run_id(case_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    code, output = _submit(str(case_file), "-n", "1", "-t", "01:00:00", "--dry-run")
    assert code == 0, output
    from orchestrator.case import load_case

    case = load_case(case_file)
    identity = rundir.run_id(case, build_stamp(case.engine.value), case_dir=tmp_path)
    assert f"--output={tmp_path}/runs/pressed-liggghts-{identity}/jobs/slurm-%j.out" in output
    assert not (tmp_path / "runs").exists()  # a dry run writes nothing


def test_a_dry_run_prints_the_script_and_submits_nothing(case_file: Path, tmp_path: Path, fake_slurm: FakeSlurm) -> None:
    code, output = _submit(str(case_file), "-n", "2", "-t", "1-00:00:00", "-N", "1", "-o", str(tmp_path / "run"), "--dry-run")
    assert code == 0, output
    assert "#SBATCH --time=1-00:00:00" in output and "#SBATCH --nodes=1" in output and "#SBATCH --signal=B:USR1@4320" in output
    assert fake_slurm.jobs() == [] and not (tmp_path / "run").exists()


@pytest.mark.parametrize(("arguments", "field"), [
    (["--partition", "x; rm -rf /"], "--partition"),
    (["--partition", "batch\n#SBATCH --exclusive"], "--partition"),
    (["--account", "$(reboot)"], "--account"),
    (["--time", "25:00"], "--time"),
    (["--time", "00:09:59"], "--time"),
    (["--time", "01:75:00"], "--time"),
    (["--time", "soon; rm -rf /"], "--time"),
    (["--ntasks", "0"], "--ntasks"),
    (["--nodes", "3"], "--nodes"),  # more nodes than tasks
    (["--max-restarts", "-1"], "--max-restarts"),
    (["-o", "/tmp/a b"], "--output"),
    (["-o", "/tmp/run%j"], "--output"),
])
def test_a_bad_value_is_one_line_naming_the_option_and_nothing_is_submitted(arguments: list[str], field: str, case_file: Path,
                                                                           tmp_path: Path, fake_slurm: FakeSlurm) -> None:
    options = {"--ntasks": "2", "--time": "01:00:00", "-o": str(tmp_path / "run"), **dict(zip(arguments[::2], arguments[1::2]))}
    code, output = _submit(str(case_file), *[word for pair in options.items() for word in pair])
    lines = [line for line in output.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error:") and field in lines[0], output
    assert "Traceback" not in output
    assert fake_slurm.jobs() == [] and not (tmp_path / "run").exists()


def test_an_engine_that_runs_on_one_process_is_not_given_more_tasks(case_file: Path, tmp_path: Path, fake_slurm: FakeSlurm) -> None:
    code, output = _submit(str(case_file), "-e", "yade", "-n", "4", "-t", "01:00:00", "-o", str(tmp_path / "run"))
    assert code == 2 and "--ntasks=4" in output and "allowed: 1" in output, output
    assert fake_slurm.jobs() == []


def test_a_run_with_a_job_queued_is_not_submitted_twice_and_status_shows_the_job(case_file: Path, tmp_path: Path,
                                                                                 fake_slurm: FakeSlurm) -> None:
    directory = tmp_path / "run"
    assert _submit(str(case_file), "-n", "1", "-t", "01:00:00", "-o", str(directory))[0] == 0
    code, output = _submit(str(case_file), "-n", "1", "-t", "01:00:00", "-o", str(directory))
    assert code == 2 and "job 1" in output and "PENDING" in output and "nothing was submitted" in output, output
    assert len(fake_slurm.jobs()) == 1
    status = CliRunner().invoke(main, ["status", str(directory)])
    assert status.exit_code == 0, status.output
    assert "pending" in status.output and "restarts: 0 of 10" in status.output and "PENDING" in status.output


def test_a_refused_submission_is_one_line() -> None:
    assert parse_job_id("4242\n") == "4242" and parse_job_id("4242;cluster2") == "4242" and parse_job_id("Submitted batch job 17\n") == "17"
    with pytest.raises(SlurmError, match="no job id"):
        parse_job_id("sbatch: queued, maybe\n")
    environment = submission_environment({"SLURM_JOB_ID": "3", "SLURM_MEM_PER_NODE": "4000", "SLURM_CONF": "/etc/slurm.conf", "PATH": "/bin"})
    assert environment == {"SLURM_CONF": "/etc/slurm.conf", "PATH": "/bin"}


def test_the_scheduler_refusing_the_job_is_one_line(case_file: Path, tmp_path: Path, fake_slurm: FakeSlurm,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_SLURM_REFUSE", "Batch job submission failed: Invalid partition name specified")
    code, output = _submit(str(case_file), "-n", "1", "-t", "01:00:00", "-p", "nosuch", "-o", str(tmp_path / "run"))
    assert code == 3 and "Invalid partition name" in output and len(output.strip().splitlines()) == 1, output


def test_the_jobs_stay_in_the_run_directory_when_an_attempt_is_retired(tmp_path: Path) -> None:
    directory = tmp_path / "run"
    record.update(directory, "7", restart=0)
    assert rundir.status(directory, builds=build_stamp) == "pending"  # submitted, not started: the jobs are no attempt
    rundir.write_record(directory, {"status": "failed"})
    assert rundir.status(directory, builds=build_stamp) == "failed"
    rundir.retire(directory, tmp_path)
    assert rundir.status(directory, builds=build_stamp) == "pending" and record.last_job(directory) == {"job_id": "7", "restart": 0}


# -- jobs that run ---------------------------------------------------------------------------------
def _after_a_new_checkpoint(directory: Path) -> Callable[[], bool]:
    """The cut of a job: true once the run sealed a checkpoint newer than those there when the job started."""
    before = _newest_sealed(directory, EXT)
    return lambda: _newest_sealed(directory, EXT) > before


@pytest.mark.engine
@requires_liggghts
def test_a_run_cut_at_two_time_limits_continues_job_after_job_to_the_uninterrupted_result(case_file: Path, tmp_path: Path,
                                                                                           fake_slurm: FakeSlurm) -> None:
    whole = _demorch(["run", str(case_file), "-o", str(tmp_path / "whole")], tmp_path)  # checkpoints as the jobs' run: every 0.05 s
    assert whole.wait(timeout=600) == 0, whole.stdout.read()[-2000:]
    directory = tmp_path / "cut"
    assert _submit(str(case_file), "-n", "1", "-t", "01:00:00", "-o", str(directory))[0] == 0
    job_variables = {"SLURM_MEM_PER_NODE": "4000", "SLURM_NTASKS": "1", "SLURM_CONF": "/etc/slurm/slurm.conf"}
    for job_id in ("1", "2"):  # each cut just after the run sealed a new checkpoint
        assert fake_slurm.run(job_id, cut=_after_a_new_checkpoint(directory), environment=job_variables) == 0
        assert not rundir.is_locked(directory) and not (directory / "results.h5").exists()
        assert "continues it" in (directory / "jobs" / f"slurm-{job_id}.out").read_text()
    assert fake_slurm.run("3") == 0  # the third job runs to the end
    assert [job["job_id"] for job in fake_slurm.jobs()] == ["1", "2", "3"]
    for job, previous in zip(fake_slurm.jobs()[1:], ("1", "2")):  # resubmitted by the job before it, to start once it has ended
        assert job["arguments"] == ["--parsable", f"--dependency=afterany:{previous}"] and job["script"] == str(directory / "jobs" / "job.sbatch")
        assert job["slurm_variables"] == ["SLURM_CONF"]  # the submitting job's own settings are not passed on
    jobs = record.read(directory)["jobs"]
    assert [(job["restart"], job["outcome"], job.get("next")) for job in jobs] == [(0, "cut", "2"), (1, "cut", "3"), (2, "completed", None)]
    first, cut = read_results(tmp_path / "whole" / "results.h5"), read_results(directory / "results.h5")
    assert np.array_equal(first.time, cut.time)
    assert np.array_equal(first.position, cut.position) and np.array_equal(first.velocity, cut.velocity)
    assert np.array_equal(first.angular_velocity, cut.angular_velocity)
    run = json.loads((directory / "run.json").read_text())
    assert run["status"] == "completed" and len(run["segments"]) == 3  # each job after the first continued from a checkpoint
    status = CliRunner().invoke(main, ["status", str(directory)])
    assert "completed, 3 segments" in status.output and "restarts: 2 of 10" in status.output, status.output


@pytest.mark.engine
@requires_liggghts
def test_a_cut_job_is_not_resubmitted_past_max_restarts_nor_without_progress(case_file: Path, tmp_path: Path, fake_slurm: FakeSlurm) -> None:
    directory = tmp_path / "run"
    assert _submit(str(case_file), "-n", "1", "-t", "01:00:00", "--max-restarts", "1", "-o", str(directory))[0] == 0
    started = lambda: "started" in (record.last_job(directory) or {})  # noqa: E731
    assert fake_slurm.run("1", cut=started) == 1  # USR1 as the job starts: no checkpoint yet, so a next job would only start afresh
    assert len(fake_slurm.jobs()) == 1
    assert "before the run wrote a new checkpoint" in (directory / "jobs" / "slurm-1.err").read_text()
    assert _submit(str(case_file), "-n", "1", "-t", "01:00:00", "--max-restarts", "1", "-o", str(directory))[0] == 0  # a new chain
    assert fake_slurm.run("2", cut=_after_a_new_checkpoint(directory)) == 0
    assert fake_slurm.run("3", cut=_after_a_new_checkpoint(directory)) == 1  # restart 1 of 1 used
    assert len(fake_slurm.jobs()) == 3
    last = record.read(directory)["jobs"][-1]
    assert last["restart"] == 1 and last["outcome"] == "cut" and "--max-restarts 1" in last["note"]
    assert rundir.status(directory, builds=build_stamp) == "incomplete" and (directory / "jobs" / "job.sbatch").exists()
