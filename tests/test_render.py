"""Rendering: numbers exact, YADE values only as Python literals, decks deterministic."""

from __future__ import annotations

import ast
import json
import math
from pathlib import Path

import jinja2
import numpy as np
import pytest

from orchestrator.case import CaseError, parse_case
from orchestrator.engines.yade.materials import series, split_in_series
from orchestrator.physics import pair_constants
from orchestrator.engines.templating import data_literal, environment
from orchestrator.validation import with_engine
from orchestrator.results import read_results
from orchestrator.runner import render_case, run_case

from orchestrator.parity import sliding_case

from conftest import requires_liggghts


@pytest.mark.parametrize("value", [0.1, 1e-17, 123456.789, -2.5e300, 0, 7, "it's \"quoted\"\nnewline", ["a", 1.5], [1, [2, 3]], {"k": None, "b": True}])
def test_deck_data_round_trips_as_data(value: object) -> None:
    """The |data filter: JSON in a Python string literal; parsing it gives the value back, exactly."""
    literal = data_literal(value)
    assert isinstance(ast.parse(literal, mode="eval").body, ast.Constant)  # one string constant: no code
    assert json.loads(ast.literal_eval(literal)) == value


def test_deck_data_refuses_non_finite_numbers() -> None:
    with pytest.raises(ValueError):
        data_literal({"dt": math.nan})


def test_numpy_numbers_render_as_plain_numbers() -> None:
    """numpy 2 writes repr(np.float64(0.5)) as 'np.float64(0.5)', which LIGGGHTS reads as 0 (a clump
    mass computed with numpy made the template's volume zero)."""
    import numpy as np

    from orchestrator.engines.templating import deck_number

    assert deck_number(np.float64(0.5)) == "0.5" and deck_number(np.int64(3)) == "3"
    assert environment("liggghts").from_string("{{ m }}").render(m=np.float64(6.25e-3)) == "0.00625"


@pytest.mark.parametrize("engine", ["liggghts", "yade"])
def test_no_template_can_emit_raw_text(engine: str) -> None:
    template = environment(engine).from_string("x = {{ value }}")
    with pytest.raises(jinja2.TemplateError, match=r"\|data"):
        template.render(value="__import__('os').system('true')")
    assert template.render(value="case_1") == "x = case_1"  # a safe deck word


def test_liggghts_template_refuses_unsafe_text() -> None:
    template = environment("liggghts").from_string("fix {{ value }}")
    with pytest.raises(jinja2.TemplateError):
        template.render(value="a\nshell rm -rf /")


@pytest.mark.parametrize("engine", ["liggghts", "yade"])
def test_render_is_deterministic_and_exact(engine: str, tmp_path: Path) -> None:
    case = sliding_case(engine)
    first = render_case(case, tmp_path, tmp_path / "a").read_text()
    second = render_case(case, tmp_path, tmp_path / "b").read_text()
    assert first == second
    # LIGGGHTS takes the pair value; YADE twice it per material (series combination of two equal halves).
    assert ("kn peratomtypepair 2 100000.0 " in first) if engine == "liggghts" else ('"kn":200000.0' in first)


def test_yade_script_is_valid_python_holding_the_case_values(tmp_path: Path) -> None:
    case = sliding_case("yade")
    script = render_case(case, tmp_path, tmp_path / "run").read_text()
    tree = ast.parse(script)
    # The case's values are one JSON document, the argument of the only json.loads call.
    calls = [node for node in ast.walk(tree) if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "loads"]
    assert len(calls) == 1 and isinstance(calls[0].args[0], ast.Constant)
    data = json.loads(calls[0].args[0].value)
    assert data["spheres"][0][1] == case.bodies.spheres[0].radius
    assert data["friction"][0][2] == pytest.approx(0.2)


def test_yade_series_split_reproduces_every_pair() -> None:
    case = parse_case(
        {
            "name": "pairs",
            "time": {"duration": 0.1, "output_interval": 0.01},
            "materials": [{"name": "brick", "density": 1700.0}, {"name": "board", "density": 1000.0}],
            "contacts": [
                {"materials": ["brick", "brick"], "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27},
                {"materials": ["brick", "board"], "en2": 0.53, "mu": 0.46, "kn": 1.5e5, "kt_over_kn": 0.3},
            ],
            "bodies": {"spheres": [{"material": "brick", "radius": 0.005, "position": [0, 0, 0.1]}]},
            "walls": [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-1, -1, 0], "edge1": [2, 0, 0], "edge2": [0, 2, 0]}],
        }
    )
    pairs = pair_constants(case)
    for quantity in ("kn", "kt", "cn"):
        per_material = split_in_series(case, pairs, quantity)
        for pair in pairs:
            a, b = pair.materials
            assert series(per_material[a], per_material[b]) == pytest.approx(getattr(pair, quantity), rel=1e-12)


def test_yade_series_split_reports_impossible_pairs() -> None:
    case = with_engine(sliding_case("yade"), "yade")
    data = case.model_dump(mode="json")
    data["contacts"][1]["kn"] = 5e5  # ball/board stiffer than twice ball/ball: not a series combination
    bad = parse_case(data)
    with pytest.raises(CaseError, match=r"kn: YADE combines per-material values in series"):
        split_in_series(bad, pair_constants(bad), "kn")


def test_initial_state_errors_come_before_any_engine(tmp_path: Path, no_engine_process: None) -> None:
    """A missing state file, or a state file on YADE, is a case error naming `initial_state`."""
    case = sliding_case("liggghts").model_copy(update={"initial_state": "no_such.restart"})
    with pytest.raises(CaseError, match=r"^initial_state: no state file at .*no_such\.restart"):
        render_case(case, tmp_path, tmp_path / "run")
    (tmp_path / "packed.restart").write_bytes(b"state")
    with pytest.raises(CaseError, match=r"initial_state: yade cannot start from a state file.*engines that can: liggghts"):
        with_engine(case.model_copy(update={"initial_state": "packed.restart"}), "yade")


def saved_state(directory: Path) -> Path:
    """A state file as a finished run leaves it: state.restart beside its run.json and case.json."""
    directory.mkdir(parents=True)
    (directory / "state.restart").write_bytes(b"state")
    (directory / "run.json").write_text(json.dumps({"status": "completed"}))
    (directory / "case.json").write_text(json.dumps({"save_state": True}))
    return directory / "state.restart"


def test_state_files_in_the_liggghts_deck(tmp_path: Path) -> None:
    """save_state writes a restart at the end; initial_state reads one (copied into the run) instead of the data file."""
    source = saved_state(tmp_path / "packing")
    case = sliding_case("liggghts").model_copy(update={"initial_state": "packing/state.restart", "save_state": True})
    deck = render_case(case, tmp_path, tmp_path / "run").read_text()
    assert "read_restart    initial.restart" in deck and "read_data" not in deck
    assert deck.rstrip().endswith("write_restart   state.restart")
    assert deck.index("reset_timestep  0") < deck.index("\nrun ")
    copy = tmp_path / "run" / "initial.restart"
    assert copy.read_bytes() == b"state" and copy.stat().st_ino != source.stat().st_ino  # a copy, not a link


@pytest.mark.parametrize("prepare", ["any_file", "unfinished_run", "no_save_state"])
def test_initial_state_must_be_a_state_this_package_wrote(prepare: str, tmp_path: Path, no_engine_process: None) -> None:
    source = saved_state(tmp_path / "packing")
    if prepare == "any_file":
        (tmp_path / "secret.txt").write_text("not a restart")
        relative = "secret.txt"
    else:
        key, value = ("status", "failed") if prepare == "unfinished_run" else ("save_state", False)
        record = tmp_path / "packing" / ("run.json" if key == "status" else "case.json")
        record.write_text(json.dumps({key: value}))
        relative = str(source.relative_to(tmp_path))
    case = sliding_case("liggghts").model_copy(update={"initial_state": relative})
    with pytest.raises(CaseError, match=r"^initial_state: .* is not a state this package wrote"):
        render_case(case, tmp_path, tmp_path / "run")


def test_mpi_settings_reach_the_command_and_the_deck(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """MPI processes and the processor grid change how LIGGGHTS is launched and split, not the case.
    Precedence: the explicit option, then the environment, then a study's default split."""
    from orchestrator.engines import RunOptions, get_adapter
    from orchestrator.plan import make_plan

    monkeypatch.setenv("DEMORCH_LIGGGHTS_MPI", "2")
    monkeypatch.delenv("DEMORCH_LIGGGHTS_GRID", raising=False)
    adapter = get_adapter("liggghts", RunOptions(default_grid="1 * 1"))
    deck = adapter.write_input(make_plan(sliding_case("liggghts"), tmp_path), tmp_path)
    assert "processors      1 * 1" in deck.read_text()
    command = adapter.command(deck)
    assert command[command.index("-np") + 1] == "2"
    assert get_adapter("liggghts", RunOptions(mpi_processes=3)).mpi_processes == 3  # the option beats the environment
    monkeypatch.setenv("DEMORCH_LIGGGHTS_GRID", "2 1 1")
    assert get_adapter("liggghts", RunOptions(default_grid="1 * 1")).processor_grid == "2 1 1"  # the user's grid wins


@pytest.mark.parametrize(("variable", "value"), [("DEMORCH_LIGGGHTS_MPI", "two"), ("DEMORCH_LIGGGHTS_MPI", "0"), ("DEMORCH_LIGGGHTS_GRID", "1 *"), ("DEMORCH_LIGGGHTS_GRID", "1 x 1")])
def test_bad_mpi_settings_name_the_variable(variable: str, value: str, monkeypatch: pytest.MonkeyPatch) -> None:
    from orchestrator.engines import get_adapter

    monkeypatch.setenv(variable, value)
    with pytest.raises(CaseError, match=f"{variable}=.*allowed range"):
        get_adapter("liggghts")


@pytest.mark.engine
def test_large_boxes_get_capped_bins_and_the_same_motion(tmp_path: Path) -> None:
    """A box of metres around millimetre spheres gets larger neighbour bins; the physics is unchanged.

    LIGGGHTS bins the whole box at half the cut-off by default: the full-scale boards made that
    1.1 GB per process and 0.2 s per neighbour rebuild. The bins only sort spheres before the
    distance test, so the slide must come out identical (to round-off) with either binning.
    """
    from orchestrator.case import Domain
    from orchestrator.engines.liggghts import adapter as liggghts

    MAX_BINS = liggghts.deck.MAX_BINS
    from orchestrator.results import read_results
    from orchestrator.results import RESULTS
    from orchestrator.runner import run_case

    small = sliding_case("liggghts", duration=0.1)
    large = small.model_copy(update={"domain": Domain(lower=(-3.0, -2.5, -0.6), upper=(3.0, 2.5, 2.9))})
    small_deck = render_case(small, tmp_path, tmp_path / "small").read_text()
    large_deck = render_case(large, tmp_path, tmp_path / "large").read_text()
    binsize = (6.0 * 5.0 * 3.5 / MAX_BINS) ** (1.0 / 3.0)  # 1.7 cm: at most MAX_BINS bins
    assert "binsize" not in small_deck
    assert f"neigh_modify    delay 0 contact_distance_factor 1.1 binsize {binsize!r}" in large_deck
    slides = []
    for case, name in ((small, "small"), (large, "large")):
        run_case(case, tmp_path, tmp_path / name)
        slides.append(read_results(tmp_path / name / RESULTS))
    assert np.abs(slides[0].position[-1] - slides[0].position[0]).max() > 1e-3  # it did slide
    np.testing.assert_allclose(slides[1].position, slides[0].position, rtol=0.0, atol=1e-12)


@requires_liggghts
@pytest.mark.engine
def test_a_run_from_a_saved_state_has_its_own_domain(tmp_path: Path) -> None:
    """A release goes further than the packing it starts from: the state's box (LIGGGHTS drops a body
    that leaves its box) is set to the case's domain. A sphere saved at rest in a 10 cm box falls
    0.44 m in 0.3 s from it, inside the second case's 2 m domain: it is not lost, and it fell as
    g t²/2 (no contact; velocity Verlet is exact under a constant force: 1e-6 relative is round-off)."""
    base = {"name": "state", "engine": "liggghts", "materials": [{"name": "glass", "density": 2500.0}],
            "contacts": [{"materials": ["glass", "glass"], "en2": 0.5, "mu": 0.3, "kn": 1e4, "kt_over_kn": 0.5}],
            "bodies": {"spheres": [{"material": "glass", "radius": 0.005, "position": [0.0, 0.0, 0.0]}]}}
    packing = parse_case({**base, "time": {"duration": 0.01, "output_interval": 0.01}, "gravity": [0.0, 0.0, 0.0], "save_state": True,
                          "domain": {"lower": [-0.05, -0.05, -0.05], "upper": [0.05, 0.05, 0.05]}})
    run_case(packing, tmp_path, tmp_path / "packing")
    release = parse_case({**base, "time": {"duration": 0.3, "output_interval": 0.1}, "initial_state": "packing/state.restart",
                          "domain": {"lower": [-1.0, -1.0, -1.0], "upper": [1.0, 1.0, 1.0]}})
    run_case(release, tmp_path, tmp_path / "release")
    trajectory = read_results(tmp_path / "release" / "results.h5")
    z, t = trajectory.position[-1, 0, 2], trajectory.time[-1]
    assert z < -0.05 and z == pytest.approx(-9.81 * t**2 / 2, rel=1e-6)


@pytest.mark.parametrize("kind", ["clump", "superquadric", "rounded_box"])
def test_the_neighbour_skin_is_the_shapes_skin_length(kind: str, tmp_path: Path) -> None:
    """The skin is SKIN_RADII × the shape's skin length: a clump's largest sphere radius, a rounded
    box's half thickness (4 mm, not its 17.7 mm bounding radius: half the neighbour pairs), a
    superquadric's bounding radius (a smaller skin made its packing slower: liggghts/deck.py). A skin
    only decides which pairs are tested, never a force."""
    from orchestrator.engines.liggghts import deck
    from orchestrator.plan import make_plan
    from orchestrator.studies import brick_drop, brick_pair

    case = brick_pair.pair_case("liggghts", brick_drop.study_brick(kind=kind), "aligned", 40.2)
    shape = make_plan(case, tmp_path).shapes[0]
    text = render_case(case, tmp_path, tmp_path / "run").read_text()
    (line,) = [row for row in text.splitlines() if row.startswith("neighbor ")]
    skin = float(line.split()[1])
    expected = {"clump": shape.radius, "superquadric": shape.bounding_radius, "rounded_box": 0.004}[kind]
    assert skin == pytest.approx(deck.SKIN_RADII * expected, rel=1e-12)
