"""A campaign killed at any moment takes its pool workers with it: killed while they were starting,
they used to live on as orphans (PPID 1, 220–420 MB each), run engines and idle for many minutes."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest
import yaml

from conftest import case_data


def workers_of(process: psutil.Process) -> list[psutil.Process]:
    """The campaign's pool workers (multiprocessing's spawned children)."""
    found = []
    for child in process.children(recursive=True):
        try:
            if any("spawn_main" in part for part in child.cmdline()):
                found.append(child)
        except psutil.NoSuchProcess:
            continue
    return found


def alive(process: psutil.Process) -> bool:
    try:
        return process.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.engine  # without the fix the orphaned workers go on to start engines
def test_workers_die_with_a_campaign_killed_as_they_start(tmp_path: Path) -> None:
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(case_data(engine="cocd")))
    (tmp_path / "campaign.yaml").write_text(yaml.safe_dump({"name": "killed", "base": "base.yaml", "designs": [
        {"kind": "grid", "parameters": {"gravity.2": [-9.81, -5.0]}}]}))
    campaign = subprocess.Popen([sys.executable, "-m", "orchestrator.cli", "campaign", "run", "campaign.yaml", "-o", "out", "-j", "2"],
                                cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    parent = psutil.Process(campaign.pid)
    workers: list[psutil.Process] = []
    started = time.monotonic()
    while not workers and time.monotonic() - started < 60 and campaign.poll() is None:
        workers = workers_of(parent)
        time.sleep(0.005)
    campaign.send_signal(signal.SIGKILL)  # the moment a worker exists, before it has even imported the package
    campaign.wait()
    assert workers, "the campaign started no worker"
    assert_all_die(workers, 5.0)


def assert_all_die(processes: list[psutil.Process], seconds: float) -> None:
    """Every process has ended within `seconds` (any left is killed after the check)."""
    try:
        deadline = time.monotonic() + seconds
        while any(alive(process) for process in processes) and time.monotonic() < deadline:
            time.sleep(0.1)
        survivors = [process.pid for process in processes if alive(process)]
        assert not survivors, f"processes {survivors} outlived their campaign"
    finally:
        for process in processes:
            if alive(process):
                process.kill()


@pytest.mark.engine
def test_dask_workers_die_with_a_campaign_killed_as_they_work(tmp_path: Path) -> None:
    """The Dask executor (a LocalCluster): its nannies and workers leave with the campaign process."""
    data = case_data(engine="cocd")
    data["time"]["duration"] = 2.0
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(data))
    (tmp_path / "campaign.yaml").write_text(yaml.safe_dump({"name": "killed", "base": "base.yaml", "designs": [
        {"kind": "grid", "parameters": {"gravity.2": [-9.81, -5.0]}}]}))
    campaign = subprocess.Popen([sys.executable, "-m", "orchestrator.cli", "campaign", "run", "campaign.yaml", "-o", "out", "-j", "2",
                                 "--executor", "dask"], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)
    parent = psutil.Process(campaign.pid)
    children: list[psutil.Process] = []
    started = time.monotonic()
    while len(children) < 3 and time.monotonic() - started < 60 and campaign.poll() is None:
        children = parent.children(recursive=True)
        time.sleep(0.05)
    campaign.send_signal(signal.SIGKILL)
    campaign.wait()
    assert children, "the campaign started no Dask process"
    assert_all_die(children, 15.0)
