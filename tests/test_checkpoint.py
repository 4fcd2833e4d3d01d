"""Checkpoints and resume: a run cut off mid-way continues from its last checkpoint and ends as an
uninterrupted run does, on every engine; campaigns resume their cut-off points.

The engines' continued runs are compared with uninterrupted ones to the bit: LIGGGHTS restart
files carry atoms, clumps and contact history; YADE's saved scene carries interactions and engine
state; cocd's state is its arrays (no contact history to lose). Measured 2026-11-30: identical
positions and velocities on all three (|Δ| = 0).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from orchestrator.case import Case, CaseError, parse_case
from orchestrator.engines import RunOptions, build_stamp, get_adapter
from orchestrator.engines import checkpoint
from orchestrator.engines.checkpoint import Resume, merge, next_segment, segment_files, segment_name
from orchestrator.engines.liggghts import adapter as liggghts_adapter
from orchestrator.engines.options import CHECKPOINT_ENV
from orchestrator.results import read_results
from orchestrator.plan import RunPlan, make_plan
from orchestrator.runner import resume_point, run_case

from conftest import requires_liggghts, requires_yade

REPO = Path(__file__).resolve().parent.parent
ENGINES = [pytest.param("liggghts", marks=[pytest.mark.engine, requires_liggghts]),
           pytest.param("yade", marks=[pytest.mark.engine, requires_yade]),
           pytest.param("cocd", marks=pytest.mark.engine)]


def trap_case(engine: str, duration: float = 0.3, **extra: object) -> Case:
    """Three spheres: one on a trap removed at 0.1 s that then falls 2 cm, two colliding on the
    floor (contact history on walls and between spheres, a wall removal)."""
    return parse_case({**extra, 
        "name": "trap", "engine": engine,
        "time": {"duration": duration, "output_interval": 0.01},
        "materials": [{"name": "glass", "density": 2500.0}, {"name": "steel", "density": 7800.0}],
        "contacts": [{"materials": ["glass", "glass"], "en2": 0.5, "mu": 0.3, "kn": 1e4, "kt_over_kn": 0.5},
                     {"materials": ["glass", "steel"], "en2": 0.5, "mu": 0.3, "kn": 2e4, "kt_over_kn": 0.5}],
        "bodies": {"spheres": [
            {"material": "glass", "radius": 0.005, "position": [-0.03, 0.0, 0.026], "velocity": [0.05, 0.0, 0.0]},
            {"material": "glass", "radius": 0.005, "position": [0.02, 0.0, 0.006], "velocity": [0.2, 0.0, 0.0]},
            {"material": "glass", "radius": 0.005, "position": [0.04, 0.001, 0.006]},
        ]},
        "walls": [
            {"name": "trap", "type": "rectangle", "material": "steel", "origin": [-0.05, -0.05, 0.02], "edge1": [0.04, 0, 0],
             "edge2": [0, 0.1, 0], "remove_at": 0.1},
            {"name": "floor", "type": "rectangle", "material": "steel", "origin": [-0.08, -0.08, 0.0], "edge1": [0.16, 0, 0],
             "edge2": [0, 0.16, 0]},
        ],
        "domain": {"lower": [-0.1, -0.1, -0.01], "upper": [0.1, 0.1, 0.06]},
    })


# A stop at rest checked every 0.05 s from 0.1 s on (never at rest here: the spheres keep rolling),
# so a checkpoint falls on a check; and contacts recorded where the engine can.
REST_AND_CONTACTS = {"time": {"duration": 0.3, "output_interval": 0.01,
                              "stop_at_rest": {"speed": 1e-6, "after": 0.1, "check_interval": 0.05}}}


@pytest.mark.parametrize("variant", ["plain", "rest and contacts", "planar"])
@pytest.mark.parametrize("engine", ENGINES)
def test_a_run_continued_from_any_checkpoint_ends_as_the_uninterrupted_one(engine: str, variant: str, tmp_path: Path) -> None:
    """Checkpoints every 0.1 s (the first at the trap's removal step); the run continued from each the
    engine offers, in turn, as new segments, reads back the uninterrupted run's frames (and
    contacts) exactly, each frame once. LIGGGHTS does not offer the one at the removal step (its
    adapter says why). `planar` (cocd only): in 2D cocd's default solver warm-starts each step from
    the last one's impulses, which the checkpoint must carry for the continued run to be exact."""
    if variant == "planar" and engine != "cocd":
        pytest.skip("the planar variant checks cocd's warm start")
    extra = {"plain": {}, "planar": {"planar": True}}.get(variant, {**REST_AND_CONTACTS, "record_contacts": engine != "cocd"})
    case = trap_case(engine, **extra)
    adapter = get_adapter(engine, RunOptions(checkpoint_interval=0.1))
    plan = make_plan(case, tmp_path)
    adapter.write_input(plan, tmp_path)
    adapter.execute(plan, tmp_path)
    whole = adapter.read_output(plan, tmp_path)
    kept = checkpoint.usable(tmp_path, adapter.checkpoint_ext)
    steps = [step for step, _ in kept]
    assert len(steps) == 2 and steps[0] * 2 == steps[1]  # the two newest kept: 0.1 and 0.2 s
    found = adapter.usable_checkpoints(plan, tmp_path)
    assert [step for step, _ in found] == (steps[1:] if engine == "liggghts" else steps)
    for segment, (step, path) in enumerate(found, start=1):
        resumed = plan.resumed(Resume(segment, step, path.name))
        adapter.write_input(resumed, tmp_path)
        adapter.execute(resumed, tmp_path)
        continued = adapter.read_output(resumed, tmp_path)
        assert np.array_equal(continued.time, whole.time)
        assert np.array_equal(continued.position, whole.position, equal_nan=True)
        assert np.array_equal(continued.velocity, whole.velocity, equal_nan=True)
        assert np.array_equal(continued.angular_velocity, whole.angular_velocity, equal_nan=True)
        if case.record_contacts:
            assert np.array_equal(continued.contacts.offset, whole.contacts.offset)
            assert np.array_equal(continued.contacts.normal_force, whole.contacts.normal_force)
            assert np.array_equal(continued.contacts.wall, whole.contacts.wall)
    assert len(segment_files(tmp_path, "engine.log")) == 1 + len(found)


def _demorch(*arguments: str, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "orchestrator.cli", *arguments], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True, env={**os.environ, "PYTHONPATH": str(REPO)})


def _kill_after_a_checkpoint(process: subprocess.Popen, case: Case, directory: Path) -> None:
    """SIGKILL the orchestrator and its engine (one process group) once a checkpoint is usable."""
    adapter = get_adapter(case.engine.value)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if directory.exists() and checkpoint.usable(directory, adapter.checkpoint_ext):
            break
        assert process.poll() is None, "the run ended before a checkpoint could be used"
        time.sleep(0.02)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()


@pytest.mark.engine
@requires_liggghts
def test_a_settling_pile_killed_with_sigkill_resumes_on_demorch_run(tmp_path: Path) -> None:
    """A pile of 20 bricks settling until at rest (the rest checks run in a loop of short runs), the
    orchestrator and LIGGGHTS killed with SIGKILL after a checkpoint: `demorch run` on the same
    directory says it resumes, and ends with the uninterrupted run's frames, every frame once; the
    record counts two segments and the simulated time lost (at most one checkpoint interval and
    one frame)."""
    from conftest import pile_case

    data = pile_case("liggghts", count=20, duration=0.8).model_dump(mode="json")
    data["time"]["stop_at_rest"] = {"speed": 0.02, "after": 0.2, "check_interval": 0.02}
    (tmp_path / "pile.yaml").write_text(yaml.safe_dump(data))
    case = parse_case(data)
    reference = run_case(case, tmp_path, tmp_path / "whole")
    process = _demorch("run", "pile.yaml", "-o", "cut", cwd=tmp_path)
    _kill_after_a_checkpoint(process, case, tmp_path / "cut")
    assert json.loads((tmp_path / "cut" / "run.json").read_text())["status"] == "running"
    resumed = _demorch("run", "pile.yaml", "-o", "cut", cwd=tmp_path)
    output = resumed.communicate(timeout=300)[0]
    assert resumed.returncode == 0, output[-2000:]
    assert "resuming from the checkpoint at t = " in output
    whole, cut = read_results(tmp_path / "whole" / "results.h5"), read_results(tmp_path / "cut" / "results.h5")
    assert np.array_equal(whole.time, cut.time) and np.all(np.diff(cut.time) > 0)
    assert np.array_equal(whole.position, cut.position) and np.array_equal(whole.orientation, cut.orientation)
    record = json.loads((tmp_path / "cut" / "run.json").read_text())
    assert [s["segment"] for s in record["segments"]] == [0, 1]
    interval = case.time.duration / 10 + case.time.output_interval
    assert 0.0 <= record["simulated_time_lost_s"] <= interval + 1e-9
    assert record["metrics"] == reference["metrics"]
    assert not checkpoint.checkpoints(tmp_path / "cut", "restart")  # a completed run keeps none


@pytest.mark.engine
@requires_liggghts
def test_a_campaign_whose_dask_workers_are_killed_resumes_every_run(tmp_path: Path) -> None:
    """Two points on a Dask LocalCluster of two workers; once a point has a usable checkpoint, both
    worker processes are killed (SIGKILL). Their nannies restart them, Dask runs the tasks again:
    every point completes, and each that had a usable checkpoint continues from it (two segments)."""
    from distributed import Client, LocalCluster

    from orchestrator.campaign import store
    from orchestrator.campaign.execute import run_campaign

    base = trap_case("liggghts", duration=4.0).model_dump(mode="json")
    base["walls"][1]["edge1"], base["walls"][1]["edge2"] = [0.6, 0, 0], [0, 0.6, 0]
    base["walls"][1]["origin"] = [-0.3, -0.3, 0.0]
    base["domain"] = {"lower": [-0.35, -0.35, -0.01], "upper": [0.35, 0.35, 0.06]}
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(base))
    (tmp_path / "campaign.yaml").write_text(yaml.safe_dump(
        {"name": "killed", "base": "base.yaml", "designs": [{"kind": "grid", "parameters": {"bodies.spheres.1.velocity.0": [0.1, 0.15]}}]}))
    out = tmp_path / "out"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
        outcome: dict[str, object] = {}
        runner = threading.Thread(target=lambda: outcome.update(counts=run_campaign(
            tmp_path / "campaign.yaml", out, jobs=2, executor="dask", dask_address=cluster.scheduler_address)))
        runner.start()
        deadline = time.monotonic() + 120
        cut: list[str] = []
        while time.monotonic() < deadline and not cut:
            points = list((out / "runs").glob("*")) if (out / "runs").exists() else []
            cut = [p.name for p in points if checkpoint.usable(p, "restart")]
            time.sleep(0.02)
        assert cut, "no point reached a checkpoint"
        for pid in client.run(os.getpid).values():
            os.kill(pid, signal.SIGKILL)
        runner.join(timeout=300)
    counts = outcome["counts"]
    assert counts.done == 2 and counts.failed == 0
    for point in (out / "runs").glob("*"):
        assert store.status(point) == "completed"
        if point.name in cut:
            record = json.loads((point / "run.json").read_text())
            assert [s["segment"] for s in record["segments"]] == [0, 1], record["segments"]


# -- rules, without an engine -------------------------------------------------------------------
def test_segment_files_are_named_and_ordered_by_segment(tmp_path: Path) -> None:
    for name in ("frames.bin", "frames.2.bin", "frames.10.bin", "frames.x.bin", "engine.log", "engine.1.log"):
        (tmp_path / name).write_text("")
    assert [p.name for p in segment_files(tmp_path, "frames.bin")] == ["frames.bin", "frames.2.bin", "frames.10.bin"]
    assert next_segment(tmp_path, "engine.log") == 2
    assert segment_name("in.liggghts", 0) == "in.liggghts" and segment_name("checkpoint.yade.gz", 3) == "checkpoint.3.yade.gz"


def test_a_later_segment_replaces_frames_from_its_first_step_on() -> None:
    steps, frames = merge([([0, 10, 20, 30], list("abcd")), ([20, 30, 40], list("CDE")), ([], []), ([40, 50], list("xy"))])
    assert steps == [0, 10, 20, 30, 40, 50] and frames == list("abCDxy")


def test_a_checkpoint_counts_once_sealed_and_the_two_newest_sealed_are_kept(tmp_path: Path) -> None:
    for step in (100, 200, 300, 400):
        (tmp_path / f"checkpoint.{step}.restart").write_text(f"state {step}")
    assert checkpoint.usable(tmp_path, "restart") == []  # nothing sealed yet
    checkpoint.seal(tmp_path, "restart", 300)  # the engine went past 300: 400 may be half written
    assert [s for s, _ in checkpoint.usable(tmp_path, "restart")] == [100, 200, 300]
    assert all(checkpoint.verified(path) for _, path in checkpoint.usable(tmp_path, "restart"))
    checkpoint.prune(tmp_path, "restart")
    assert [s for s, _ in checkpoint.checkpoints(tmp_path, "restart")] == [200, 300, 400]
    assert not (tmp_path / "checkpoint.100.restart.sha256").exists()


def test_a_liggghts_checkpoint_is_sealed_only_once_a_later_step_is_reported(tmp_path: Path) -> None:
    """LIGGGHTS prints the thermo line of step S, ends the sub-run, then writes checkpoint S
    (`write_restart`), then prints S again as the next sub-run starts: at either line of S the file
    may still be being written, so it is sealed at the next step reported."""
    from orchestrator.engines.liggghts.adapter import ThermoWatcher, seal_behind

    watcher = ThermoWatcher(1e-5, seal_behind(tmp_path, total=9330))
    (tmp_path / "checkpoint.3110.restart").write_bytes(b"half of a restart file")
    for line in ("    3110       27  4.5002302e-18 ", "    3110       27  4.5002302e-18 "):
        watcher(line)
        assert checkpoint.usable(tmp_path, "restart") == []
    watcher("    3732       27  5.5879222e-21 ")
    assert [step for step, _ in checkpoint.usable(tmp_path, "restart")] == [3110]
    (tmp_path / "checkpoint.9330.restart").write_bytes(b"the last step")
    watcher("    9330       27  1.0e-21 ")
    assert [step for step, _ in checkpoint.usable(tmp_path, "restart")] == [3110]  # the last step's stays unsealed


def test_the_checkpoint_interval_is_whole_output_intervals_and_can_be_turned_off(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(CHECKPOINT_ENV, raising=False)
    plan = dict(duration=1.0, dt=1e-4, output_every=100, total_steps=10_000)
    assert RunOptions().checkpoint_steps(**plan) == 1000  # a tenth of the run
    assert RunOptions(checkpoint_interval=0.026).checkpoint_steps(**plan) == 300  # the nearest whole frame
    assert RunOptions(checkpoint_interval=0).checkpoint_steps(**plan) is None
    assert RunOptions(checkpoint_interval=2.0).checkpoint_steps(**plan) is None  # longer than the run
    monkeypatch.setenv(CHECKPOINT_ENV, "0.05")
    assert RunOptions().checkpoint_steps(**plan) == 500
    monkeypatch.setenv(CHECKPOINT_ENV, "soon")
    with pytest.raises(CaseError, match=rf"{CHECKPOINT_ENV}='soon': .*allowed range: 0 \(none\) to 10000"):
        RunOptions().checkpoint_steps(**plan)


@pytest.mark.parametrize("value", ["-1", "nan", "inf", "1e9"])
def test_a_bad_checkpoint_interval_is_one_line_naming_the_option(value: str) -> None:
    result = subprocess.run([sys.executable, "-m", "orchestrator.cli", "--checkpoint-interval", value, "run", "cases/free_fall.yaml"],
                            cwd=REPO, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "checkpoint-interval" in lines[0], result.stderr


class _Adapter:
    """What resume_point asks of an adapter."""

    checkpoint_ext = "npz"

    def __init__(self, last: int | None):
        self.last = last

    def last_frame_step(self, plan: RunPlan, rundir: Path) -> int | None:
        return self.last

    def usable_checkpoints(self, plan: RunPlan, rundir: Path) -> list[tuple[int, Path]]:
        return checkpoint.usable(rundir, self.checkpoint_ext)


def _cut_off(directory: Path, case: Case, status: str = "running", run_id: str | None = None) -> None:
    from orchestrator import rundir

    directory.mkdir(exist_ok=True)
    rundir.save_inputs(directory, case)
    (directory / "run.json").write_text(json.dumps({"status": status, "run_id": run_id or rundir.run_id(case, build_stamp(case.engine.value))}))
    (directory / "engine.log").write_text("")
    for step in (50, 100, 150):
        (directory / f"checkpoint.{step}.npz").write_text(f"state {step}")
    checkpoint.seal(directory, "npz", 100)  # 150 was being written when the run was cut off


def test_only_a_cut_off_run_of_the_same_inputs_with_a_finished_checkpoint_resumes(tmp_path: Path) -> None:
    case = trap_case("cocd")
    _cut_off(tmp_path, case)
    plan = make_plan(case, tmp_path)
    assert resume_point(plan, tmp_path, _Adapter(last=160)) == Resume(1, 100, "checkpoint.100.npz")  # 150 has no seal
    # A resumed segment cut off right after its first frame (at its checkpoint's step) goes on from the same checkpoint.
    assert resume_point(plan, tmp_path, _Adapter(last=100)) == Resume(1, 100, "checkpoint.100.npz")
    other = make_plan(trap_case("cocd", duration=0.4), tmp_path)
    assert resume_point(other, tmp_path, _Adapter(last=120)) is None  # other inputs: start afresh
    _cut_off(tmp_path, case, status="failed")
    assert resume_point(plan, tmp_path, _Adapter(last=120)) is None


@pytest.mark.parametrize("damage", ["truncated", "zeroed", "random", "empty", "one number changed"])
def test_a_damaged_checkpoint_is_set_aside_and_the_older_one_used(damage: str, tmp_path: Path) -> None:
    """Never restart from zero while a checkpoint that matches its seal exists; never delete the damaged one."""
    case = trap_case("cocd")
    _cut_off(tmp_path, case)
    newest = tmp_path / "checkpoint.100.npz"
    text = newest.read_bytes()
    newest.write_bytes({"truncated": text[:3], "zeroed": bytes(len(text)), "random": os.urandom(len(text)), "empty": b"",
                        "one number changed": text.replace(b"100", b"101")}[damage])
    plan = make_plan(case, tmp_path)
    assert resume_point(plan, tmp_path, _Adapter(last=160)) == Resume(1, 50, "checkpoint.50.npz")
    assert (tmp_path / "checkpoint.100.npz.damaged").read_bytes() == newest.with_name("checkpoint.100.npz.damaged").read_bytes()
    assert not newest.exists() and (tmp_path / "checkpoint.100.npz.damaged.sha256").exists()
    (tmp_path / "checkpoint.50.npz").write_bytes(b"")  # the older one damaged too: nothing verified is left
    assert resume_point(plan, tmp_path, _Adapter(last=160)) is None
    assert sorted(p.name for p in tmp_path.glob("*.damaged")) == ["checkpoint.100.npz.damaged", "checkpoint.50.npz.damaged"]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_run_killed_with_sigkill_resumes_on_demorch_run_on_every_engine(engine: str, tmp_path: Path) -> None:
    """The trap case, its orchestrator and engine killed with SIGKILL once a checkpoint is usable;
    `demorch run` on the same directory continues it and ends with the uninterrupted run's frames
    exactly, every frame once, two segments on record."""
    data = trap_case(engine, duration=0.6).model_dump(mode="json")
    (tmp_path / "trap.yaml").write_text(yaml.safe_dump(data))
    case = parse_case(data)
    run_case(case, tmp_path, tmp_path / "whole")
    process = _demorch("run", "trap.yaml", "-o", "cut", cwd=tmp_path)
    _kill_after_a_checkpoint(process, case, tmp_path / "cut")
    resumed = _demorch("run", "trap.yaml", "-o", "cut", cwd=tmp_path)
    output = resumed.communicate(timeout=300)[0]
    assert resumed.returncode == 0 and "resuming from the checkpoint" in output, output[-2000:]
    whole, cut = read_results(tmp_path / "whole" / "results.h5"), read_results(tmp_path / "cut" / "results.h5")
    assert np.array_equal(whole.time, cut.time)
    assert np.array_equal(whole.position, cut.position) and np.array_equal(whole.velocity, cut.velocity)
    assert [s["segment"] for s in json.loads((tmp_path / "cut" / "run.json").read_text())["segments"]] == [0, 1]


def colliding_spheres(engine: str, law: str) -> Case:
    """The trap case with two more spheres thrown into the others: pairs meet, part and meet again."""
    data = trap_case(engine, duration=0.6).model_dump(mode="json")
    for pair in data["contacts"]:
        pair["law"] = law
    data["bodies"]["spheres"] += [
        {"material": "glass", "radius": 0.005, "position": [0.06, 0.0, 0.006], "velocity": [-0.3, 0.0, 0.0]},
        {"material": "glass", "radius": 0.005, "position": [0.03, 0.012, 0.006], "velocity": [0.0, -0.2, 0.0]},
    ]
    return parse_case(data)


@pytest.mark.parametrize(("engine", "law"), [pytest.param("liggghts", "bilinear", marks=[pytest.mark.engine, requires_liggghts]),
                                             pytest.param("liggghts", "linear", marks=[pytest.mark.engine, requires_liggghts]),
                                             pytest.param("yade", "bilinear", marks=[pytest.mark.engine, requires_yade]),
                                             pytest.param("cocd", "linear", marks=pytest.mark.engine)])
def test_writing_checkpoints_leaves_the_run_unchanged(engine: str, law: str, tmp_path: Path) -> None:
    """A run with a checkpoint every 0.05 s equals one without, to the bit (on LIGGGHTS a restart
    file forces a neighbour-list rebuild: the law's history must come through it unchanged)."""
    case = colliding_spheres(engine, law)
    runs = []
    for interval in (0.0, 0.05):
        directory = tmp_path / str(interval)
        directory.mkdir()
        adapter = get_adapter(engine, RunOptions(checkpoint_interval=interval))
        plan = make_plan(case, tmp_path)
        adapter.write_input(plan, directory)
        adapter.execute(plan, directory)
        runs.append(adapter.read_output(plan, directory))
    assert np.array_equal(runs[0].position, runs[1].position) and np.array_equal(runs[0].velocity, runs[1].velocity)


def test_liggghts_loop_times_are_read_per_sub_run_set_ups_included() -> None:
    """The benchmarks' engine cost: every "Loop time" line of a log, in order (a zero-step set-up too)."""
    log = ("Loop time of 2.82689 on 2 procs for 805 steps with 1921 atoms, finish time Wed Dec  2 06:07:06 2026\n"
           "  16100     1921      7.8964854\n"
           "Loop time of 1.427e-06 on 1 procs for 0 steps with 1920 atoms, finish time Wed Dec  2 06:22:31 2026\n")
    assert liggghts_adapter.loop_times(log) == [(2.82689, 805), (1.427e-06, 0)]


def test_clearing_a_completed_runs_checkpoints_takes_orphaned_and_half_written_seals_too(tmp_path: Path) -> None:
    """A kill between a pruned checkpoint's deletion and its seal's, or while a seal is written, leaves
    a seal alone: the run's completion clears those too, and keeps what was set aside as damaged."""
    names = ["checkpoint.100.restart", "checkpoint.100.restart.sha256",  # a checkpoint and its seal
             "checkpoint.50.restart.sha256",  # a seal whose checkpoint was pruned
             "checkpoint.150.restart.sha256.tmp",  # a seal being written
             "checkpoint.20.restart.damaged", "checkpoint.20.restart.damaged.sha256",  # set aside
             "checkpoint.100.yade", "frames.bin"]  # another engine's, and no checkpoint at all
    for name in names:
        (tmp_path / name).write_text("x")
    checkpoint.clear(tmp_path, "restart")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checkpoint.100.yade", "checkpoint.20.restart.damaged",
                                                          "checkpoint.20.restart.damaged.sha256", "frames.bin"]
