"""More careless and hostile input through the CLI, one table per kind of file: case fields, campaign
files, avalanche and collapse studies, command-line arguments and damaged run directories. Each
exits with its code (2 invalid input, 5 damaged results) and one line naming the field or file,
within 5 s and 500 MB, before any engine starts (the `no_engine_process` fixture fails otherwise)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

import h5py
import numpy as np
import pytest
import yaml

from conftest import assert_one_line_error, case_data, run_cli

REPO = Path(__file__).resolve().parent.parent
FLOOR = {"type": "rectangle", "name": "floor", "material": "glass", "origin": [-0.1, -0.1, 0.0], "edge1": [0.2, 0, 0], "edge2": [0, 0.2, 0]}
SHAPE = {"name": "b", "length": 0.031, "width": 0.015, "thickness": 0.008, "layout": [4, 2, 1]}


def with_field(**extra: Any) -> Callable[[], dict[str, Any]]:
    return lambda: {**case_data(), **extra}


def changed(**changes: Any) -> Callable[[], dict[str, Any]]:
    return lambda: case_data(**changes)


def without(field: str) -> Callable[[], dict[str, Any]]:
    return lambda: {k: v for k, v in case_data().items() if k != field}


# name: (case data, the field the message must name)
CASES: dict[str, tuple[Callable[[], Any], str]] = {
    "top_level_list": (lambda: [1, 2], "must be a mapping"),
    "top_level_number": (lambda: 42, "must be a mapping"),
    "empty_file": (lambda: None, "must be a mapping"),
    "misspelt_field": (with_field(gravty=[0, 0, -9.81]), "gravty: Extra inputs"),
    "no_materials": (changed(materials=[]), "materials"),
    "contact_with_unknown_material": (changed(contacts__0__materials=["glass", "steel"]), "unknown material 'steel'"),
    "material_named_twice": (changed(materials=[{"name": "glass", "density": 2500.0}, {"name": "glass", "density": 2600.0}]), "materials: names must be unique"),
    "en2_zero": (changed(contacts__0__en2=0.0), "contacts.0.en2"),
    "en2_above_one": (changed(contacts__0__en2=1.5), "contacts.0.en2"),
    "mu_negative": (changed(contacts__0__mu=-0.1), "contacts.0.mu"),
    "mu_huge": (changed(contacts__0__mu=1e9), "contacts.0.mu"),
    "kn_zero": (changed(contacts__0__kn=0.0), "contacts.0.kn"),
    "kn_infinite": (changed(contacts__0__kn=float("inf")), "contacts.0.kn"),
    "kn_not_a_number": (changed(contacts__0__kn="1e5abc"), "contacts.0.kn"),
    "kt_negative": (changed(contacts__0__kt_over_kn=-0.4), "contacts.0.kt_over_kn"),
    "duration_negative": (changed(time__duration=-1.0), "time.duration"),
    "duration_zero": (changed(time__duration=0.0), "time.duration"),
    "duration_of_thirty_years": (changed(time__duration=1e9), "time.duration"),
    "interval_longer_than_the_run": (changed(time__output_interval=5.0), "time.output_interval"),
    "step_negative": (changed(time__step=-1e-5), "time.step"),
    "step_a_word": (changed(time__step="soon"), "time.step"),
    "no_time": (without("time"), "time: Field required"),
    "radius_zero": (changed(bodies__spheres__0__radius=0.0), "bodies.spheres.0.radius"),
    "radius_a_kilometre": (changed(bodies__spheres__0__radius=1e3), "bodies.spheres.0.radius"),
    "position_of_two_numbers": (changed(bodies__spheres__0__position=[0.0, 1.0]), "bodies.spheres.0.position"),
    "position_of_words": (changed(bodies__spheres__0__position=["a", "b", "c"]), "bodies.spheres.0.position.0"),
    "velocity_of_booleans": (changed(bodies__spheres__0__velocity=[True, False, True]), "bodies.spheres.0.velocity.0"),
    "bodies_null": (changed(bodies=None), "bodies"),
    "layout_of_zero_spheres": (with_field(shapes=[{**SHAPE, "layout": [0, 1, 1]}]), "shapes.0.layout.0"),
    "layout_of_a_billion_spheres": (with_field(shapes=[{**SHAPE, "layout": [1000, 1000, 1000]}]), "shapes.0.layout.0"),
    "brick_of_negative_length": (with_field(shapes=[{**SHAPE, "length": -0.031}]), "shapes.0.length"),
    "rounding_on_a_bevelled_brick": (with_field(shapes=[{**SHAPE, "bevel_deg": 2.0, "rounding": 0.001}]), "rounding: needs bevel_deg 0"),
    "rounding_beyond_the_thickness": (with_field(shapes=[{**SHAPE, "rounding": 0.005}]), "rounding"),
    "rounding_of_a_nanometre": (with_field(shapes=[{**SHAPE, "rounding": 1e-9}]), "shapes.0: rounding: allowed: 0, or [1e-06, 0.004) m"),
    "clump_of_spheres_below_a_micron": (with_field(shapes=[{**SHAPE, "thickness": 1e-4, "layout": [4, 2, 64]}]),
                                        "shapes.0: layout: the clump's smallest sphere would be 7.81e-07 m in radius; allowed: at least 1e-06 m"),
    "spin_of_1e5_rad_per_s": (changed(bodies__spheres__0__angular_velocity=[0.0, 1e5, 0.0]),
                              "bodies.spheres.0.angular_velocity: 1e+05 rad/s moves the surface at up to 500 m/s"),
    "clump_of_unknown_shape": (changed(bodies={"clumps": [{"shape": "nope", "material": "glass", "position": [0, 0, 1]}]}), "unknown shape 'nope'"),
    "wall_with_a_zero_edge": (with_field(walls=[{**FLOOR, "edge1": [0, 0, 0]}]), "walls.0.rectangle"),
    "wall_with_parallel_edges": (with_field(walls=[{**FLOOR, "edge2": [0.4, 0, 0]}]), "walls.0.rectangle"),
    "wall_of_unknown_type": (with_field(walls=[{**FLOOR, "type": "cylinder"}]), "walls.0"),
    "mesh_file_missing": (with_field(walls=[{"type": "mesh", "name": "m", "material": "glass", "file": "nope.stl"}]), "walls.m.file"),
    "mesh_file_garbage": (with_field(walls=[{"type": "mesh", "name": "m", "material": "glass", "file": "garbage.stl"}]), "walls.m.file"),
    "mesh_path_outside": (with_field(walls=[{"type": "mesh", "name": "m", "material": "glass", "file": "../../../../etc/passwd"}]), "walls.0.mesh.file"),
    "domain_inside_out": (with_field(domain={"lower": [1, 1, 1], "upper": [-1, -1, -1]}), "domain"),
    "seed_negative": (changed(seed=-5), "seed"),
    "seed_a_word": (changed(seed="abc"), "seed"),
    "engine_as_a_list": (changed(engine=["liggghts"]), "engine"),
    "initial_state_any_file": (changed(initial_state="/etc/passwd"), "initial_state: /etc/passwd is not a state this package wrote"),
    "initial_state_missing": (changed(initial_state="no/such/state.restart"), "initial_state: no state file"),
    "save_state_perhaps": (changed(save_state="perhaps"), "save_state"),
    "density_of_a_neutron_star": (changed(materials__0__density=1e30), "materials.0.density"),
    "gravity_nan": (changed(gravity=[0.0, 0.0, float("nan")]), "gravity.2"),
    "name_with_a_null_character": (changed(name="a\x00b"), "name"),
    "name_with_a_path": (changed(name="../../etc"), "name"),
    "name_with_template_syntax": (changed(name="{{ 7 * 7 }}"), "name"),
    "cocd_tolerance_below_double_precision": (changed(cocd__tolerance=1e-300), "cocd.tolerance"),
    "inertia_of_a_feather_brick": (with_field(shapes=[{**SHAPE, "mass": 1e-9, "inertia": [1.0, 1.0, 1.0]}]),
                                   "inertia: 1.0 kg m² is more than a body of mass 1e-09 kg"),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_bad_case_file(name: str, tmp_path: Path, no_engine_process: None) -> None:
    make, field = CASES[name]
    (tmp_path / "garbage.stl").write_bytes(b"\x00garbage\xff" * 10)
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(make()))
    assert_one_line_error(*run_cli(["run", str(path), "-o", str(tmp_path / "run")]), expected_code=2, field=field)
    assert not (tmp_path / "run").exists()


def test_a_number_of_four_hundred_digits(tmp_path: Path, no_engine_process: None) -> None:
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(case_data()).replace("2500.0", "1" + "0" * 400))
    assert_one_line_error(*run_cli(["run", str(path), "-o", str(tmp_path / "run")]), expected_code=2, field="materials.0.density")


GRID = {"kind": "grid", "parameters": {"contacts.0.mu": [0.3, 0.5]}}


def campaign(**fields: Any) -> dict[str, Any]:
    return {"name": "c", "base": "base.yaml", "designs": [GRID], **fields}


CAMPAIGNS: dict[str, tuple[Any, str]] = {
    "base_missing": (campaign(base="nope.yaml"), "base:"),
    "base_a_directory": (campaign(base="."), "cannot read the base case"),
    "base_invalid": (campaign(base="bad.yaml"), "contacts.0.en2"),
    "parameter_the_case_lacks": (campaign(designs=[{"kind": "grid", "parameters": {"bodies.spheres.7.radius": [0.1]}}]), "bodies.spheres.7"),
    "parameter_path_of_attributes": (campaign(designs=[{"kind": "grid", "parameters": {"..__class__": [0.1]}}]), "designs.0.grid.parameters"),
    "parameter_value_out_of_range": (campaign(designs=[{"kind": "grid", "parameters": {"contacts.0.en2": [0.5, 7.0]}}]), "contacts.0.en2"),
    "grid_without_values": (campaign(designs=[{"kind": "grid", "parameters": {"contacts.0.en2": []}}]), "designs.0.grid.parameters"),
    "design_of_unknown_kind": (campaign(designs=[{"kind": "halton", "samples": 3}]), "designs.0"),
    "lhs_of_zero_samples": (campaign(designs=[{"kind": "lhs", "samples": 0, "ranges": {"contacts.0.mu": [0.1, 0.5]}}]), "designs.0.lhs.samples"),
    "lhs_range_inside_out": (campaign(designs=[{"kind": "lhs", "samples": 3, "ranges": {"contacts.0.mu": [0.5, 0.1]}}]), "low must be below high"),
    "replicates_negative": (campaign(replicates=-1), "replicates"),
    "derived_unknown_name": (campaign(derived={"contacts.0.kn": "stiffness * 2"}), "derived expression"),
    "derived_attribute_access": (campaign(derived={"contacts.0.kn": "().__class__"}), "derived expressions may only name case paths"),
    "derived_lambda": (campaign(derived={"contacts.0.kn": "(lambda: 1)()"}), "only numbers, case paths"),
    "engine_unknown": (campaign(engine="pfc"), "engine"),
    "timeout_negative": (campaign(timeout_s=-5), "timeout_s"),
    "name_empty": (campaign(name=""), "name"),
    "misspelt_field": (campaign(jobs=4), "jobs: Extra inputs"),
    "top_level_list": ("- a\n- b\n", "must be a mapping"),
    "duplicate_key": ("name: c\nname: d\nbase: base.yaml\n", "duplicate key 'name'"),
    "alias_bomb": ("name: c\nbase: base.yaml\na: &a [1,1,1,1,1,1,1,1,1]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\n", "aliases"),
}


@pytest.mark.parametrize("name", sorted(CAMPAIGNS))
def test_a_bad_campaign_file(name: str, tmp_path: Path, no_engine_process: None) -> None:
    data, field = CAMPAIGNS[name]
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(case_data()))
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(case_data(contacts__0__en2=2.0)))
    path = tmp_path / "campaign.yaml"
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
    assert_one_line_error(*run_cli(["campaign", "run", str(path), "-o", str(tmp_path / "out")]), expected_code=2, field=field)


def edited(preset: str, path: str, value: Any) -> dict[str, Any]:
    if preset == "random_pour_quarter_search.yaml":  # the quarter as a density search (its preset packs once)
        data = yaml.safe_load((REPO / "cases" / "avalanche" / "random_pour_quarter.yaml").read_text())
        data["packing"]["density_search"] = {"max_trials": 3}
        preset = ""
    else:  # preset+kind: the preset with that brick kind
        data = yaml.safe_load((REPO / "cases" / preset.split("+")[0]).read_text())
        if "+" in preset:
            data["brick"] = {**data.get("brick", {}), "kind": preset.split("+")[1]}
    node = data
    *parents, last = path.split(".")
    for part in parents:
        node = node.setdefault(part, {})
    node[last] = value
    return data


STUDIES: dict[str, tuple[list[str], str, str, Any, str]] = {  # command, preset, field, value, expected in the message
    "avalanche_launch_below_the_slope": (["avalanche"], "avalanche/small.yaml", "geometry.launch_height", -0.4, "geometry.launch_height"),
    "avalanche_board_of_no_length": (["avalanche"], "avalanche/small.yaml", "geometry.board_length", 0.0, "geometry.board_length"),
    "avalanche_a_cubic_kilometre": (["avalanche"], "avalanche/small.yaml", "packing.volume", 1e3, "packing.volume"),
    "avalanche_packing_unknown": (["avalanche"], "avalanche/small.yaml", "packing.kind", "levitated", "packing.kind"),
    "avalanche_release_negative": (["avalanche"], "avalanche/small.yaml", "release.duration", -2.0, "release.duration"),
    "avalanche_rest_speed_negative": (["avalanche"], "avalanche/small.yaml", "release.stop_at_rest.speed", -1.0, "release.stop_at_rest.speed"),
    "avalanche_seed_fraction": (["avalanche"], "avalanche/small.yaml", "seed", 1.5, "seed"),
    "avalanche_box_inside_out": (["avalanche"], "avalanche/small.yaml", "geometry.box_depth", -0.1, "geometry.box_depth"),
    "avalanche_misspelt_field": (["avalanche"], "avalanche/small.yaml", "slope", 45, "slope: Extra inputs"),
    "avalanche_rounded_bevelled_brick": (["avalanche"], "avalanche/small.yaml", "brick", {"bevel_deg": 2.0}, "rounding"),
    # checks a study makes before any engine, naming its own fields (they failed after the packing, or named case fields)
    "avalanche_rounded_box_recording_contacts": (["avalanche"], "avalanche/small.yaml+rounded_box", "release.record_contacts", True,
                                                 "release.record_contacts: liggghts does not record the contacts of rounded_box bricks"),
    "avalanche_rounded_box_on_yade": (["avalanche", "-e", "yade"], "avalanche/small.yaml", "brick.kind", "rounded_box", "brick.kind: yade takes clump"),
    "avalanche_denser_than_its_bricks": (["avalanche"], "avalanche/small.yaml", "packing.apparent_density", 3000.0, "packing.apparent_density"),
    "avalanche_first_trial_beyond_the_bounds": (["avalanche"], "random_pour_quarter_search.yaml", "packing.brick_brick_mu", 5.0,
                                                "packing.brick_brick_mu: 5 starts the density search outside"),
    "avalanche_packing_step_of_nothing": (["avalanche"], "avalanche/small.yaml", "packing.time_safety_factor", 1e-300, "packing.time_safety_factor"),
    "avalanche_release_step_of_nothing": (["avalanche"], "avalanche/small.yaml", "release.time_safety_factor", 1e-300, "release.time_safety_factor"),
    "avalanche_rounded_box_too_round": (["avalanche"], "avalanche/small.yaml", "brick", {"kind": "rounded_box", "rounding": 0.01},
                                        "rounding: allowed: [1e-06, 0.004) m"),
    "collapse_slope_of_95_degrees": (["collapse", "run"], "collapse/horizontal.yaml", "channel.slope_deg", 95.0, "channel.slope_deg"),
    "collapse_grains_of_no_size": (["collapse", "run"], "collapse/horizontal.yaml", "grains.diameter", 0.0, "grains.diameter"),
    "collapse_polydispersity_200_percent": (["collapse", "run"], "collapse/horizontal.yaml", "grains.polydispersity", 2.0, "grains.polydispersity"),
    "collapse_four_dimensions": (["collapse", "run"], "collapse/horizontal.yaml", "dimension", 4, "dimension"),
    "collapse_column_negative": (["collapse", "run"], "collapse/horizontal.yaml", "column.height", -0.07, "column.height"),
    "collapse_bed_negative": (["collapse", "run"], "collapse/horizontal.yaml", "bed.erodible_thickness", -0.001, "bed.erodible_thickness"),
    "collapse_mu_negative": (["collapse", "run"], "collapse/horizontal.yaml", "contacts.mu", -0.3, "contacts.mu"),
    "collapse_settling_negative": (["collapse", "run"], "collapse/horizontal.yaml", "preparation.settle_time", -1.0, "preparation.settle_time"),
    "collapse_calibrated_on_a_slope": (["collapse", "calibrate"], "collapse/horizontal.yaml", "channel.slope_deg", 22.0, "channel.slope_deg"),
}


@pytest.mark.parametrize("name", sorted(STUDIES))
def test_a_bad_study_file(name: str, tmp_path: Path, no_engine_process: None) -> None:
    command, preset, field, value, expected = STUDIES[name]
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(edited(preset, field, value)))
    assert_one_line_error(*run_cli([*command, str(path), "-o", str(tmp_path / "out")]), expected_code=2, field=expected)


ARGUMENTS: dict[str, tuple[list[str], str]] = {  # {tmp}: the test's directory, holding case.yaml and a_file
    "run_a_missing_file": (["run", "{tmp}/nope.yaml"], "cannot read the case file"),
    "run_a_directory": (["run", "{tmp}"], "cannot read the case file"),
    "run_into_a_file": (["run", "{tmp}/case.yaml", "-o", "{tmp}/a_file"], "--output"),
    "run_on_an_unknown_engine": (["run", "{tmp}/case.yaml", "-e", "pfc"], "--engine"),
    "mpi_zero": (["--mpi", "0", "run", "{tmp}/case.yaml"], "--mpi"),
    "mpi_of_a_supercomputer": (["--mpi", "100000", "run", "{tmp}/case.yaml"], "--mpi"),
    "unknown_option": (["run", "{tmp}/case.yaml", "--fast"], "--fast"),
    "unknown_command": (["simulate", "{tmp}/case.yaml"], "simulate"),
    "render_without_output": (["render", "{tmp}/case.yaml"], "--output"),
    "post_a_missing_directory": (["post", "{tmp}/nope"], "RUNDIR"),
    "post_a_file": (["post", "{tmp}/a_file"], "RUNDIR"),
    "paraview_a_missing_directory": (["paraview", "{tmp}/nope"], "RUNDIR"),
    "paraview_a_stride_of_zero": (["paraview", "{tmp}", "--stride", "0"], "--stride"),
    "paraview_a_resolution_of_one": (["paraview", "{tmp}", "--resolution", "1"], "--resolution"),
    "avalanche_a_missing_study": (["avalanche", "{tmp}/nope.yaml"], "cannot read the avalanche study"),
    "collapse_a_missing_study": (["collapse", "run", "{tmp}/nope.yaml"], "cannot read the collapse study"),
    "collapse_calibrate_a_missing_study": (["collapse", "calibrate", "{tmp}/nope.yaml"], "cannot read the collapse study"),
    "campaign_status_of_nothing": (["campaign", "status", "{tmp}/nope"], "CAMPAIGN_DIR"),
    "campaign_table_of_nothing": (["campaign", "table", "{tmp}/nope"], "CAMPAIGN_DIR"),
    "campaign_plot_of_nothing": (["campaign", "plot", "{tmp}/nope"], "CAMPAIGN_DIR"),
    "campaign_jobs_not_a_number": (["campaign", "run", "{tmp}/case.yaml", "-j", "many"], "--jobs"),
    "campaign_jobs_zero": (["campaign", "run", "{tmp}/case.yaml", "-j", "0"], "'--jobs' / '-j': 0 is not in the range 1<=x<=100000"),
    "campaign_jobs_negative": (["campaign", "run", "{tmp}/case.yaml", "-j", "-1"], "'--jobs' / '-j': -1 is not in the range 1<=x<=100000"),
}


@pytest.mark.parametrize("name", sorted(ARGUMENTS))
def test_bad_command_line_arguments(name: str, tmp_path: Path, no_engine_process: None) -> None:
    """Usage errors too are one line (not click's usage block), exit 2; lazily imported command
    modules are exercised, so a broken import inside a command shows here."""
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case_data()))
    (tmp_path / "a_file").write_text("x")
    arguments, field = ARGUMENTS[name]
    assert_one_line_error(*run_cli([a.replace("{tmp}", str(tmp_path)) for a in arguments]), expected_code=2, field=field)


def _h5(build: Callable[[h5py.File], None]) -> Callable[[Path], None]:
    def make(directory: Path) -> None:
        with h5py.File(directory / "results.h5", "w") as store:
            build(store)
    return make


def _wrong_shapes(store: h5py.File) -> None:
    store.create_dataset("time", data=np.arange(3.0))
    frames = store.create_group("frames")
    frames.create_dataset("position", data=np.zeros(7))
    frames.create_dataset("velocity", data=np.zeros(7))


DAMAGED: dict[str, Callable[[Path], Any]] = {
    "results_with_time_only": _h5(lambda store: store.create_dataset("time", data=np.arange(3.0))),
    "results_of_the_wrong_shapes": _h5(_wrong_shapes),
    "results_a_directory": lambda d: (d / "results.h5").mkdir(),
    "report_not_text": lambda d: (d / "report.json").write_bytes(b"\xff\xfe\x00"),
    "report_of_the_wrong_kinds": lambda d: (d / "report.json").write_text(json.dumps({"study": "avalanche", "deposit": "W"})),
}


@pytest.mark.parametrize("name", sorted(DAMAGED))
def test_post_on_more_damaged_run_directories(name: str, tmp_path: Path) -> None:
    DAMAGED[name](tmp_path)
    assert_one_line_error(*run_cli(["post", str(tmp_path)]), expected_code=5, field="damaged results")


@pytest.mark.parametrize("kind", ["device", "fifo", "foreign", "huge"])
def test_a_validation_record_that_is_no_record_is_one_line_without_reading_it_whole(tmp_path: Path, kind: str) -> None:
    """`demorch validation --record` reads a regular JSON file of bounded size holding a record: a
    device (/dev/zero grew to 23.6 GB before), a FIFO (it hung), a foreign JSON (a KeyError) and a
    file over 50 MB are refused in one line naming --record, exit 2."""
    import os

    import orchestrator.studies.validation_page  # noqa: F401  (imported before the timed call: matplotlib's import is not the check's time)

    path = {"device": Path("/dev/zero"), "fifo": tmp_path / "fifo", "foreign": tmp_path / "foreign.json", "huge": tmp_path / "huge.json"}[kind]
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "foreign":
        path.write_text(json.dumps({"drops": [1, 2]}))
    elif kind == "huge":
        with open(path, "wb") as stream:
            stream.truncate(60_000_000)  # sparse: no disk used
    assert_one_line_error(*run_cli(["validation", "--page-only", "--record", str(path), "--page", str(tmp_path / "page.md")]),
                          expected_code=2, field="--record")


@pytest.mark.parametrize("arguments, field", [(["--size", "nan", "0.015", "0.008"], "--size"), (["--size", "0.031", "inf", "0.008"], "--size"),
                                              (["--density", "nan"], "--density")])
def test_a_brick_of_no_size_is_one_line(arguments: list[str], field: str) -> None:
    """`demorch brick` printed a table of NaN for a NaN size; now one line naming the option and its range."""
    assert_one_line_error(*run_cli(["brick", *arguments]), expected_code=2, field=field)
