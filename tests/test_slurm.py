"""Campaigns on SLURM (orchestrator.campaign.slurm): the job script each job runs, without a cluster."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from orchestrator.campaign.slurm import SlurmJobs
from orchestrator.case import CaseError
from orchestrator.cli.main import main


def test_the_job_script_books_the_mpi_processes_and_retires_the_worker_before_the_limit() -> None:
    result = CliRunner().invoke(main, ["--checkpoint-interval", "0.03", "campaign", "slurm", "campaigns/collapse/study22_reduced.yaml",
                                       "--walltime", "01:00:00", "--jobs", "3", "--processes", "8", "--memory", "16GB",
                                       "--partition", "batch", "--directive=--exclusive", "--dry-run"])
    assert result.exit_code == 0, result.output
    script = result.output
    for line in ("#SBATCH -t 01:00:00", "#SBATCH --cpus-per-task=8", "#SBATCH -p batch", "#SBATCH --exclusive",
                 "export DEMORCH_LIGGGHTS_MPI=8", "export DEMORCH_CHECKPOINT_INTERVAL=0.03"):
        assert line in script, line
    assert "--nthreads 1" in script  # one run at a time per job
    assert "--lifetime 3420s --lifetime-stagger 60s" in script  # 3 min before the hour: 5 % of it


@pytest.mark.parametrize(("walltime", "seconds"), [("00:10:00", 600), ("1-00:00:00", 86_400), ("12:30:05", 45_005)])
def test_walltimes_in_slurm_formats(walltime: str, seconds: int) -> None:
    spec = SlurmJobs(walltime, jobs=1)
    assert spec.seconds() == seconds
    assert 120 <= spec.margin() < spec.seconds()


@pytest.mark.parametrize("walltime", ["5:00", "00:09:59", "1:00:00:00", "soon", "01:00"])
def test_a_bad_walltime_is_one_line_naming_the_option(walltime: str) -> None:
    with pytest.raises(CaseError, match="--walltime="):
        SlurmJobs(walltime, jobs=1).seconds()
    result = CliRunner().invoke(main, ["campaign", "slurm", "campaigns/collapse/study22_reduced.yaml", "--walltime", walltime, "--jobs", "1", "--dry-run"])
    assert result.exit_code == 2 and "--walltime" in result.output


def test_a_partition_that_is_not_a_plain_name_is_refused_before_any_job_script() -> None:
    result = CliRunner().invoke(main, ["campaign", "slurm", "campaigns/collapse/study22_reduced.yaml", "--walltime", "01:00:00", "--jobs", "1",
                                       "--partition", "x; rm -rf /", "--dry-run"])
    assert result.exit_code == 2 and "--partition" in result.output and "#SBATCH" not in result.output
