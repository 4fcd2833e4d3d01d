"""Nothing stands for inputs it was not made from: sealed runs, content-addressed directories and
studies, and the geometry checks of shaped bodies and study boxes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from orchestrator import rundir
from orchestrator.campaign import store
from orchestrator.campaign.execute import perform
from orchestrator.case import CaseError, parse_case
from orchestrator.engines import build_stamp
from orchestrator.plan import make_plan
from orchestrator.runner import ensure_run, run_case
from orchestrator.studies.avalanche.study import load_study, packing_case

from conftest import free_fall_case, requires_liggghts

REPO = Path(__file__).resolve().parent.parent


@requires_liggghts
@pytest.mark.engine
def test_a_run_is_stale_in_a_directory_named_for_another_id(tmp_path: Path) -> None:
    """A content-addressed directory must hold the run of its own id: a campaign point or packing
    directory holding another input's run is stale (run again), never completed."""
    case = free_fall_case("liggghts")
    directory = tmp_path / "0123456789abcdef"
    run_case(case, tmp_path, directory)
    assert rundir.status(directory, builds=build_stamp) == "completed"  # as a plain run directory: its own record is sound
    assert rundir.status(directory, builds=build_stamp, expected_id="0123456789abcdef") == "stale"
    record = rundir.read_json(directory / "run.json")
    assert rundir.status(directory, builds=build_stamp, expected_id=record["run_id"]) == "completed"
    assert "not the 0123456789abcdef its directory stands for" in rundir.why_stale(directory, record, expected_id="0123456789abcdef")
    assert store.status(directory) == "stale"  # a campaign point is named for its id


@requires_liggghts
@pytest.mark.engine
def test_a_packing_whose_saved_state_was_edited_is_set_aside_and_made_again(tmp_path: Path) -> None:
    """A completed run seals its results and saved state; ensure_run verifies the seals before reuse."""
    case = free_fall_case("liggghts").model_copy(update={"save_state": True})
    directory, reused = ensure_run(case, tmp_path, "packing", lambda d: d / "state.restart")
    record = rundir.read_json(directory / "run.json")
    assert set(record["sealed"]) == {"results.h5", "state.restart"} and not reused
    assert ensure_run(case, tmp_path, "packing", lambda d: d / "state.restart") == (directory, True)
    state = directory / "state.restart"
    state.write_bytes(np.random.default_rng(1).bytes(state.stat().st_size))  # damaged: random bytes
    again, reused = ensure_run(case, tmp_path, "packing", lambda d: d / "state.restart")
    assert again == directory and not reused
    set_aside = rundir.read_json(directory / "run.json")["set_aside"]
    assert set_aside["why"] == "state.restart changed since it was sealed"
    assert (Path(set_aside["attic"]) / "state.restart").read_bytes() != state.read_bytes()  # the damaged file kept in the attic
    assert rundir.status(directory, builds=build_stamp, expected_id=directory.name) == "completed"


@requires_liggghts
@pytest.mark.engine
def test_a_study_whose_release_results_were_edited_is_released_again_not_re_reported(tmp_path: Path) -> None:
    """A finished study is measured again only from the release it sealed: results.h5 changed since
    (here the deposit moved 10 cm down the flow) is set aside in the attic, with one line saying why,
    and the release runs again from the same packing."""
    import h5py

    from conftest import tiny_study
    from orchestrator.studies.avalanche.study import run_study

    study = tiny_study("liggghts")
    study = study.model_copy(update={"release": study.release.model_copy(update={"duration": 0.4})})
    first = run_study(study, tmp_path / "study")
    results = tmp_path / "study" / "run" / "results.h5"
    with h5py.File(results, "r+") as edited:
        edited["frames/position"][-1, :, 0] += 0.1
    again = run_study(study, tmp_path / "study")
    assert not again["finished_before"] and again["packing"]["reused"]
    assert again["set_aside"]["why"] == "its release results.h5 changed since it was sealed"
    assert again["deposit"]["runout"] == pytest.approx(first["deposit"]["runout"], abs=1e-9)  # the true deposit, released again
    assert (Path(again["set_aside"]["attic"]) / "results.h5").exists()  # the edited file kept, not deleted
    assert run_study(study, tmp_path / "study")["finished_before"]  # the new release is sealed and reused


def test_a_campaign_point_whose_mesh_changed_after_the_plan_is_not_run_into_the_old_points_directory(tmp_path: Path) -> None:
    """The directory of a point stands for the id of the inputs as planned: if a file the case names
    changed since, the worker gives the point up (a relaunch plans it under its new id)."""
    floor = tmp_path / "floor.stl"
    facet = "solid f\n facet normal 0 0 1\n  outer loop\n   vertex -1 -1 {0}\n   vertex 1 -1 {0}\n   vertex 1 1 {0}\n  endloop\n endfacet\nendsolid f\n"
    floor.write_text(facet.format(0.0))
    data = json.loads(free_fall_case("liggghts").model_dump_json())
    data["walls"] = [{"type": "mesh", "name": "floor", "material": "glass", "file": "floor.stl"}]
    case = parse_case(data)
    planned = rundir.run_id(case, build_stamp(case.engine.value), case_dir=tmp_path)
    floor.write_text(facet.format(-0.01))  # edited while the campaign runs
    directory = tmp_path / "runs" / planned
    summary = perform(case.model_dump_json(), str(directory), str(tmp_path), None)
    assert summary["status"] == "skipped" and "inputs changed since the launch planned it" in summary["reason"]
    assert not rundir.holds_attempt(directory)  # nothing was run into the old id's directory


def _brick_case(positions: list[list[float]], orientations: list[list[float]] | None = None, kind: str = "superquadric") -> dict:
    study = load_study(REPO / "cases" / "avalanche" / "small.yaml")
    data = json.loads(packing_case(study).model_dump_json())
    data["shapes"][0]["kind"] = kind
    clump = data["bodies"]["clumps"][0]
    data["bodies"]["clumps"] = [{**clump, "position": p, "orientation": q, "velocity": [0, 0, 0]}
                                for p, q in zip(positions, orientations or [[1.0, 0.0, 0.0, 0.0]] * len(positions))]
    data["walls"] = [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-1.0, -1.0, 0.0],
                      "edge1": [2.0, 0.0, 0.0], "edge2": [0.0, 2.0, 0.0]}]
    data["gravity"] = [0.0, 0.0, -9.81]
    return data


@pytest.mark.parametrize("kind", ["superquadric", "clump"])
def test_bricks_at_one_spot_or_cut_by_the_floor_are_refused_before_any_engine_starts(kind: str) -> None:
    """Two bricks at one spot (turned 90° apart); a brick lying flat 2 mm into the floor; the same
    bricks touching, or resting flat on the floor, pass. Every message names the clump's field."""
    flat = 0.004  # half the brick's thickness: lying flat on the floor
    make_plan(parse_case(_brick_case([[0.0, 0.0, flat], [0.0, 0.0, 3 * flat]], kind=kind)), REPO)  # stacked, touching
    with pytest.raises(CaseError, match=r"^bodies\.clumps\.1\.position: body 1 overlaps body 0 by"):
        make_plan(parse_case(_brick_case([[0.0, 0.0, 0.05], [0.0, 0.0, 0.05]], [[1, 0, 0, 0], [0.7071, 0, 0, 0.7071]], kind=kind)), REPO)
    with pytest.raises(CaseError, match=r"^bodies\.clumps\.0\.position: the body cuts wall 'floor' by"):
        make_plan(parse_case(_brick_case([[0.0, 0.0, flat - 0.002]], kind=kind)), REPO)


def test_the_shipped_packings_pass_the_shape_checks_quickly() -> None:
    """The presets' starting layouts (rain grids, an ordered pile 0.2 mm apart) are fit to run."""
    for name in ("small", "ordered_pile_full"):
        make_plan(packing_case(load_study(REPO / "cases" / "avalanche" / f"{name}.yaml")), REPO)


@pytest.mark.parametrize(("fields", "message"), [
    ({"geometry": {"box_width": 0.06}, "packing": {"volume": 0.001}}, r"^geometry\.box_width: 0\.06 m holds less than two bricks"),
    ({"packing": {"volume": 0.1}}, r"^packing\.volume: 0\.1 m³ does not fit the box"),
    ({"packing": {"volume": 1e-7}}, r"^packing\.volume: 1e-07 m³ at 1000 kg/m³ is less than one brick"),
    ({"geometry": {"box_depth": 2.0}}, r"^geometry\.box_depth: the box .* runs past the slope board's top end"),
    ({"geometry": {"box_width": 5.0}}, r"^geometry\.box_width: 5\.0 m is wider than the boards"),
    ({"packing": {"kind": "ordered_pile", "volume": 0.001}, "geometry": {"box_depth": 0.03}}, r"^geometry\.box_depth: 0\.03 m holds less than two bricks of an ordered pile"),
])
def test_a_study_box_that_cannot_work_is_a_field_error(fields: dict, message: str) -> None:
    from orchestrator.studies.avalanche.study import KIND

    with pytest.raises(CaseError, match=message.replace("^", "^study.yaml: ")):
        KIND.parse({"name": "x", **fields}, "study.yaml")


def test_a_study_that_fails_before_making_anything_leaves_no_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from orchestrator.studies.avalanche.study import KIND, run_study
    from conftest import tiny_study

    def refuse(*args: object, **kwargs: object) -> None:
        raise CaseError("packing: refused")

    monkeypatch.setattr(KIND, "prepare", refuse)
    with pytest.raises(CaseError, match="refused"):
        run_study(tiny_study("liggghts"), tmp_path / "study")
    assert not (tmp_path / "study").exists()
    (tmp_path / "kept").mkdir()
    (tmp_path / "kept" / "notes.txt").write_text("mine")
    with pytest.raises(CaseError):
        run_study(tiny_study("liggghts"), tmp_path / "kept")
    assert (tmp_path / "kept" / "notes.txt").read_text() == "mine"  # a directory the user made stays as it was


@requires_liggghts
@pytest.mark.engine
def test_packings_directory_trouble_is_a_field_error_and_a_finished_packing_in_a_read_only_directory_is_read(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A file where the packing's directory (or the attic) should be: one error naming it, no traceback.
    A directory that cannot be written (its lock file cannot be made) still serves a finished packing."""
    case = free_fall_case("liggghts")
    root = tmp_path / "packings"
    root.mkdir()
    (root / rundir.run_id(case, build_stamp(case.engine.value), case_dir=root)).write_text("not a directory")
    with pytest.raises(CaseError, match=r"^the packing directory: .* is a file where the run's directory should be: move it away"):
        ensure_run(case, root, "packing")
    directory, _ = ensure_run(case, tmp_path / "fine", "packing")
    (tmp_path / "fine" / "attic").write_text("in the attic's place")
    (directory / "results.h5").write_bytes(b"damaged")  # to be set aside: the attic is needed
    with pytest.raises(CaseError, match=r"attic: cannot keep what is set aside there"):
        ensure_run(case, tmp_path / "fine", "packing")
    (tmp_path / "fine" / "attic").unlink()
    directory, _ = ensure_run(case, tmp_path / "fine", "packing")  # made again

    def read_only(path: Path, wait: bool = True) -> None:
        raise rundir.Unlockable(f"{path} cannot be written (Read-only file system): a run directory needs its lock file there")

    monkeypatch.setattr(rundir, "locked", read_only)
    assert ensure_run(case, tmp_path / "fine", "packing") == (directory, True)
    with pytest.raises(CaseError, match=r"^the packing directory: .*Read-only file system.*; give a writable one"):
        ensure_run(case, tmp_path / "elsewhere", "packing")


@requires_liggghts
@pytest.mark.engine
def test_a_campaign_study_point_whose_release_results_were_edited_is_stale_and_runs_again(tmp_path: Path) -> None:
    """A study point's record seals its release's results: edited since, the point is `stale`, and
    the next launch runs it again (the edited file goes to the attic)."""
    import h5py
    import yaml

    from conftest import tiny_study
    from orchestrator.campaign.execute import run_campaign

    study = tiny_study("liggghts").model_dump(mode="json", exclude_defaults=True)
    study["release"]["duration"] = 0.4
    (tmp_path / "tiny.yaml").write_text(yaml.safe_dump(study))
    (tmp_path / "c.yaml").write_text(yaml.safe_dump({"name": "c", "base": "tiny.yaml"}))
    out = tmp_path / "out"
    assert run_campaign(tmp_path / "c.yaml", out).done == 1
    point = next((out / "runs").iterdir())
    assert store.status(point) == "completed"
    with h5py.File(point / "run" / "results.h5", "r+") as edited:
        edited["frames/position"][-1, :, 0] += 0.1
    assert store.status(point) == "stale"
    assert run_campaign(tmp_path / "c.yaml", out).done == 1 and store.status(point) == "completed"
