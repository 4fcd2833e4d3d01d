"""A fake SLURM for the tests: `sbatch`, `squeue` and `sacct` on PATH that keep their jobs as JSON
files in a folder, and a queue that the test drives.

sbatch records each submission (its arguments, the script, the SLURM_* variables it was given) and
answers a job id; nothing runs until the test calls `FakeSlurm.run(job_id, cut=…)`, which runs the
job's script as SLURM would (bash, SLURM_JOB_ID set, standard output and error to the files of its
#SBATCH --output and --error, %j replaced) and, once `cut()` is true, sends USR1 to the batch shell
alone, as `--signal=B:USR1@…` does before a time limit. squeue and sacct answer the states.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

import pytest

SBATCH = """#!{python}
import json, os, pathlib, sys
state = pathlib.Path(os.environ["FAKE_SLURM_DIR"])
if os.environ.get("FAKE_SLURM_REFUSE"):
    print("sbatch: error: " + os.environ["FAKE_SLURM_REFUSE"], file=sys.stderr)
    sys.exit(1)
job_id = str(len(list(state.glob("*.json"))) + 1)
job = {{"job_id": job_id, "arguments": sys.argv[1:-1], "script": sys.argv[-1], "state": "PENDING",
        "slurm_variables": sorted(key for key in os.environ if key.startswith("SLURM_"))}}
(state / (job_id + ".json")).write_text(json.dumps(job))
print(job_id if "--parsable" in sys.argv else "Submitted batch job " + job_id)
"""

STATE = """#!{python}
import json, os, pathlib, sys
job_id = sys.argv[sys.argv.index("--jobs") + 1]
path = pathlib.Path(os.environ["FAKE_SLURM_DIR"]) / (job_id + ".json")
state = json.loads(path.read_text())["state"] if path.exists() else ""
if {queued} == (state in ("PENDING", "RUNNING")):
    print(state)
"""

GRACE_S = 120.0  # s a job may take to end after USR1 before the fake kills it, as SLURM does at the limit


class FakeSlurm:
    """The fake scheduler's folder and the test's hold on its queue."""

    def __init__(self, root: Path):
        self.state = root / "jobs"
        self.bin = root / "bin"
        self.state.mkdir(parents=True)
        self.bin.mkdir()
        for name, text in (("sbatch", SBATCH), ("squeue", STATE.replace("{queued}", "True")), ("sacct", STATE.replace("{queued}", "False"))):
            (self.bin / name).write_text(text.format(python=sys.executable))
            (self.bin / name).chmod(0o755)

    def jobs(self) -> list[dict]:
        """Every submission, oldest first."""
        return sorted((json.loads(path.read_text()) for path in self.state.glob("*.json")), key=lambda job: int(job["job_id"]))

    def _set(self, job_id: str, state: str) -> None:
        path = self.state / f"{job_id}.json"
        path.write_text(json.dumps({**json.loads(path.read_text()), "state": state}))

    def run(self, job_id: str, cut: Callable[[], bool] | None = None, environment: dict[str, str] | None = None) -> int:
        """Run the job's script to its end; USR1 to its batch shell once `cut()` is true. Returns its exit status."""
        job = next(job for job in self.jobs() if job["job_id"] == job_id)
        assert job["state"] == "PENDING", job
        script = Path(job["script"]).read_text()
        logs = {name: Path(value.replace("%j", job_id)) for name, value in re.findall(r"^#SBATCH --(output|error)=(\S+)$", script, re.M)}
        self._set(job_id, "RUNNING")
        with open(logs["output"], "w") as out, open(logs["error"], "w") as err:
            shell = subprocess.Popen(["bash", job["script"]], stdout=out, stderr=err, stdin=subprocess.DEVNULL,
                                     env={**os.environ, **(environment or {}), "SLURM_JOB_ID": job_id})
            signalled = False
            while shell.poll() is None:
                if cut is not None and not signalled and cut():
                    shell.send_signal(signal.SIGUSR1)
                    signalled = True
                    try:
                        shell.wait(timeout=GRACE_S)
                    except subprocess.TimeoutExpired:
                        shell.kill()
                time.sleep(0.01)
        self._set(job_id, "TIMEOUT" if signalled else "COMPLETED" if shell.returncode == 0 else "FAILED")
        return shell.wait()


@pytest.fixture
def fake_slurm(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> FakeSlurm:
    """The fake scheduler first on PATH for this test and what it starts."""
    fake = FakeSlurm(tmp_path / "slurm")
    monkeypatch.setenv("PATH", f"{fake.bin}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.setenv("FAKE_SLURM_DIR", str(fake.state))
    return fake
