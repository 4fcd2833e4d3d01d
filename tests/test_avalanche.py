"""The avalanche set-up: geometry, packings and brick counts, then a tiny study on a real engine."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from orchestrator.studies.avalanche.geometry import AvalancheGeometry, apparent_density, brick_count, ordered_pile, rain_positions
from orchestrator.studies.avalanche.study import AvalancheStudy, packing_case, run_study
from orchestrator.shapes.clump import BrickClump
from orchestrator.shapes.rigid import quaternion_matrix
from orchestrator.engines.liggghts import adapter as liggghts
from orchestrator.results import Trajectory, read_results
from orchestrator.results import RESULTS
from orchestrator.runner import run_case
from orchestrator.rundir import saved_case

from conftest import engine_params, requires_liggghts, tiny_study

BRICK = BrickClump(0.031, 0.015, 0.008, 1700.0, (4, 2, 1))


def test_release_box_sits_at_the_launch_height() -> None:
    geometry = AvalancheGeometry()
    corner = geometry.box_corner()
    assert corner[2] == pytest.approx(1.0)  # the trap's foot is 1 m above the toe
    assert corner[0] == pytest.approx(-1.0)  # on a 45° slope, 1 m back from the toe
    walls = {w["name"]: w for w in geometry.walls(trap_closed=True)}
    assert set(walls) == {"slope", "runout", "box_left", "box_right", "box_back", "trap"}
    assert "trap" not in {w["name"] for w in geometry.walls(trap_closed=False)}
    assert np.linalg.norm(walls["box_back"]["edge2"]) == pytest.approx(0.2)


def test_brick_counts_match_the_2012_study() -> None:
    assert brick_count(0.040, 1000.0, BRICK) == pytest.approx(6300, rel=0.02)
    assert brick_count(0.040, 1600.0, BRICK) == pytest.approx(10000, rel=0.02)


def test_rain_grid_lies_inside_the_box_footprint() -> None:
    geometry = AvalancheGeometry()
    positions, orientations = rain_positions(geometry, BRICK, 300, seed=3)
    axes = geometry.box_axes
    local = (positions - geometry.box_corner()) @ axes.T
    assert np.all(local[:, 0] - BRICK.bounding_radius >= 0) and np.all(local[:, 0] + BRICK.bounding_radius <= geometry.box_depth)
    assert np.all(local[:, 1] - BRICK.bounding_radius >= 0) and np.all(local[:, 1] + BRICK.bounding_radius <= geometry.box_width)
    assert np.all(local[:, 2] - BRICK.bounding_radius > 0)
    np.testing.assert_allclose(np.linalg.norm(orientations, axis=1), 1.0)
    # Same seed, same packing; another seed, another.
    assert np.array_equal(rain_positions(geometry, BRICK, 300, seed=3)[1], orientations)
    assert not np.array_equal(rain_positions(geometry, BRICK, 300, seed=4)[1], orientations)


def test_ordered_pile_lays_bricks_along_the_slope_at_the_experiments_density() -> None:
    from orchestrator.studies.avalanche.study import PILE_GAP

    geometry = AvalancheGeometry()
    positions, orientations = ordered_pile(geometry, BRICK, 19 * 26 * 2, gap=0.0)  # two full layers
    long_axis = quaternion_matrix(orientations[0]) @ [1.0, 0.0, 0.0]
    np.testing.assert_allclose(long_axis, geometry.down, atol=1e-12)
    # Bricks flush: mass / (box floor × 2 layers) = 1700 × the share of the floor under the rows,
    # exactly (the levelling fills the strips between the rows and the walls).
    fill = (19 * BRICK.length) * (26 * BRICK.width) / (0.6 * 0.4)
    assert apparent_density(geometry, positions, orientations, BRICK) == pytest.approx(1700.0 * fill, rel=1e-9)
    # The pile as a study lays it: 19 × 26 still fit at PILE_GAP, and once the layers have settled onto
    # each other (gaps normal to the floor closed) it is within 3 % of the experiment's 1600 kg/m³.
    positions, orientations = ordered_pile(geometry, BRICK, 19 * 26 * 20, gap=PILE_GAP)
    axes = geometry.box_axes
    local = (positions - geometry.box_corner()) @ axes.T
    assert local[:, 0].max() + BRICK.length / 2 < 0.6 and local[:, 1].max() + BRICK.width / 2 < 0.4
    layer = np.round((local[:, 2] - PILE_GAP) / (BRICK.thickness + PILE_GAP) - 0.5)
    settled = positions - np.outer(layer * PILE_GAP + PILE_GAP, geometry.normal)
    assert apparent_density(geometry, settled, orientations, BRICK) == pytest.approx(1600.0, rel=0.03)


@pytest.mark.parametrize("turn", [(0.0, 0.0, 0.0), (90.0, 0.0, 0.0), (0.0, 90.0, 0.0), (90.0, 0.0, 90.0)])
def test_apparent_density_of_one_brick_on_a_face_is_its_own(turn: tuple[float, float, float]) -> None:
    """The volume under the top surface of a brick lying on any face is its box: 1700 kg/m³ back."""
    from scipy.spatial.transform import Rotation

    geometry = AvalancheGeometry(box_depth=0.1, box_width=0.1, box_height=0.05)
    rotation = Rotation.from_euler("xyz", turn, degrees=True)
    extent = np.abs(rotation.as_matrix()) @ BRICK.extent  # along u, v, n
    frame = Rotation.from_matrix(np.stack([geometry.down, [0.0, 1.0, 0.0], geometry.normal], axis=1)) * rotation  # brick → world
    position = geometry.box_to_world(extent / 2 + [0.03, 0.04, 0.0])  # edges on grid cell edges (1 mm), bare floor around
    x, y, z, w = frame.as_quat()
    density = apparent_density(geometry, position[None], np.array([[w, x, y, z]]), BRICK, spacing=0.001)
    assert density == pytest.approx(1700.0, rel=1e-9)


def test_flipped_bevelled_pile_turns_bricks_at_random_and_keeps_each_inside_its_cell() -> None:
    """Random flips: each brick half-turned about one of its axes or not, with a seed; no two overlap."""
    from orchestrator.studies.avalanche.geometry import HALF_TURNS, pile_rows

    geometry, bevelled, gap = AvalancheGeometry(), BrickClump(0.031, 0.015, 0.008, 1700.0, (4, 2, 1), bevel_deg=2.0), 0.0005
    count = 400
    positions, orientations = ordered_pile(geometry, bevelled, count, gap=gap, flip_seed=11)
    again, _ = ordered_pile(geometry, bevelled, count, gap=gap, flip_seed=11)
    np.testing.assert_array_equal(positions, again)  # reproducible from the seed
    _, unflipped = ordered_pile(geometry, bevelled, 1, gap=gap)
    base = quaternion_matrix(unflipped[0])
    turns = [int(np.argmin([np.abs(quaternion_matrix(q) - base @ quaternion_matrix(h)).max() for h in HALF_TURNS])) for q in orientations]
    for q, turn in zip(orientations, turns):
        np.testing.assert_allclose(quaternion_matrix(q), base @ quaternion_matrix(HALF_TURNS[turn]), atol=1e-12)
    assert all(0.15 < turns.count(t) / count < 0.35 for t in range(4))  # the four turns, about equally often
    # Every corner of every brick lies in that brick's cell of the pile: bevels jutting out of the
    # nominal box on either side still leave the neighbours apart.
    rows, columns = pile_rows(geometry, bevelled, gap)
    cell = bevelled.extent + gap
    axes = geometry.box_axes
    index = np.arange(count)
    cells = np.stack([index % rows, (index // rows) % columns, index // (rows * columns)], axis=1)
    for k in range(count):
        corners = positions[k] + (bevelled.vertices.reshape(-1, 3) - bevelled.centroid_offset) @ quaternion_matrix(orientations[k]).T
        local = (corners - geometry.box_corner()) @ axes.T - np.array([0.0, 0.0, gap])
        assert np.all(local >= cells[k] * cell - 1e-12) and np.all(local <= (cells[k] + 1) * cell + 1e-12)


def test_flips_are_refused_for_a_random_pour() -> None:
    with pytest.raises(Exception, match=r"packing.flips|flips: only for kind ordered_pile"):
        AvalancheStudy.model_validate({"name": "x", "packing": {"kind": "random_pour", "flips": True}})


def test_a_stages_pre_flight_checks_name_the_studys_fields(tmp_path: Path) -> None:
    """The checks made before an engine starts (orchestrator.preflight) speak of the study's own
    fields for a study's stage: a packing of 100 s written every 10 µs is 10 million frames, over the
    million allowed."""
    from orchestrator.case import CaseError
    from orchestrator.plan import make_plan

    study = AvalancheStudy.model_validate({"name": "x", "geometry": {"box_depth": 0.1, "box_width": 0.1, "box_height": 0.1},
                                           "packing": {"volume": 0.0005, "settle_time": 100.0},
                                           "release": {"output_interval": 1e-5}})
    with pytest.raises(CaseError, match=r"^release\.output_interval: 1e-05 s gives [0-9]+ frames"):
        make_plan(packing_case(study), tmp_path)


@pytest.mark.engine
def test_capped_bins_leave_a_brick_pour_unchanged_to_round_off(tmp_path: Path) -> None:
    """Bricks (clumps) poured onto mesh walls move the same with bins far larger than LIGGGHTS' own.

    LIGGGHTS' bins only sort spheres and triangles before the distance tests, so larger bins (the
    cap of engines/liggghts/adapter.py, here forced to 2.2 cm against the 6 mm default) may change the order
    of the force sums, never a force. Measured: the two pours agree bit for bit until the first
    impacts (0.1 s), then differ by round-off that the collisions amplify (1.5e-14 m at 0.12 s,
    5e-11 m at 0.16 s, about 10 x per 0.01 s, as chaotic granular flow does). A contact missed or
    added would shift a brick by its overlap at once (1e-5 m and more), far above the 1e-8 m allowed.
    """
    study = tiny_study("liggghts")
    study = study.model_copy(update={"packing": study.packing.model_copy(update={"settle_time": 0.16}),
                                     "brick": study.brick.model_copy(update={"kind": "clump"})})
    pours = []
    for name, cap in (("own_bins", float("inf")), ("capped_bins", 2e5)):
        run_case(packing_case(study), tmp_path, tmp_path / name, adapter=liggghts.LiggghtsAdapter(max_bins=cap))
        pours.append(read_results(tmp_path / name / RESULTS))
    assert "binsize 0.02" in (tmp_path / "capped_bins" / "in.liggghts").read_text()
    assert "binsize" not in (tmp_path / "own_bins" / "in.liggghts").read_text()
    kinetic = (pours[0].velocity**2 * pours[0].mass[None, :, None]).sum(axis=(1, 2))
    assert kinetic[-1] < 0.5 * kinetic.max()  # the bricks did collide: half their energy is gone
    np.testing.assert_allclose(pours[1].position, pours[0].position, rtol=0.0, atol=1e-8)


@pytest.mark.engine
@requires_liggghts
def test_the_ordered_pile_packs_under_a_lid_that_holds_a_brick_thrown_up(tmp_path: Path) -> None:
    """The stacked pile's packing closes the box at its height (the rain's does not need to), so a
    brick squeezed out of the partial top layer cannot leave it. Here the top brick is launched at
    2 m/s along the box's normal, enough to rise 20 cm with nothing above it: with the lid every centre
    ends inside the box, at most half a thickness (4 mm) from the lid at any frame."""
    study = tiny_study("liggghts")
    study = study.model_copy(update={"packing": study.packing.model_copy(update={"kind": "ordered_pile", "settle_time": 0.3})})
    case = packing_case(study)
    geometry = study.geometry.build()
    lid = {w.name: w for w in case.walls}["lid"]
    assert geometry.world_to_box(np.array([lid.origin]))[0, 2] == pytest.approx(study.geometry.box_height)
    assert "lid" not in {w.name for w in packing_case(tiny_study("liggghts")).walls}  # the rain stands above the box
    top = int(np.argmax(geometry.world_to_box(np.array([c.position for c in case.bodies.clumps]))[:, 2]))
    thrown = case.model_copy(deep=True)
    thrown.bodies.clumps[top] = thrown.bodies.clumps[top].model_copy(update={"velocity": tuple(2.0 * geometry.normal)})
    run_case(thrown, tmp_path, tmp_path / "thrown")
    packed = read_results(tmp_path / "thrown" / RESULTS)
    height = geometry.world_to_box(packed.position.reshape(-1, 3))[:, 2]
    assert height.max() <= study.geometry.box_height - 0.004 + 1e-4
    assert height[-packed.n_bodies:].max() < study.geometry.box_height and not geometry.outside_box(packed.position[-1]).any()


@pytest.mark.parametrize("engine", engine_params())
def test_tiny_avalanche_reaches_the_flat_and_stops_and_its_packing_is_reused(engine: str, tmp_path: Path) -> None:
    study = tiny_study(engine)
    packings = tmp_path / "packings"
    report = run_study(study, tmp_path / "first", packings=packings)
    trajectory = read_results(tmp_path / "first" / "run" / RESULTS)
    assert trajectory.n_bodies == study.brick_count
    assert np.isfinite(trajectory.position[-1]).all()  # no brick lost, mass conserved
    assert np.all(trajectory.position[0, :, 0] < 0.0)  # packed in the box, on the slope, at the opening
    # Packed as a slab in the box standing on its base: every centre within the box's depth from the
    # trap, its width and its height above the slope (not heaped against the trap above the box).
    geometry = study.geometry.build()
    assert not geometry.outside_box(trajectory.position[0]).any()
    assert report["initial"]["bodies_outside_box"] == 0
    assert report["initial"]["rear_z"] > report["initial"]["z_cm"] > geometry.box_corner()[2]
    assert report["packing"]["reused"] is False and report["finished_before"] is False
    deposit = report["deposit"]
    assert deposit["bodies_in_deposit"] + deposit["outliers"] == study.brick_count  # every brick accounted for
    assert deposit["x_cm"] > 0.0  # the mass centre ended on the flat board
    # Stopped: what still moves (a brick settling on an edge, say) holds < 1e-4 of the energy released.
    assert report["kinetic_to_released_energy"] < 1e-4
    assert 0.0 < deposit["travel_angle_cm_deg"] < 45.0
    # The front (the deposit's leading brick) never moves back by more than a brick length and ends
    # within one of the deposit's distal end R.
    front = np.array(report["front"]["position"], dtype=float)
    brick_length = study.brick.length
    assert np.nanmax(np.fmax.accumulate(front) - front) <= brick_length
    assert abs(report["front"]["final_position"] - deposit["runout"]) <= brick_length
    # The release starts exactly where the packing ended (LIGGGHTS: its restart file; YADE: exact placement).
    packing_dir = Path(report["packing"]["directory"])
    packed = read_results(packing_dir / RESULTS)
    np.testing.assert_allclose(trajectory.position[0], packed.position[-1], rtol=0, atol=1e-9)
    # Packed in place, the state is not turned between the stages: the kinetic energy at the opening is
    # the packing's last (to round-off of the velocities written, 1e-9 relative).
    kinetic = [float((t.mass[:, None] * t.velocity[i] ** 2).sum()) for t, i in ((packed, -1), (trajectory, 0))]
    assert kinetic[1] == pytest.approx(kinetic[0], rel=1e-9, abs=1e-15)
    assert saved_case(packing_dir).gravity == pytest.approx(geometry.packing_gravity())  # the box on its base
    assert saved_case(tmp_path / "first" / "run").gravity == pytest.approx((0.0, 0.0, -9.81))  # the release: vertical
    # A brick may fall off a board's edge in a release (counted, not an error); never out of the box.
    assert saved_case(tmp_path / "first" / "run").lost_bodies == "drop" and saved_case(packing_dir).lost_bodies == "error"
    assert deposit["bodies_lost"] == 0
    # Rerunning reuses the packing and the release: nothing new is computed.
    rerun = run_study(study, tmp_path / "first", packings=packings)
    assert rerun["deposit"] == deposit and rerun["finished_before"] is True
    # Another release (slipperier board) from the same packing: no new packing run, a different flow.
    # μ 0.25 against 0.46: with μ 0.40 the slipperier board once ended at X_CM 0.094 m against 0.103 m,
    # after a change of LIGGGHTS' neighbour bins alone; a few bricks scatter by more than that contrast.
    slippery = study.model_copy(update={"contacts": study.contacts.model_copy(update={"brick_board": study.contacts.brick_board.model_copy(update={"mu": 0.25})})})
    packing_mtime = (packing_dir / RESULTS).stat().st_mtime_ns
    # Run into the same directory: the finished release was made from other inputs, so it is set aside
    # (kept in the attic beside it, with the reason) and the study runs again; its packing is reused.
    second = run_study(slippery, tmp_path / "first", packings=packings)
    assert second["packing"]["reused"] is True and second["packing"]["directory"] == str(packing_dir)
    assert second["finished_before"] is False and "made from other inputs" in second["set_aside"]["why"]
    kept = Path(second["set_aside"]["attic"])
    assert json.loads((kept / "report.json").read_text())["deposit"] == deposit and (kept / "run" / RESULTS).is_file()
    assert (packing_dir / RESULTS).stat().st_mtime_ns == packing_mtime
    assert len([d for d in packings.iterdir() if d.is_dir()]) == 1
    assert second["deposit"]["x_cm"] > deposit["x_cm"]  # less friction on the boards: the mass travels further


@requires_liggghts
@pytest.mark.engine
def test_the_density_search_stops_within_its_budget_and_keeps_the_closest_trial(tmp_path: Path) -> None:
    """A target no pour can reach (1500 kg/m³, a random pour of bricks packs at ≈ 1000): the search
    packs its two trials, the second with less friction than the first (a looser pile asks for a
    smoother contact), keeps the denser of the two and says the target was missed."""
    from orchestrator.engines import RunOptions
    from orchestrator.studies.avalanche.study import KIND

    study = tiny_study("liggghts")
    study = study.model_copy(update={"packing": study.packing.model_copy(update={
        "apparent_density": 1500.0, "settle_time": 0.25, "density_search": study.packing.density_search.model_copy(update={"max_trials": 2})})})
    prepared, directory, reused, record = KIND.prepare(study, tmp_path / "packings", None, None, RunOptions())
    trials = record["trials"]
    assert len(trials) == 2 and not record["target_reached"] and "closest of 2 trial(s)" in record["warning"]
    assert trials[1]["mu"] < trials[0]["mu"] == 0.86
    best = max(trials, key=lambda t: t["apparent_density"])
    assert str(directory) == best["directory"] and record["brick_brick_mu"] == best["mu"]
    assert all(t["apparent_density"] < 1500.0 and t["wall_s"] > 0 for t in trials)
    assert {c.mu for c in prepared.contacts if c.materials == ("brick", "brick")} == {best["mu"]}
    # Asked again, every trial is reused: the same packings, nothing new run.
    again = KIND.prepare(study, tmp_path / "packings", None, None, RunOptions())[3]
    assert [t["directory"] for t in again["trials"]] == [t["directory"] for t in trials] and all(t["reused"] for t in again["trials"])


def test_the_packing_stands_the_box_on_its_base_and_the_release_keeps_vertical_gravity() -> None:
    """Gravity along the slope's normal while packing (Fig. 9: the box filled standing on its base, then set
    on the slope); the release's walls are the box's own, its height, without the trap."""
    from orchestrator.studies.avalanche.study import release_case

    study = tiny_study("liggghts")
    geometry = study.geometry.build()
    gravity = np.array(packing_case(study).gravity)
    np.testing.assert_allclose(gravity, -9.81 * geometry.normal, atol=1e-12)
    assert gravity @ geometry.down == pytest.approx(0.0, abs=1e-12)  # nothing pushes the bricks towards the trap
    full = AvalancheGeometry()
    centre, rear = full.slab(0.040)
    assert (centre[0], centre[2]) == pytest.approx((-1.15, 1.27), abs=0.01)  # Fig. 9's initial centre of mass
    assert (rear[0], rear[2]) == pytest.approx((-1.41, 1.41), abs=0.02)  # Fig. 9's upper end of the box's base
    release = release_case(study, _packed(study), None)
    assert tuple(release.gravity) == (0.0, 0.0, -9.81)
    walls = {w.name: w for w in release.walls}
    assert "trap" not in walls and np.linalg.norm(walls["box_back"].edge2) == pytest.approx(study.geometry.box_height)


def test_preset_studies_load_with_the_paper_brick_counts() -> None:
    from orchestrator.studies.avalanche.study import load_study

    presets = {p.stem: load_study(p) for p in sorted((Path(__file__).parent.parent / "cases" / "avalanche").glob("*.yaml"))}
    # The paper's counts are round ("≈ 10 000 bricks"); 40 l at 1600 kg/m³ of the study's brick
    # (6.2475 g, rounded at 1 mm) is 10 244 bricks, of the sharp box (6.324 g) 10 120: hence 3 %.
    assert presets["random_pour_full"].brick.build().mass == pytest.approx(6.2475e-3, rel=1e-5)
    assert presets["random_pour_full"].brick_count == pytest.approx(6300, rel=0.03)
    soft = presets["random_pour_full_kn2e4"]
    assert soft.brick_count == presets["random_pour_full"].brick_count and soft.seed == presets["random_pour_full"].seed
    assert soft.contacts.brick_brick.kn == soft.contacts.brick_board.kn == 2e4
    assert soft.release.stop_at_rest is not None and soft.release.stop_at_rest.stray_fraction == 0.01  # the measured 52 min
    assert presets["ordered_pile_full"].brick_count == pytest.approx(10000, rel=0.03)
    assert presets["ordered_pile_bevelled_full"].brick_count == pytest.approx(10000, rel=0.02)
    assert presets["ordered_pile_bevelled_full"].brick.build().bevel_deg == 2.0 and presets["ordered_pile_bevelled_full"].packing.flips
    assert presets["small"].brick_count == pytest.approx(95, rel=0.02)


def test_packing_law_must_match_the_flow_law() -> None:

    with pytest.raises(Exception, match=r"packing.contacts.law"):
        AvalancheStudy.model_validate({"name": "x", "contacts": {"law": "bilinear"}, "packing": {"contacts": {"law": "linear"}}})


def test_packing_key_ignores_what_happens_after_the_opening() -> None:
    """Studies that differ only in the flow's contacts or duration share a packing; a packing input changes it."""
    from orchestrator.validation import with_engine
    from orchestrator.studies.avalanche.study import packing_key

    study = tiny_study("liggghts")
    longer = study.model_copy(update={"release": study.release.model_copy(update={"duration": 3.0})})
    other_flow = study.model_copy(update={"contacts": study.contacts.model_copy(update={"law": "bilinear", "brick_brick": study.contacts.brick_brick.model_copy(update={"en2": 0.3})})})
    other_seed = study.model_copy(update={"seed": 7})
    key = packing_key(study)
    assert packing_key(longer) == key and packing_key(other_flow) == key
    assert packing_key(other_seed) != key
    assert packing_key(with_engine(study, "yade")) != key  # another engine, another packing


def _packed(study: AvalancheStudy, n: int = 3) -> Trajectory:
    """A one-frame packing of n bricks at rest in the study's box (for building its release case)."""
    position = study.geometry.build().box_to_world([0.05, 0.05, 0.01])
    return Trajectory(time=np.zeros(1), ids=np.arange(n), material=np.zeros(n, dtype=int), mass=np.ones(n), radius=np.full(n, 0.01),
                      inertia=np.ones((n, 3)), position=np.tile(position, (1, n, 1)), velocity=np.zeros((1, n, 3)),
                      angular_velocity=np.zeros((1, n, 3)), orientation=np.tile([1.0, 0.0, 0.0, 0.0], (1, n, 1)))


def test_packing_step_is_its_own_and_only_the_packings() -> None:
    """`packing.time_safety_factor` sets the packing's Δt (a fraction of the shortest contact
    duration) and nothing of the release; unset, the packing is the one it always was (same key)."""
    from orchestrator import physics
    from orchestrator.studies.avalanche.study import packing_key, release_case

    study = tiny_study("liggghts")
    coarse = study.model_copy(update={"packing": study.packing.model_copy(update={"time_safety_factor": 0.04})})
    default_step = physics.time_step(packing_case(study))
    # the engine's default factor is 0.02 for the compiled bilinear law: 0.04 doubles the step
    assert physics.time_step(packing_case(coarse)) == pytest.approx(2.0 * default_step, rel=1e-12)
    assert packing_key(coarse) != packing_key(study)
    unset = study.model_copy(update={"packing": study.packing.model_copy(update={"time_safety_factor": None})})
    assert packing_key(unset) == packing_key(study)
    packed = _packed(study)
    assert physics.time_step(release_case(coarse, packed, None)) == physics.time_step(release_case(study, packed, None))


@pytest.mark.parametrize(("settings", "kind"), [
    ({}, "rounded_box"),
    ({"contacts": {"law": "linear"}}, "superquadric"),
    ({"release": {"record_contacts": True}}, "superquadric"),
    ({"brick": {"bevel_deg": 2.0, "rounding": 0.0}}, "clump"),
    ({"brick": {"kind": "superquadric"}}, "superquadric"),
    ({"engine": "yade"}, "clump"),
])
def test_a_study_gets_the_engines_preferred_brick_where_its_settings_allow(settings: dict, kind: str) -> None:
    """LIGGGHTS' preferred brick is the rounded box; a study it cannot serve (a linear law, recorded
    contacts: the rounded box has neither) gets the superquadric, a bevelled brick a clump."""
    study = AvalancheStudy.model_validate({"name": "x", "engine": "liggghts", **settings})
    assert study.brick_spec.kind == kind


def test_engine_override_gives_a_runnable_study() -> None:
    """`demorch avalanche -e yade`: the study, and the cases it expands into, run on the engine asked for."""
    from orchestrator.validation import with_engine
    from orchestrator.studies.avalanche.study import packing_case

    study = with_engine(tiny_study("liggghts"), "yade")
    assert packing_case(study).engine.value == "yade" and packing_case(study).save_state is False
    assert with_engine(study, None) is study


def test_the_packaged_reference_is_the_shared_one_where_both_exist() -> None:
    """The packaged copy (installs without shared/, fresh clones) carries every number the project's
    shared reference has: a section missing there breaks the studies that read it."""
    import orchestrator.studies.reference as reference

    if not reference.SHARED_REFERENCE.is_file():
        pytest.skip("no shared/reference beside this checkout")
    assert reference.PACKAGED_REFERENCE.read_text() == reference.SHARED_REFERENCE.read_text(), (
        "copy shared/reference/reference.toml to orchestrator/data/reference.toml")


def test_reference_numbers_fall_back_to_the_packaged_copy(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """Installed without the project's shared/ folder, reports still have their reference numbers."""
    import orchestrator.studies.reference as avalanche_study

    monkeypatch.delenv("DEMORCH_REFERENCE", raising=False)
    monkeypatch.setattr(avalanche_study, "SHARED_REFERENCE", tmp_path / "absent.toml")
    assert avalanche_study.reference_path() == avalanche_study.PACKAGED_REFERENCE
    reference = avalanche_study.load_reference()
    assert reference["contact"]["richefeu2012"]["brick_support"]["en2"] == 0.53
    monkeypatch.setenv("DEMORCH_REFERENCE", str(tmp_path / "missing.toml"))
    with pytest.raises(avalanche_study.CaseError, match=r"reference numbers: cannot read"):
        avalanche_study.load_reference()


def test_packing_verdict_passes_within_its_tolerance_and_blames_a_small_box() -> None:
    from orchestrator.studies.avalanche.table import packing_verdict

    full = 0.6 * 0.4
    assert packing_verdict(1019.0, 1000.0, full) == "pass"  # the density search's default tolerance: 2 %
    assert packing_verdict(1025.0, 1000.0, full) == "off by +2%"
    assert packing_verdict(1025.0, 1000.0, full, tolerance=0.03) == "pass"
    assert packing_verdict(940.0, 1000.0, full) == "off by -6%"
    assert packing_verdict(940.0, 1000.0, full / 1.5) == "off by -6%"  # a box near the experiment's: no excuse
    small = packing_verdict(820.0, 1000.0, 0.148 * 0.099)
    assert small.startswith("off by -18%: expected") and "1/16 of the experiment's floor" in small


def test_the_report_shows_the_opening_beside_fig9_and_the_demo_beside_the_study_codes_ranges() -> None:
    """The table's rows of the initial state: the slab's points always, Fig. 9's for the experiment's box;
    the demo's deposit rows carry the study code's ranges for the demo (validation record)."""
    from orchestrator.studies.avalanche.table import demo_ranges
    from orchestrator.studies.avalanche.table import comparison_rows
    from orchestrator.studies.avalanche.study import load_study

    initial = {"x_cm": -1.152, "z_cm": 1.272, "rear_x": -1.432, "rear_z": 1.432, "bulk_volume": 0.0408, "apparent_density": 981.0,
               "bodies_outside_box": 0, "slab_x_cm": -1.153, "slab_z_cm": 1.271, "slab_rear_x": -1.424, "slab_rear_z": 1.424}
    deposit_keys = ("length", "runout", "width", "height", "x_cm", "travel_angle_cm_deg", "fahrboschung_deg", "outliers")
    report = {"deposit": dict.fromkeys(deposit_keys, 1.0), "front": {"max_velocity": 1.0, "final_position": 1.0,
              "position": [0.0], "velocity": [1.0]}, "initial": initial}
    full = {**report, "study": load_study(Path(__file__).parent.parent / "cases" / "avalanche" / "random_pour_full.yaml").model_dump(mode="json")}
    rows = {name: reference for name, _, reference, _ in comparison_rows(full, {})}
    assert rows["opening: centre of mass x (m)"] == "slab: -1.153; Fig. 9: ≈ -1.15"
    assert rows["opening: rear of the base z (m)"] == "slab: 1.424; Fig. 9: ≈ 1.41"
    assert demo_ranges(full) is None and rows["R (m)"] == ""
    demo = {**report, "study": load_study(Path(__file__).parent.parent / "cases" / "avalanche" / "small.yaml").model_dump(mode="json")}
    ranges = demo_ranges(demo)
    rows = {name: reference for name, _, reference, _ in comparison_rows(demo, {}, ranges)}
    assert rows["R (m)"].startswith(f"{ranges['runout'][0]:.3g}–{ranges['runout'][1]:.3g} (study's code")
    assert "Fig. 9" not in rows["opening: centre of mass x (m)"]


def test_a_full_scale_deposit_is_shown_beside_the_experiments_with_its_verdicts() -> None:
    """At full scale each deposit metric sits beside the experiment's (reference.toml
    [avalanche.manzella2009.deposit]) and the study's DEM, judged on the experiment: L, R, W within
    10 %, X_CM within 5 cm, the angles within 2°, H as a ratio; the ordered pile beside its own
    experiment and both of the study's brick models."""
    from orchestrator.studies.avalanche.study import load_study
    from orchestrator.studies.avalanche.table import comparison_rows
    from orchestrator.studies.reference import load_reference

    reference = load_reference()
    experiment = reference["avalanche"]["manzella2009"]["deposit"]["random_pour_experiment"]
    deposit = {"length": experiment["L"] * 1.09, "runout": experiment["R"] * 1.12, "width": experiment["W"], "height": 2 * experiment["H"],
               "x_cm": experiment["X_CM"] + 0.06, "travel_angle_cm_deg": experiment["phi_CM"] - 1.9, "fahrboschung_deg": 35.0, "outliers": 0}
    cases = Path(__file__).parent.parent / "cases" / "avalanche"
    report = {"deposit": deposit, "front": {"max_velocity": 1.0, "final_position": 1.0, "position": [0.0], "velocity": [1.0]},
              "study": load_study(cases / "random_pour_full.yaml").model_dump(mode="json")}
    rows = {name: (reference_cell, verdict) for name, _, reference_cell, verdict in comparison_rows(report, reference)}
    assert rows["L (m)"] == ("experiment 0.931; study's DEM 0.882", "pass")
    assert rows["R (m)"][1] == "off by +12% (allowed ±10%)"
    assert rows["H (m)"][1] == "2.00 × the experiment's"
    assert rows["X_CM (m)"][1] == "off by +0.06 (allowed ±0.05)"
    assert rows["φ_CM (°)"][1] == "pass" and rows["φ_app (°)"][1] == "off by +3 (allowed ±2)"
    report["study"] = load_study(cases / "ordered_pile_full.yaml").model_dump(mode="json")
    rows = {name: (reference_cell, verdict) for name, _, reference_cell, verdict in comparison_rows(report, reference)}
    assert rows["W (m)"][0] == "experiment 1.389; study's DEM: perfect 1.039, bevelled 1.21"
    quarter = {**report, "study": load_study(cases / "random_pour_quarter.yaml").model_dump(mode="json")}
    assert {verdict for name, _, _, verdict in comparison_rows(quarter, reference) if name == "L (m)"} == {""}  # not the experiment's set-up
