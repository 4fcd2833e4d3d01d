"""A run is what went into it: its id follows every input (the code that writes the deck, the files a
case names, the non-default fields), one plan per run, and adapters that keep nothing between runs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from orchestrator import physics, preflight, rundir
from orchestrator.campaign import store
from orchestrator.campaign.execute import run_campaign
from orchestrator.case import Case, parse_case
from orchestrator.cli.main import main
from orchestrator.engines import build, build_stamp, get_adapter
from orchestrator.imports import package_modules
from orchestrator.plan import make_plan
from orchestrator.runner import ensure_run, run_case

from conftest import free_fall_case, requires_liggghts

BUILD = {"engine": "cocd", "version": "fixed", "inputs": "fixed"}  # a build given, so no engine is asked


def test_the_deck_code_is_every_module_the_engine_package_imports() -> None:
    """What was left out of a hand-kept list is in the closure: the brick's spheres, the wall triangles,
    the renderer itself, the plan; and nothing of the studies or the command line."""
    for engine in ("liggghts", "yade", "cocd"):
        modules = build.deck_modules(engine)
        assert {"orchestrator.shapes.clump", "orchestrator.geometry", "orchestrator.physics", "orchestrator.plan", "orchestrator.case"} <= set(modules)
        assert not any(m.startswith(("orchestrator.studies", "orchestrator.cli", "orchestrator.campaign")) for m in modules)
    assert "orchestrator.engines.templating" in build.deck_modules("liggghts")


def _edited_module(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, module: str, old: str, new: str) -> None:
    """The package as if `module`'s source had `old` replaced by `new` (the build hash reads sources)."""
    source = package_modules()[module]
    text = source.read_text()
    assert old in text
    edited = tmp_path / source.name
    edited.write_text(text.replace(old, new))
    monkeypatch.setattr("orchestrator.imports.package_modules", lambda: {**package_modules(), module: edited})
    monkeypatch.setattr(build, "package_modules", lambda: {**package_modules(), module: edited})
    build._code_hash.cache_clear()


@pytest.fixture(autouse=True)
def _fresh_code_hash() -> None:
    build._code_hash.cache_clear()
    yield
    build._code_hash.cache_clear()


def test_editing_the_bricks_sphere_placement_changes_the_build_but_a_docstring_does_not(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    before = build.deck_hash("liggghts", None)
    _edited_module(monkeypatch, tmp_path, "orchestrator.shapes.clump", "Bricks as clumps ", "Reworded: Bricks as clumps ")
    assert build.deck_hash("liggghts", None) == before  # documentation is not code
    monkeypatch.undo()
    _edited_module(monkeypatch, tmp_path, "orchestrator.shapes.clump", "(fraction - 0.5)", "(fraction - 0.5000001)")  # spheres a hair elsewhere
    assert build.deck_hash("liggghts", None) != before


@pytest.mark.engine
def test_a_run_made_before_a_brick_edit_is_stale_and_runs_again(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """ensure_run (the packings' path): reused while nothing changed; after the brick's code changed,
    the finished run reads `stale`, never `completed`, and the same case runs again."""
    case = free_fall_case("cocd")
    directory, reused = ensure_run(case, tmp_path, "free fall")
    assert not reused and rundir.status(directory, builds=build_stamp) == "completed"
    assert ensure_run(case, tmp_path, "free fall") == (directory, True)
    (tmp_path / "edited").mkdir()
    _edited_module(monkeypatch, tmp_path / "edited", "orchestrator.shapes.clump", "(fraction - 0.5)", "(fraction - 0.5000001)")
    assert rundir.status(directory, builds=build_stamp) == "stale"
    again, reused = ensure_run(case, tmp_path, "free fall")
    assert not reused and again != directory and rundir.status(again, builds=build_stamp) == "completed"


def _mesh_case(tmp_path: Path, tilt: float) -> Path:
    floor = tmp_path / "floor.stl"
    z = tilt * np.array([-0.1, 0.1, 0.1])
    floor.write_text("solid floor\n facet normal 0 0 1\n  outer loop\n"
                     f"   vertex -0.1 -0.1 {z[0]}\n   vertex 0.1 -0.1 {z[1]}\n   vertex 0.1 0.1 {z[2]}\n"
                     "  endloop\n endfacet\nendsolid floor\n")
    data = json.loads(free_fall_case("liggghts").model_dump_json())
    data["bodies"]["spheres"][0]["position"] = [0.05, -0.05, 0.05]
    data["walls"] = [{"type": "mesh", "name": "floor", "material": "glass", "file": "floor.stl"}]
    path = tmp_path / "base.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_an_edited_mesh_or_initial_state_changes_the_id(tmp_path: Path) -> None:
    case = parse_case(yaml.safe_load(_mesh_case(tmp_path, 0.0).read_text()))
    flat = rundir.run_id(case, BUILD, tmp_path)
    _mesh_case(tmp_path, 0.2)  # the floor tilted in place, same path
    assert rundir.run_id(case, BUILD, tmp_path) != flat
    state = tmp_path / "state.restart"
    state.write_bytes(b"one")
    data = json.loads(free_fall_case("liggghts").model_dump_json())
    started = parse_case({**data, "initial_state": "state.restart"})
    first = rundir.run_id(started, BUILD, tmp_path)
    state.write_bytes(b"two")
    assert rundir.run_id(started, BUILD, tmp_path) != first


def test_a_field_added_with_a_default_keeps_every_id() -> None:
    """The id covers the fields that differ from their defaults: a new field's default is invisible."""

    class Extended(Case):
        new_knob: float = 1.0

    data = json.loads(free_fall_case("cocd").model_dump_json())
    assert rundir.run_id(Extended.model_validate(data), BUILD) == rundir.run_id(Case.model_validate(data), BUILD)
    assert rundir.run_id(Extended.model_validate({**data, "new_knob": 2.0}), BUILD) != rundir.run_id(Case.model_validate(data), BUILD)
    # Writing a default out changes nothing either: the same run.
    data["seed"] = Case.model_fields["seed"].default
    assert rundir.run_id(Case.model_validate(data), BUILD) == rundir.run_id(free_fall_case("cocd"), BUILD)


@requires_liggghts
@pytest.mark.engine
def test_a_campaign_relaunched_after_a_mesh_edit_runs_again_and_marks_the_old_point_stale(tmp_path: Path) -> None:
    _mesh_case(tmp_path, 0.0)
    (tmp_path / "campaign.yaml").write_text(yaml.safe_dump(
        {"name": "mesh", "base": "base.yaml", "designs": [{"kind": "grid", "parameters": {"seed": [7]}}]}))
    out = tmp_path / "out"
    assert run_campaign(tmp_path / "campaign.yaml", out).done == 1
    _mesh_case(tmp_path, 0.2)  # the floor tilted in place
    counts = run_campaign(tmp_path / "campaign.yaml", out)
    assert counts.done == 1 and counts.skipped == 0  # it ran again: never "0 run, 1 already there"
    index = store.build_index(out)
    assert sorted(index["status"]) == ["completed", "stale"]
    assert index.loc[index["status"] == "completed", "superseded"].tolist() == [False]


@pytest.mark.engine
def test_after_a_base_case_edit_the_index_has_one_current_row_per_point(tmp_path: Path) -> None:
    data = json.loads(free_fall_case("cocd").model_dump_json())
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(data))
    (tmp_path / "campaign.yaml").write_text(yaml.safe_dump(
        {"name": "edit", "base": "base.yaml", "designs": [{"kind": "grid", "parameters": {"seed": [7, 8]}}]}))
    out = tmp_path / "out"
    assert run_campaign(tmp_path / "campaign.yaml", out).done == 2
    data["gravity"] = [0.0, 0.0, -9.0]
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(data))
    assert run_campaign(tmp_path / "campaign.yaml", out).done == 2
    index = store.build_index(out)
    current = index[~index["superseded"]]
    assert len(index) == 4 and len(current) == 2 and set(current["status"]) == {"completed"}
    assert set(index[index["superseded"]]["status"]) == {"stale"}
    assert sorted(current["param.seed"]) == [7, 8]


@pytest.mark.engine
def test_the_schedule_and_the_plan_are_made_once_per_run(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """`demorch run`: one schedule, one pre-flight check, whatever reads them (deck, resume, record, domain check)."""
    calls = {"schedule": 0, "preflight": 0}
    schedule, check_all = physics.schedule, preflight.check_all

    def counted_schedule(case: Case) -> physics.Schedule:
        calls["schedule"] += 1
        return schedule(case)

    def counted_check(*arguments: object) -> None:
        calls["preflight"] += 1
        check_all(*arguments)

    monkeypatch.setattr(physics, "schedule", counted_schedule)
    monkeypatch.setattr(preflight, "check_all", counted_check)
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(json.loads(free_fall_case("cocd").model_dump_json())))
    from click.testing import CliRunner

    result = CliRunner().invoke(main, ["run", str(tmp_path / "case.yaml"), "-o", str(tmp_path / "run")])
    assert result.exit_code == 0, result.output
    assert calls == {"schedule": 1, "preflight": 1}


@pytest.mark.engine
@pytest.mark.parametrize("engine", [pytest.param("liggghts", marks=requires_liggghts), "cocd"])
def test_one_adapter_runs_two_cases_interleaved_as_it_runs_each_alone(engine: str, tmp_path: Path) -> None:
    """An adapter holds no per-run state: writing case B between writing and running case A changes nothing."""
    adapter = get_adapter(engine)
    state = dict(vars(adapter))
    first = free_fall_case(engine)
    second = parse_case({**json.loads(first.model_dump_json()), "gravity": [0.0, 0.0, -3.0]})
    alone = []
    for case in (first, second):
        directory = tmp_path / f"alone-{len(alone)}"
        run_case(case, tmp_path, directory)
        alone.append(json.loads((directory / "run.json").read_text())["metrics"])
    plans = [make_plan(case, tmp_path) for case in (first, second)]
    directories = [tmp_path / "a", tmp_path / "b"]
    for plan, directory in zip(plans, directories):
        directory.mkdir()
        adapter.write_input(plan, directory)
    for plan, directory in zip(reversed(plans), reversed(directories)):
        adapter.execute(plan, directory)
    outputs = [adapter.read_output(plan, directory) for plan, directory in zip(plans, directories)]
    assert vars(adapter) == state
    from orchestrator.post import summary

    assert [summary.summary(t) for t in outputs] == alone
    assert outputs[0].position[-1, 0, 2] < outputs[1].position[-1, 0, 2]  # the stronger gravity fell further


DEFAULTS = Path(__file__).with_name("identity_defaults.json")


def current_defaults() -> dict[str, object]:
    """'Model.Section.field' → default (JSON) of every field of the case and the study models, from their JSON Schemas."""
    from orchestrator.studies.registry import LAUNCH_KINDS

    found: dict[str, object] = {}
    for model in (kind.model for kind in LAUNCH_KINDS.values()):
        schema = model.model_json_schema()
        sections = {model.__name__: schema, **{f"{model.__name__}.{name}": part for name, part in schema.get("$defs", {}).items()}}
        for section, part in sections.items():
            for field, spec in part.get("properties", {}).items():
                if "default" in spec:
                    found[f"{section}.{field}"] = spec["default"]
    return found


def test_a_default_changes_only_with_the_schema_version() -> None:
    """The id leaves defaults out, so a default whose value changes would silently keep every id: such a
    change must come with a new rundir.SCHEMA_VERSION (and this record, written by running this file).
    New fields with defaults are free."""
    recorded = json.loads(DEFAULTS.read_text())
    if recorded["schema_version"] != rundir.SCHEMA_VERSION:
        pytest.fail(f"rundir.SCHEMA_VERSION is {rundir.SCHEMA_VERSION}, the defaults are recorded for {recorded['schema_version']}: "
                    "record them again with `.venv/bin/python tests/test_identity.py`")
    now = current_defaults()
    changed = {key: (value, now[key]) for key, value in recorded["defaults"].items() if key in now and now[key] != value}
    assert not changed, f"defaults changed without a new rundir.SCHEMA_VERSION (recorded, now): {changed}"


if __name__ == "__main__":
    DEFAULTS.write_text(json.dumps({"schema_version": rundir.SCHEMA_VERSION, "defaults": current_defaults()}, indent=1, sort_keys=True) + "\n")
    print(f"recorded {DEFAULTS}")
