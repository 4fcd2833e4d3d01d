"""Campaigns on real engines: a 2 × 3 grid, resuming, SIGKILL in the middle, failures, Dask."""

from __future__ import annotations

import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from orchestrator import rundir
from orchestrator.campaign import store
from orchestrator.campaign import execute
from orchestrator.campaign.execute import plan_campaign, run_campaign
from orchestrator.campaign.spec import CampaignSpec, design_points, evaluate, expand, load_campaign
from orchestrator.case import CaseError
from orchestrator.engines import build_stamp
from orchestrator.results import read_results

from conftest import assert_one_line_error, requires_liggghts, run_cli

REPO = Path(__file__).resolve().parent.parent
BASE = REPO / "cases" / "free_fall.yaml"


def write_campaign(directory: Path, designs: list[dict], **extra: object) -> Path:
    """A campaign over the free-fall case shortened to 0.05 s (≈ 0.3 s per LIGGGHTS run)."""
    base = yaml.safe_load(BASE.read_text())
    base["time"]["duration"] = 0.05
    base_path = directory / "base.yaml"
    base_path.write_text(yaml.safe_dump(base))
    path = directory / "campaign.yaml"
    path.write_text(yaml.safe_dump({"name": "grid", "base": "base.yaml", "designs": designs, **extra}))
    return path


GRID = [{"kind": "grid", "parameters": {"bodies.spheres.0.velocity": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], "gravity.2": [-9.81, -5.0, -1.0]}}]


def test_designs_expand_as_documented(tmp_path: Path) -> None:
    spec, base = load_campaign(write_campaign(tmp_path, GRID, replicates=2, derived={"contacts.0.kt_over_kn": "contacts.0.mu * 0.5"}))
    expanded = expand(spec, base)
    assert len(expanded) == 2 * 3 * 2
    assert len({rundir.run_id(case, build_stamp(case.engine.value)) for _, case in expanded}) == 12  # replicates differ by seed
    assert all(case.contacts[0].kt_over_kn == pytest.approx(0.25) for _, case in expanded)
    lhs = design_points(CampaignSpec.model_validate({"name": "x", "base": "b", "designs": [{"kind": "lhs", "samples": 10, "ranges": {"a": [0, 1], "b": [5, 6]}}]}).designs[0])
    assert len(lhs) == 10 and all(0 <= p["a"] <= 1 and 5 <= p["b"] <= 6 for p in lhs)
    # Latin hypercube: one sample in each tenth of each range.
    assert sorted(int(p["a"] * 10) for p in lhs) == list(range(10))


def test_derived_expressions_are_arithmetic_only() -> None:
    data = {"contacts": [{"kn": 2.0}]}
    assert evaluate("contacts.0.kn * 3 + 1", data) == 7.0
    with pytest.raises(CaseError):
        evaluate("__import__('os').system('true')", data)


def test_unknown_parameter_path_is_a_clear_error(tmp_path: Path) -> None:
    spec, base = load_campaign(write_campaign(tmp_path, [{"kind": "grid", "parameters": {"contacts.0.mew": [0.1]}}]))
    with pytest.raises(CaseError, match=r"has no 'contacts.0.mew'"):
        expand(spec, base)


def test_jobs_below_one_write_nothing_and_workers_are_capped_at_the_points_to_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """-j takes 1 … : below is an error before points.json; the local pool and a Dask cluster the
    launch starts get at most one worker per point to run, and none start when nothing is left."""
    campaign, out = write_campaign(tmp_path, [{"kind": "grid", "parameters": {"gravity.2": [-9.81, -5.0]}}]), tmp_path / "out"
    for jobs in (0, -1):
        with pytest.raises(CaseError, match=rf"--jobs: {jobs} runs at once; allowed: at least 1"):
            run_campaign(campaign, out, jobs=jobs)
    assert not out.exists()
    workers: list[tuple[str, int]] = []

    def local(plan: execute.LaunchPlan, jobs: int):  # no engine: every point reported failed, nothing written
        workers.append(("local", jobs))
        yield from ({"run_id": identifier, "status": "failed", "error": "not run"} for identifier in plan.to_run)

    monkeypatch.setattr(execute, "local_results", local)
    monkeypatch.setattr(execute, "dask_results", lambda plan, jobs, address=None, start=None: (workers.append(("dask", jobs)), local(plan, jobs))[1])
    assert run_campaign(campaign, out, jobs=8).failed == 2
    assert run_campaign(campaign, out, jobs=8, executor="dask").failed == 2
    assert workers == [("local", 2), ("dask", 2), ("local", 2)]
    monkeypatch.setattr(store, "status", lambda directory: "completed")
    assert run_campaign(campaign, out, jobs=8, executor="dask").skipped == 2
    assert len(workers) == 3  # nothing to run: no pool, no cluster


def test_a_directory_holding_another_campaign_is_refused_and_the_same_one_resumes(tmp_path: Path) -> None:
    """campaign.json records the name, base and designs: another campaign into that directory is
    one line (exit 2) and points.json stays as it was; the same campaign plans again."""
    campaign, out = write_campaign(tmp_path, GRID), tmp_path / "out"
    first = plan_campaign(campaign, out)
    points = (out / store.POINTS).read_text()
    other = tmp_path / "other.yaml"
    other.write_text(yaml.safe_dump({"name": "other", "base": "base.yaml", "designs": [{"kind": "grid", "parameters": {"gravity.2": [-3.0]}}]}))
    assert_one_line_error(*run_cli(["campaign", "run", str(other), "-o", str(out)]), expected_code=2,
                          field=f"--output: {out} holds campaign 'grid' (base {tmp_path / 'base.yaml'}), and campaign 'other' differs in its name and designs")
    assert (out / store.POINTS).read_text() == points and not (out / store.INDEX).exists()
    assert plan_campaign(campaign, out).points == first.points  # a relaunch
    (out / store.CAMPAIGN).unlink()  # a directory from before campaign.json: the parameters its points vary tell
    with pytest.raises(CaseError, match=r"holds another campaign \(varying \['bodies.spheres.0.velocity', 'gravity.2'\]\)"):
        plan_campaign(other, out)
    plan_campaign(campaign, out)
    assert (out / store.CAMPAIGN).exists()


@requires_liggghts
@pytest.mark.engine
def test_grid_completes_then_resumes_exactly(tmp_path: Path) -> None:
    campaign = write_campaign(tmp_path, GRID)
    out = tmp_path / "out"
    first = run_campaign(campaign, out, jobs=2)
    assert (first.done, first.failed, first.skipped) == (6, 0, 0)
    index = pd.read_parquet(out / "index.parquet")
    assert len(index) == 6 and set(index["status"]) == {"completed"}
    # Final vertical speed = g t for each gravity of the grid: the runs are the cases they claim.
    for _, row in index.iterrows():
        velocity = read_results(store.run_dir(out, row["run_id"]) / "results.h5").velocity[-1, 0, 2]
        assert velocity == pytest.approx(row["param.gravity.2"] * 0.05, rel=1e-6)
    again = run_campaign(campaign, out, jobs=2)
    assert (again.done, again.skipped) == (0, 6)
    victim = index["run_id"].iloc[3]
    (store.run_dir(out, victim) / "results.h5").unlink()
    third = run_campaign(campaign, out, jobs=2)
    assert (third.done, third.skipped) == (1, 5)
    assert store.status(store.run_dir(out, victim)) == "completed"


@requires_liggghts
@pytest.mark.engine
def test_a_crashing_run_is_recorded_and_the_others_complete(tmp_path: Path) -> None:
    # A 1 mm domain: the sphere leaves it at once and LIGGGHTS loses it.
    designs = [{"kind": "zip", "parameters": {"domain": [None, {"lower": [-0.1, -0.1, 0.999], "upper": [0.1, 0.1, 1.1]}]}}]
    campaign = write_campaign(tmp_path, designs)
    counts = run_campaign(campaign, tmp_path / "out", jobs=2)
    assert (counts.done, counts.failed) == (1, 1)
    index = pd.read_parquet(tmp_path / "out" / "index.parquet")
    failed = index[index["status"] == "failed"].iloc[0]
    assert "left the simulation domain" in failed["error"]
    import json

    record = json.loads((store.run_dir(tmp_path / "out", failed["run_id"]) / "run.json").read_text())
    assert record["log_tail"], "a failed run keeps its log tail"


@requires_liggghts
@pytest.mark.engine
def test_sigkill_in_the_middle_then_relaunch(tmp_path: Path) -> None:
    """Kill the campaign process with SIGKILL mid-way; the relaunch finishes without duplicates."""
    designs = [{"kind": "grid", "parameters": {"gravity.2": [-9.81, -9.0, -8.0, -7.0, -6.0, -5.0, -4.0, -3.0]}}]
    campaign = write_campaign(tmp_path, designs)
    base = yaml.safe_load((tmp_path / "base.yaml").read_text())
    base["time"]["duration"] = 0.3  # ≈ 1 s per run, so the kill lands mid-campaign
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(base))
    out = tmp_path / "out"
    command = [sys.executable, "-m", "orchestrator.cli", "campaign", "run", str(campaign), "-o", str(out), "-j", "2"]
    stderr_path = tmp_path / "campaign.stderr"
    with open(stderr_path, "w") as stderr:
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr, stdin=subprocess.DEVNULL, cwd=REPO)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        done = [d for d in (out / "runs").glob("*") if store.status(d) == "completed"] if (out / "runs").exists() else []
        if len(done) >= 2:
            break
        assert process.poll() is None, f"the campaign ended before it could be killed:\n{stderr_path.read_text()[-2000:]}"
        time.sleep(0.05)
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    time.sleep(0.5)  # let the kernel deliver PR_SET_PDEATHSIG to workers and engines
    finished_before = {d.name: (d / "results.h5").stat().st_mtime_ns for d in (out / "runs").glob("*") if store.status(d) == "completed"}
    assert 2 <= len(finished_before) < 8
    counts = run_campaign(campaign, out, jobs=2)
    assert counts.skipped == len(finished_before)
    assert counts.done + counts.skipped == 8 and counts.failed == 0
    runs = list((out / "runs").glob("*"))
    assert len(runs) == 8 and all(store.status(d) == "completed" for d in runs)  # no duplicates
    for name, mtime in finished_before.items():
        assert (out / "runs" / name / "results.h5").stat().st_mtime_ns == mtime  # untouched


@requires_liggghts
@pytest.mark.engine
def test_dask_local_cluster_gives_the_same_results(tmp_path: Path) -> None:
    campaign = write_campaign(tmp_path, GRID)
    run_campaign(campaign, tmp_path / "pool", jobs=2)
    run_campaign(campaign, tmp_path / "dask", jobs=2, executor="dask")
    pool = pd.read_parquet(tmp_path / "pool" / "index.parquet").set_index("run_id").sort_index()
    dask = pd.read_parquet(tmp_path / "dask" / "index.parquet").set_index("run_id").sort_index()
    assert list(pool.index) == list(dask.index)  # the same content-addressed runs
    metrics = [c for c in pool.columns if c.startswith("metric.")]
    pd.testing.assert_frame_equal(pool[metrics], dask[metrics], rtol=0, atol=0)


@requires_liggghts
@pytest.mark.engine
def test_a_shared_run_is_made_once_while_another_process_waits_for_it(tmp_path: Path) -> None:
    """Two workers need the same run (a packing, say): the first makes it under its directory's lock;
    the second, arriving while it runs, waits and reuses it (runner.ensure_run)."""
    import threading

    from conftest import free_fall_case
    from orchestrator import rundir
    from orchestrator.runner import ensure_run

    case = free_fall_case("liggghts")
    directory = tmp_path / rundir.run_id(case, build_stamp(case.engine.value))
    second: dict[str, object] = {}

    def arrive_while_running() -> None:
        deadline = time.monotonic() + 60.0
        while not rundir.is_locked(directory) and time.monotonic() < deadline:
            time.sleep(0.005)
        second["arrived_while_locked"] = rundir.is_locked(directory)
        second["result"] = ensure_run(case, tmp_path, "shared")
        second["returned"] = time.monotonic()

    waiter = threading.Thread(target=arrive_while_running)
    waiter.start()
    made = ensure_run(case, tmp_path, "shared")
    finished = time.monotonic()
    waiter.join(timeout=120.0)
    assert made == (directory, False)
    assert second["arrived_while_locked"] and second["result"] == (directory, True)
    assert second["returned"] >= finished - 0.5  # it came back only once the run was there
    assert [d.name for d in tmp_path.iterdir()] == [directory.name]  # one run, no attic


def test_a_random_pours_packing_hashes_to_its_run_id_when_read_back(tmp_path: Path) -> None:
    """A finished run is reused only if its saved case.json hashes to its run id (rundir.current).
    A random pour's bricks have random orientations, which validation must not move when read back
    (renormalising moved the last bits of a third of them: every pour looked stale and ran again)."""
    from orchestrator import rundir
    from orchestrator.studies.avalanche.study import load_study, packing_case

    case = packing_case(load_study(REPO / "cases" / "avalanche" / "random_pour_full_kn2e4.yaml"))
    assert len(case.bodies.clumps) > 6000  # about one in 150 of its orientations moved
    rundir.save_inputs(tmp_path, case)
    assert rundir.run_id(rundir.saved_case(tmp_path), build_stamp(case.engine.value)) == rundir.run_id(case, build_stamp(case.engine.value))


@settings(max_examples=300, deadline=None)
@given(st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 4).filter(lambda q: sum(v * v for v in q) > 1e-6))
def test_a_clumps_orientation_is_a_unit_quaternion_that_reads_back_to_the_bit(quaternion: tuple[float, ...]) -> None:
    from orchestrator.case import Clump

    clump = Clump(shape="brick", material="brick", position=(0.0, 0.0, 0.0), orientation=quaternion)
    # unit to 1e-12 in its norm, as the validator keeps it (the squared norm is then within 2e-12:
    # hypothesis found (0, 0, 1, 1e-6), whose norm is 1 + 5e-13)
    assert abs(math.hypot(*clump.orientation) - 1.0) <= 1e-12
    assert Clump.model_validate_json(clump.model_dump_json()).orientation == clump.orientation


# 72 s of the default run's budget; its two parts are checked apart, faster: one preparation shared by
# a campaign's points (tests/test_collapse.py, test_campaign_over_slopes_shares_the_preparation) and
# a worker waiting for a run another one is making (the test above). So it runs with -m slow.
@requires_liggghts
@pytest.mark.engine
@pytest.mark.slow
def test_avalanche_campaign_shares_one_packing(tmp_path: Path) -> None:
    """A campaign over an avalanche study: two board frictions, one packing made once and fed to both."""
    from conftest import tiny_study

    study = tiny_study("liggghts").model_dump(mode="json")
    (tmp_path / "study.yaml").write_text(yaml.safe_dump(study))
    campaign = tmp_path / "campaign.yaml"
    designs = [{"kind": "grid", "parameters": {"contacts.brick_board.mu": [0.40, 0.46]}}]
    campaign.write_text(yaml.safe_dump({"name": "boards", "base": "study.yaml", "designs": designs}))
    counts = run_campaign(campaign, tmp_path / "out", jobs=2)
    assert (counts.done, counts.failed) == (2, 0)
    packings = [d for d in (tmp_path / "out" / "packings").iterdir() if d.is_dir()]
    assert len(packings) == 1  # the second worker waited for the first one's packing and reused it
    index = pd.read_parquet(tmp_path / "out" / "index.parquet").set_index("param.contacts.brick_board.mu")
    assert set(index["status"]) == {"completed"}
    assert index.loc[0.40, "metric.deposit.x_cm"] > index.loc[0.46, "metric.deposit.x_cm"]  # less friction, further
    assert (index["metric.packing.apparent_density"] > 0).all()
    assert run_campaign(campaign, tmp_path / "out", jobs=2).skipped == 2  # relaunch: nothing to run


def test_example_avalanche_campaign_is_nine_studies_on_one_packing() -> None:
    from orchestrator.studies.avalanche.study import AvalancheStudy, packing_key

    spec, base = load_campaign(REPO / "campaigns" / "avalanche_small_board_contacts.yaml")
    expanded = expand(spec, base)
    assert len(expanded) == 9 and all(isinstance(study, AvalancheStudy) for _, study in expanded)
    assert len({rundir.run_id(study, build_stamp(study.engine.value)) for _, study in expanded}) == 9
    assert len({packing_key(study) for _, study in expanded}) == 1


SHIPPED_CAMPAIGNS = sorted(path for path in (REPO / "campaigns").rglob("*.yaml") if "designs" in yaml.safe_load(path.read_text()))


@pytest.mark.parametrize("path", SHIPPED_CAMPAIGNS, ids=lambda path: str(path.relative_to(REPO / "campaigns")))
def test_every_shipped_campaign_expands_to_valid_distinct_runs(path: Path) -> None:
    # Some shipped campaigns (study22_reduced: hours per run) are never run by the suite: at least
    # their base, overrides and every point must validate, and no two points may be the same run.
    spec, base = load_campaign(path)
    expanded = expand(spec, base)
    assert expanded, f"{path}: no points"
    assert len({rundir.run_id(point, build_stamp(point.engine.value)) for _, point in expanded}) == len(expanded)


@requires_liggghts
@pytest.mark.engine
def test_a_template_change_reruns_the_runs_it_affects(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The run id hashes the deck templates: after a template edit a relaunch runs every point again
    and reports the old runs as stale, never as completed."""
    templates = tmp_path / "templates"
    shutil.copytree(REPO / "templates", templates)
    monkeypatch.setenv("DEMORCH_TEMPLATES", str(templates))  # read by this process and the workers it spawns
    campaign = write_campaign(tmp_path, [{"kind": "grid", "parameters": {"gravity.2": [-9.81, -5.0]}}])
    first = run_campaign(campaign, tmp_path / "out", jobs=1)
    assert (first.done, first.skipped) == (2, 0)
    deck = templates / "liggghts" / "case.in.j2"
    deck.write_text(deck.read_text() + "# an edited template\n")
    second = run_campaign(campaign, tmp_path / "out", jobs=1)
    assert (second.done, second.skipped, second.failed) == (2, 0, 0)  # rerun, not reported as done
    statuses = sorted(store.build_index(tmp_path / "out")["status"])
    assert statuses == ["completed", "completed", "stale", "stale"]
    assert run_campaign(campaign, tmp_path / "out", jobs=1).skipped == 2  # and now current


@requires_liggghts
@pytest.mark.engine
def test_two_launches_on_one_directory_run_each_point_once(tmp_path: Path) -> None:
    """Two `campaign run` at once on one directory share the work through the run locks."""
    campaign = write_campaign(tmp_path, [{"kind": "grid", "parameters": {"gravity.2": [-9.81, -8.0, -7.0, -6.0, -5.0, -4.0]}}])
    out = tmp_path / "out"
    command = [sys.executable, "-m", "orchestrator.cli", "campaign", "run", str(campaign), "-o", str(out), "-j", "1"]
    launches = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=tmp_path) for _ in range(2)]
    outputs = [launch.communicate(timeout=300)[0] for launch in launches]
    assert all(launch.returncode == 0 for launch in launches), outputs
    ran = [int(line.split(": ", 1)[1].split(" run,")[0]) for text in outputs for line in text.splitlines() if " run, " in line]
    assert len(ran) == 2 and sum(ran) == 6, outputs  # each point run by exactly one of the two
    runs = list((out / "runs").iterdir())
    assert len(runs) == 6 and all(store.status(d) == "completed" for d in runs)
    assert not (out / "attic").exists()  # no attempt was interrupted or repeated


@pytest.mark.engine
def test_a_campaign_file_with_engine_cocd_runs(tmp_path: Path) -> None:
    """`engine:` in a campaign file accepts every engine of the registry, cocd included."""
    base = {
        "name": "rest", "time": {"duration": 0.02, "output_interval": 0.01},
        "materials": [{"name": "ball", "density": 2500.0}, {"name": "floor", "density": 2500.0}],
        "contacts": [{"materials": ["ball", "ball"], "en2": 0.5, "mu": 0.5, "kn": 1.0e5, "kt_over_kn": 0.4},
                     {"materials": ["ball", "floor"], "en2": 0.5, "mu": 0.5, "kn": 1.0e5, "kt_over_kn": 0.4}],
        "walls": [{"type": "rectangle", "name": "floor", "material": "floor", "origin": [-0.1, -0.1, 0.0],
                   "edge1": [0.2, 0.0, 0.0], "edge2": [0.0, 0.2, 0.0]}],
        "bodies": {"spheres": [{"material": "ball", "radius": 0.005, "position": [0.0, 0.0, 0.005]}]},
    }
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(base))
    campaign = tmp_path / "campaign.yaml"
    campaign.write_text(yaml.safe_dump({"name": "cocd", "base": "base.yaml", "engine": "cocd",
                                        "designs": [{"kind": "grid", "parameters": {"contacts.1.mu": [0.2, 0.5]}}]}))
    counts = run_campaign(campaign, tmp_path / "out", jobs=1)
    assert (counts.done, counts.failed) == (2, 0)
    index = store.build_index(tmp_path / "out")
    assert set(index["engine"]) == {"cocd"} and set(index["status"]) == {"completed"}
