"""Careless and hostile input: each one exits with its code and one line naming the field or file,
quickly and without a traceback, before any engine starts (the guard of conftest.py would fail a
test that starts one). Limits: 5 s and 500 MB per input, checked with tracemalloc on the parse."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from orchestrator import physics
from orchestrator.plan import make_plan
from orchestrator.campaign import store
from orchestrator.campaign.spec import CampaignSpec, evaluate, expand
from orchestrator.case import CaseError, load_case, parse_case
from orchestrator.cli.main import main
from orchestrator.engines.yade.materials import split_in_series

from conftest import assert_one_line_error, case_data, run_cli

BALL = {"material": "glass", "radius": 0.005}


ALIAS_BOMB = "name: x\na: &a [1,1,1,1,1,1,1,1,1]\n" + "".join(
    f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join([f'*{chr(97 + k)}'] * 9)}]\n" for k in range(8))

FILES = {
    "alias_bomb": (ALIAS_BOMB, "aliases"),
    "duplicate_key": ("name: a\nname: b\n", "duplicate key 'name'"),
    "binary_garbage": ("\x00\x01\x02\xff", "not UTF-8 text"),
    "deep_nesting": ("a: " + "[" * 5000 + "]" * 5000 + "\n", "not valid YAML"),
    "huge_list": ("name: x\nmaterials: [" + ", ".join(["{name: m, density: -1}"] * 3000) + "]\n", "materials"),
}


@pytest.mark.parametrize("name", sorted(FILES))
def test_hostile_yaml_files(name: str, tmp_path: Path, no_engine_process: None) -> None:
    text, field = FILES[name]
    path = tmp_path / f"{name}.yaml"
    path.write_bytes(text.encode("utf-8", "surrogateescape") if name != "binary_garbage" else b"\x00\x01\x02\xff")
    assert_one_line_error(*run_cli(["run", str(path), "-o", str(tmp_path / "run")]), expected_code=2, field=field)
    assert not (tmp_path / "run").exists()  # nothing started, nothing written


ABSURD = {
    "position_1e300": ({"bodies__spheres__0__position": [0.0, 0.0, 1e300]}, "bodies.spheres.0.position.2"),
    "gravity_1e300": ({"gravity": [0.0, 0.0, -1e300]}, "gravity.2"),
    "speed_1e8": ({"bodies__spheres__0__velocity": [1e8, 0.0, 0.0]}, "bodies.spheres.0.velocity.0"),
    "spin_1e9": ({"bodies__spheres__0__angular_velocity": [0.0, 1e9, 0.0]}, "bodies.spheres.0.angular_velocity.1"),
    "negative_density": ({"materials__0__density": -1.0}, "materials.0.density"),
    "nan_radius": ({"bodies__spheres__0__radius": float("nan")}, "bodies.spheres.0.radius"),
    "step_longer_than_a_contact": ({"time__step": 1e-3}, "time.step"),
    "output_every_nanosecond": ({"time__step": 1e-9, "time__output_interval": 1e-9}, "time.output_interval"),
    "speed_against_step": ({"bodies__spheres__0__velocity": [900.0, 0.0, 0.0]}, "bodies.spheres.0.velocity"),
    "outside_domain": ({"domain": {"lower": [-1, -1, -1], "upper": [1, 1, 0.5]}}, "bodies.spheres.0.position"),
    "coincident_spheres": ({"bodies__spheres": [{**BALL, "position": [0, 0, 1]}, {**BALL, "position": [0, 0, 1]}]}, "bodies.spheres.1.position"),
    "overlapping_spheres": ({"bodies__spheres": [{**BALL, "position": [0, 0, 1]}, {**BALL, "position": [0, 0, 1.009]}]}, "overlaps"),
    "long_name": ({"name": "n" * 5000}, "name"),
    "engine_unknown": ({"engine": "lammps"}, "engine"),
}


@pytest.mark.parametrize("name", sorted(ABSURD))
def test_absurd_values_are_refused_before_any_engine(name: str, tmp_path: Path, no_engine_process: None) -> None:
    changes, field = ABSURD[name]
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(case_data(**changes)))
    code, output, seconds, peak = run_cli(["run", str(path), "-o", str(tmp_path / "run")])
    assert_one_line_error(code, output, seconds, peak, expected_code=2, field=field)
    assert len(output) < 700  # every message is bounded


def test_a_sphere_inside_a_wall_is_named(tmp_path: Path, no_engine_process: None) -> None:
    data = case_data(bodies__spheres__0__position=[0.0, 0.0, 0.002])
    data["materials"].append({"name": "board", "density": 1000.0})
    data["contacts"].append({**data["contacts"][0], "materials": ["glass", "board"]})
    data["walls"] = [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.1, -0.1, 0.0],
                      "edge1": [0.2, 0.0, 0.0], "edge2": [0.0, 0.2, 0.0]}]
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    assert_one_line_error(*run_cli(["run", str(path), "-o", str(tmp_path / "run")]), expected_code=2, field="cuts wall 'floor'")


def test_the_run_ends_within_half_an_output_interval_of_the_duration() -> None:
    """0.35 s written every 1e-5 s with a longer step (1.2e-5 s) ran 0.41 s: the frames counted the
    requested interval while each lasted a whole step."""
    case = parse_case(case_data(time__step=1.2e-5, time__duration=0.35, time__output_interval=1e-5))
    plan = physics.schedule(case)
    assert abs(plan.end_time - 0.35) <= 0.5 * plan.output_every * plan.dt


@pytest.mark.parametrize(("expression", "message"), [("1 / 0", "divides by zero"), ("10 ** 10 ** 10", "overflows"),
                                                     ("(" * 500 + "1" + ")" * 500, "not valid"), ("__import__('os')", "only numbers")])
def test_derived_expressions_fail_cleanly(expression: str, message: str) -> None:
    started = time.perf_counter()
    with pytest.raises(CaseError, match=message):
        evaluate(expression, {"contacts": [{"kn": 1.0}]})
    assert time.perf_counter() - started < 1.0


def test_a_design_of_ten_billion_points_is_refused_before_it_is_made() -> None:
    spec = CampaignSpec.model_validate({"name": "x", "base": "b", "designs": [
        {"kind": "grid", "parameters": {"gravity.2": [float(v) for v in range(100_000)]}},
        {"kind": "lhs", "samples": 100_000, "ranges": {"gravity.0": [0.0, 1.0]}}]})
    started = time.perf_counter()
    with pytest.raises(CaseError, match=r"designs: 1e\+10 runs .* at most 100000"):
        expand(spec, case_data())
    assert time.perf_counter() - started < 1.0


@pytest.mark.parametrize("content", ["{garbage", "[1, 2]", '{"abc": 5}', ""])
def test_a_garbage_points_file_gives_an_empty_or_clean_index(content: str, tmp_path: Path) -> None:
    (tmp_path / store.POINTS).write_text(content)
    table = store.build_index(tmp_path)
    assert table.empty or set(table["status"]) == {"pending"}


DAMAGED = {
    "truncated_results": lambda d: (d / "results.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + b"\x00" * 100),
    "random_results": lambda d: (d / "results.h5").write_bytes(np.random.default_rng(1).bytes(4096)),
    "empty_results": lambda d: (d / "results.h5").write_bytes(b""),
    "results_without_frames": lambda d: h5py.File(d / "results.h5", "w").close(),
    "garbage_report": lambda d: (d / "report.json").write_text("{garbage"),
    "list_report": lambda d: (d / "report.json").write_text("[1, 2]"),
    "report_without_study": lambda d: (d / "report.json").write_text('{"deposit": {}}'),
}


@pytest.mark.parametrize("name", sorted(DAMAGED))
def test_post_on_a_damaged_run_directory(name: str, tmp_path: Path) -> None:
    DAMAGED[name](tmp_path)
    assert_one_line_error(*run_cli(["post", str(tmp_path)]), expected_code=5, field="damaged results")


def test_post_on_a_run_without_results_says_its_status(tmp_path: Path) -> None:
    (tmp_path / "run.json").write_text("[not, a, record")
    assert_one_line_error(*run_cli(["post", str(tmp_path)]), expected_code=2, field="no results.h5 (run status: unknown)")


def test_the_yade_restitution_bound_is_a_restitution() -> None:
    """A ball/board pair more dissipative than YADE's series rule allows: the message states an e_n²
    range inside (0, 1], not the damping coefficients."""
    data = case_data(engine="yade")
    data["materials"].append({"name": "board", "density": 1000.0})
    data["contacts"][0]["en2"] = 0.5
    data["contacts"].append({**data["contacts"][0], "materials": ["glass", "board"], "en2": 0.3})
    data["walls"] = [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-1, -1, 0], "edge1": [2, 0, 0], "edge2": [0, 2, 0]}]
    case = parse_case(data)
    with pytest.raises(CaseError, match=r"\(glass/board\)\.en2: .*allowed range: \[0\.\d+, 1\] \(got 0\.3\)"):
        split_in_series(case, physics.pair_constants(case, dashpot_for_bilinear=True), "cn")


FINITE = st.floats(allow_nan=True, allow_infinity=True, width=64)
JSONISH = st.recursive(st.none() | st.booleans() | FINITE | st.integers() | st.text(max_size=20),
                       lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=12), children, max_size=4),
                       max_leaves=30)


@settings(max_examples=150, deadline=2000, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(changes=st.dictionaries(st.sampled_from(["name", "engine", "seed", "time", "gravity", "materials", "contacts", "bodies",
                                                "walls", "domain", "shapes", "planar", "save_state", "initial_state"]), JSONISH, max_size=3))
def test_any_case_validates_or_raises_the_project_error(changes: dict[str, Any]) -> None:
    """Property: a case made of arbitrary values either validates (and then passes or fails the
    pre-flight checks with a CaseError) or raises CaseError; never anything else, quickly."""
    data = {**case_data(), **changes}
    started = time.perf_counter()
    try:
        case = parse_case(data)
        make_plan(case, Path("."))
    except CaseError as error:
        assert "\n" not in str(error) and len(str(error)) < 2000
    assert time.perf_counter() - started < 2.0


@settings(max_examples=100, deadline=2000, database=None)
@given(spec=st.dictionaries(st.sampled_from(["name", "base", "kind", "engine", "designs", "replicates", "derived", "timeout_s"]), JSONISH, max_size=4))
def test_any_campaign_spec_validates_or_raises_the_project_error(spec: dict[str, Any]) -> None:
    from orchestrator.validation import parse_model

    data = {"name": "c", "base": "base.yaml", **spec}
    try:
        parsed = parse_model(CampaignSpec, data, "campaign")
        expand(parsed, case_data())
    except CaseError as error:
        assert "\n" not in str(error)


def test_shipped_cases_pass_the_preflight_checks() -> None:
    for path in sorted((Path(__file__).parent.parent / "cases").glob("*.yaml")):
        make_plan(load_case(path), path.parent)


LEAVING = {"name": "leave", "time": {"step": 1.0e-5, "duration": 0.2, "output_interval": 0.01}, "gravity": [0.0, 0.0, 0.0],
           "materials": [{"name": "glass", "density": 2500.0}],
           "contacts": [{"materials": ["glass", "glass"], "en2": 0.5, "mu": 0.5, "kn": 1.0e5, "kt_over_kn": 0.4}],
           "bodies": {"spheres": [{**BALL, "position": [0.0, 0.0, 0.0], "velocity": [1.0, 0.0, 0.0]}]},
           "domain": {"lower": [-0.05, -0.05, -0.05], "upper": [0.05, 0.05, 0.05]}}


@pytest.mark.engine
@pytest.mark.parametrize("engine", ["yade"])
def test_a_body_leaving_the_domain_ends_the_run_alike_on_every_engine(engine: str, tmp_path: Path) -> None:
    """Through the CLI on YADE, which used to exit 0 with the body outside; every engine ending the
    run with the same message is a case of the parity matrix (tests/test_parity.py)."""
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(LEAVING))
    result = CliRunner().invoke(main, ["run", str(path), "-e", engine, "-o", str(tmp_path / "run")])
    assert result.exit_code == 3, result.output
    assert "left the simulation domain" in result.output and "enlarge `domain:`" in result.output
    assert json.loads((tmp_path / "run" / "run.json").read_text())["status"] == "failed"


@pytest.mark.engine
def test_a_relaunch_says_failed_runs_remain(tmp_path: Path) -> None:
    """The first launch fails two points; the relaunch runs nothing, and still exits 3 naming them."""
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(LEAVING))
    campaign = tmp_path / "campaign.yaml"
    campaign.write_text(yaml.safe_dump({"name": "leave", "base": "base.yaml", "engine": "cocd",
                                        "designs": [{"kind": "grid", "parameters": {"bodies.spheres.0.velocity": [[1.0, 0, 0], [2.0, 0, 0]]}}]}))
    for _ in range(2):
        result = CliRunner().invoke(main, ["campaign", "run", str(campaign), "-o", str(tmp_path / "out"), "-j", "1"])
        assert result.exit_code == 3, result.output
        assert "2 failed runs remain" in result.output
