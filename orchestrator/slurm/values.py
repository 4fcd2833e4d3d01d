"""What users give for a SLURM job, checked before it goes into a job script or onto a command line.

Each check returns the value or raises a one-line CaseError naming the option and what is allowed:
a partition like `x; rm -rf /` or a path with a space never reaches an `#SBATCH` line or a shell.
"""

from __future__ import annotations

import re
from pathlib import Path

from orchestrator.validation import CaseError

_WALLTIME = re.compile(r"^(?:(\d+)-)?(\d{1,2}):(\d{2}):(\d{2})$")
MIN_WALLTIME_S = 600  # a job shorter than 10 min would spend most of it starting and checkpointing
MIN_MARGIN_S = 120  # s: time for the engine to be stopped and the job to end (and resubmit) cleanly
MAX_SIGNAL_S = 65535  # s: the largest lead time SLURM's --signal=…@TIME takes

_NAME = re.compile(r"^[A-Za-z0-9_.,-]{1,64}$")
NAME_RULE = "1 to 64 letters, digits or _ . , -"
_PATH = re.compile(r"^/[A-Za-z0-9_./+@=-]*$")
PATH_RULE = "an absolute path of letters, digits and _ . / + @ = - (no spaces, no %)"


def walltime_seconds(value: str, option: str) -> int:
    """The wall-time limit [D-]HH:MM:SS in seconds (at least MIN_WALLTIME_S); a CaseError naming `option` otherwise."""
    match = _WALLTIME.match(value)
    if not match:
        raise CaseError(f"{option}={value!r}: must be [D-]HH:MM:SS, e.g. 01:00:00")
    days, hours, minutes, seconds = (int(part or 0) for part in match.groups())
    if minutes > 59 or seconds > 59:
        raise CaseError(f"{option}={value!r}: minutes and seconds must be 00 to 59")
    total = ((days * 24 + hours) * 60 + minutes) * 60 + seconds
    if total < MIN_WALLTIME_S:
        raise CaseError(f"{option}={value!r}: allowed range: at least 00:10:00")
    return total


def margin_seconds(walltime_s: int) -> int:
    """Seconds before a job's limit at which its run is stopped: 5 % of the wall time (s), at least MIN_MARGIN_S."""
    return max(MIN_MARGIN_S, walltime_s // 20)


def check_name(value: str, option: str) -> str:
    """A partition (or a comma-separated list of them), an account or a job name: NAME_RULE."""
    if not _NAME.match(value):
        raise CaseError(f"{option}={value!r}: allowed: {NAME_RULE}")
    return value


def check_path(path: Path, option: str) -> Path:
    """An absolute path that an #SBATCH line and a shell take as it is: PATH_RULE."""
    if not _PATH.match(str(path)):
        raise CaseError(f"{option}={str(path)!r}: allowed: {PATH_RULE}")
    return path
