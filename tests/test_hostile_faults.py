"""Inputs that used to hang, run away or end in the wrong exit class, through the real `demorch`.

Files that are not regular files (a FIFO, /dev/zero, a symlink loop) and a mesh of a million
triangles run in a subprocess with a time limit and an address-space cap, so a regression fails
here instead of hanging the test run or eating the machine's memory. Each input must end with its
exit code and one line, within the limits below, before any engine starts.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from orchestrator import physics, preflight
from orchestrator.case import parse_case
from orchestrator.rundir import locked

from conftest import assert_one_line_error, case_data, run_cli

SECONDS, MEMORY_MB, ADDRESS_SPACE = 30.0, 1500, 4 * 2**30
FLOOR = [[[-1, -1, 0], [1, -1, 0], [1, 1, 0]], [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]]


def demorch(arguments: list[str], cwd: Path, env: dict[str, str] | None = None) -> tuple[int | None, list[str], float, float]:
    """(exit code, or None when killed at the time limit; non-empty output lines; seconds; peak MB)."""
    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))
        os.setsid()

    started = time.perf_counter()
    with tempfile.TemporaryFile() as output:
        process = subprocess.Popen([sys.executable, "-m", "orchestrator.cli", *arguments], cwd=cwd, stdout=output,
                                   stderr=subprocess.STDOUT, env={**os.environ, "COLUMNS": "250", **(env or {})}, preexec_fn=cap)
        while not (finished := os.wait4(process.pid, os.WNOHANG))[0]:  # wait4: this child's own peak memory
            if time.perf_counter() - started > SECONDS:
                os.killpg(process.pid, signal.SIGKILL)
                finished = os.wait4(process.pid, 0)
                break
            time.sleep(0.02)
        process.returncode = code = os.waitstatus_to_exitcode(finished[1])
        output.seek(0)
        lines = [line for line in output.read().decode(errors="replace").splitlines() if line.strip()]
    return (code if code >= 0 else None), lines, time.perf_counter() - started, finished[2].ru_maxrss / 1024


def write_stl(path: Path, triangles: Any) -> None:
    """A binary STL of (t, 3, 3) vertices."""
    vertices = np.asarray(triangles, dtype="<f4").reshape(-1, 3, 3)
    record = np.zeros(len(vertices), dtype=[("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])
    record["vertices"] = vertices
    path.write_bytes(b"\0" * 80 + np.uint32(len(vertices)).tobytes() + record.tobytes())


def mesh_case(directory: Path, stl: str, **changes: Any) -> Path:
    data = case_data(**changes)
    data["walls"] = [{"type": "mesh", "name": "m", "material": "glass", "file": stl}]
    path = directory / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def assert_refused(result: tuple[int | None, list[str], float, float], code: int, field: str) -> None:
    exit_code, lines, seconds, peak = result
    assert exit_code == code, (exit_code, lines[-3:], seconds)
    assert len(lines) == 1 and lines[0].startswith("error:") and field in lines[0], lines
    assert seconds < SECONDS and peak < MEMORY_MB, (seconds, peak)


def test_a_case_file_that_is_a_fifo_is_refused_without_waiting(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "case.yaml")
    assert_refused(demorch(["run", "case.yaml", "-o", "run"], tmp_path), 2, "it is a FIFO, not a regular file")


def test_a_mesh_that_is_a_fifo_is_refused_without_waiting(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "m.stl")
    mesh_case(tmp_path, "m.stl")
    assert_refused(demorch(["run", "case.yaml", "-o", "run"], tmp_path), 2, "walls.m.file")


def test_dev_zero_as_the_case_or_the_mesh_reads_nothing(tmp_path: Path) -> None:
    assert_refused(demorch(["run", "/dev/zero", "-o", "run"], tmp_path), 2, "not a regular file")
    (tmp_path / "m.stl").symlink_to("/dev/zero")
    mesh_case(tmp_path, "m.stl")
    assert_refused(demorch(["run", "case.yaml", "-o", "run"], tmp_path), 2, "walls.m.file")


def test_symlink_loops_as_the_case_or_the_mesh(tmp_path: Path) -> None:
    for suffix in ("yaml", "stl"):
        (tmp_path / f"a.{suffix}").symlink_to(tmp_path / f"b.{suffix}")
        (tmp_path / f"b.{suffix}").symlink_to(tmp_path / f"a.{suffix}")
    assert_refused(demorch(["run", "a.yaml", "-o", "run"], tmp_path), 2, "a symlink loop")
    mesh_case(tmp_path, "a.stl")
    assert_refused(demorch(["run", "case.yaml", "-o", "run"], tmp_path), 2, "walls.m.file")


def test_a_mesh_of_a_million_triangles_is_checked_in_seconds(tmp_path: Path) -> None:
    """The pre-flight used to take 0.18 ms per triangle (3 min here). Small triangles scattered over
    the floor plus one under the sphere, which sinks into it: the check must find that one."""
    corners = np.random.default_rng(1).uniform(-1.0, 1.0, (1_000_000 - 1, 3)) * [1.0, 1.0, 0.0]
    small = np.stack([corners, corners + [1e-3, 0.0, 0.0], corners + [0.0, 1e-3, 0.0]], axis=1)
    write_stl(tmp_path / "m.stl", np.concatenate([small, [[[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.0, 0.1, 0.0]]]]))
    mesh_case(tmp_path, "m.stl", bodies__spheres__0__position=[0.0, 0.0, 0.002])
    assert_refused(demorch(["run", "case.yaml", "-o", "run"], tmp_path), 2, "cuts wall 'm'")


# Input defects that used to reach an engine (exit 3) or end as "unexpected" (exit 1): each is one
# line naming the field, exit 2, and no engine starts (no_engine_process).
def stl_case(triangles: list[Any], **wall: Any) -> Any:
    def make(directory: Path) -> dict[str, Any]:
        write_stl(directory / "m.stl", triangles)
        data = case_data()
        data["walls"] = [{"type": "mesh", "name": "m", "material": "glass", "file": "m.stl", **wall}]
        return data
    return make


DEFECTS: dict[str, tuple[Any, str]] = {
    "kn_1e-300": (lambda d: case_data(contacts__0__kn=1e-300, time__step="auto"), "contacts.0.kn"),
    "ten_billion_steps": (lambda d: case_data(time={"step": 1e-6, "duration": 1e4, "output_interval": 1.0}), "time.duration"),
    "radius_1e-300": (lambda d: case_data(bodies__spheres__0__radius=1e-300), "bodies.spheres.0.radius"),
    "density_1e-300": (lambda d: case_data(materials__0__density=1e-300), "materials.0.density"),
    "stl_zero_area_triangle": (stl_case(FLOOR + [[[0, 0, 0], [0.5, 0, 0], [1, 0, 0]]]), "walls.m.file: triangle 2"),
    "stl_sliver_triangle": (stl_case(FLOOR + [[[0, 0, 0], [1, 0, 0], [0.5, 0.001, 0]]]), "triangle 2 of"),
    "stl_nan_vertex": (stl_case(FLOOR + [[[np.nan, 0, 0], [0.5, 0, 0], [1, 1, 0]]]), "walls.m.file: triangle 2"),
    "stl_inf_vertex": (stl_case(FLOOR + [[[np.inf, 0, 0], [0.5, 0, 0], [1, 1, 0]]]), "walls.m.file: triangle 2"),
    "mesh_at_scale_1e6": (stl_case(FLOOR, scale=1e6), "walls.m.scale"),
}


@pytest.mark.parametrize("name", sorted(DEFECTS))
def test_a_defect_caught_before_the_engine_is_exit_2(name: str, tmp_path: Path, no_engine_process: None) -> None:
    make, field = DEFECTS[name]
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(make(tmp_path)))
    assert_one_line_error(*run_cli(["run", str(tmp_path / "case.yaml"), "-o", str(tmp_path / "run")]), expected_code=2, field=field)


@pytest.mark.parametrize(("arguments", "environment", "field"), [
    (["run", "{case}", "--timeout", "-1"], {}, "--timeout"),
    (["run", "{case}", "--timeout", "nan"], {}, "--timeout"),
    (["run", "{case}"], {"DEMORCH_LIGGGHTS_MPI": "²"}, "DEMORCH_LIGGGHTS_MPI"),
])
def test_bad_run_settings_are_exit_2(arguments: list[str], environment: dict[str, str], field: str, tmp_path: Path,
                                      monkeypatch: pytest.MonkeyPatch, no_engine_process: None) -> None:
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case_data()))
    for name, value in environment.items():
        monkeypatch.setenv(name, value)
    command = [a.replace("{case}", str(tmp_path / "case.yaml")) for a in arguments] + ["-o", str(tmp_path / "run")]
    assert_one_line_error(*run_cli(command), expected_code=2, field=field)


def test_a_busy_run_directory_is_a_usage_error(tmp_path: Path, no_engine_process: None) -> None:
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case_data()))
    with locked(tmp_path / "run", wait=False):  # another run holds it
        result = run_cli(["run", str(tmp_path / "case.yaml"), "-o", str(tmp_path / "run")])
    assert_one_line_error(*result, expected_code=2, field="in use by another run")


def test_an_unwritable_run_directory_is_a_usage_error(tmp_path: Path, no_engine_process: None) -> None:
    """A read-only directory; under root, whom permissions do not stop, a directory below a file."""
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case_data()))
    if os.geteuid() == 0:
        (tmp_path / "a_file").write_text("x")
        target = tmp_path / "a_file" / "run"
    else:
        (tmp_path / "locked").mkdir(mode=0o555)
        target = tmp_path / "locked" / "run"
    assert_one_line_error(*run_cli(["run", str(tmp_path / "case.yaml"), "-o", str(target)]), expected_code=2, field="--output: cannot write")


def test_an_orientation_of_1e200_is_the_identity_and_a_unit_one_is_kept() -> None:
    """The normaliser squared 1e200 to infinity and divided the quaternion to zeros."""
    data = case_data()
    data["shapes"] = [{"name": "b", "length": 0.031, "width": 0.015, "thickness": 0.008}]
    data["bodies"] = {"clumps": [{"shape": "b", "material": "glass", "position": [0, 0, 1], "orientation": [1e200, 0, 0, 0]},
                                 {"shape": "b", "material": "glass", "position": [0, 0, 2], "orientation": [0.6, 0.0, 0.8, 0.0]}]}
    clumps = parse_case(data).bodies.clumps
    assert clumps[0].orientation == (1.0, 0.0, 0.0, 0.0)
    assert clumps[1].orientation == (0.6, 0.0, 0.8, 0.0)


def test_an_output_interval_below_the_step_is_reported_with_what_is_used() -> None:
    case = parse_case(case_data(time={"step": 1e-5, "duration": 0.02, "output_interval": 1e-9}))
    (note,) = preflight.notes(case, physics.schedule(case))
    assert note.startswith("time.output_interval: 1e-09 s") and "every 1 step (1e-05 s), 2001 frames" in note
    plain = parse_case(case_data())
    assert preflight.notes(plain, physics.schedule(plain)) == []


def test_a_case_file_over_the_cap_is_refused_by_what_is_read(tmp_path: Path, no_engine_process: None) -> None:
    path = tmp_path / "case.yaml"
    with path.open("wb") as handle:
        handle.truncate(17 * 2**20)  # sparse: 17 MB of zeros on no disk
    assert_one_line_error(*run_cli(["run", str(path), "-o", str(tmp_path / "run")]), expected_code=2, field="is over 16 MB")
