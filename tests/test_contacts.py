"""Contact output (`record_contacts`): the engines' contacts read back into results.h5 /contacts, the
per-body counts and force sums, the coordination number and the force chains."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from orchestrator.case import CaseError, parse_case
from orchestrator.engines.liggghts.dump import contact_rows, read_local_dump
from orchestrator.post import contacts as derived
from orchestrator.results import CONTACT_LAYOUT, Contacts, layout, read_results
from orchestrator.runner import run_case
from tests.conftest import engine_params

G = 9.81
RADIUS = 0.005
KN_SPHERES, KN_FLOOR = 1.0e4, 2.0e4


def pressed_case(engine: str) -> dict:
    """A sphere resting on a glued one, and a sphere resting on the floor (linear law, e² 0.1:
    at rest well before the end)."""
    return {
        "name": "pressed",
        "engine": engine,
        "time": {"duration": 0.2, "output_interval": 0.05},
        "materials": [{"name": "glass", "density": 2500.0}, {"name": "steel", "density": 7800.0}],
        "contacts": [
            {"materials": ["glass", "glass"], "en2": 0.1, "mu": 0.3, "kn": KN_SPHERES, "kt_over_kn": 0.5},
            {"materials": ["glass", "steel"], "en2": 0.1, "mu": 0.3, "kn": KN_FLOOR, "kt_over_kn": 0.5},
        ],
        "bodies": {"spheres": [
            {"material": "glass", "radius": RADIUS, "position": [0.0, 0.0, 2 * RADIUS], "fixed": True},  # clear of the floor
            {"material": "glass", "radius": RADIUS, "position": [0.0, 0.0, 4 * RADIUS]},
            {"material": "glass", "radius": RADIUS, "position": [0.03, 0.0, RADIUS]},
        ]},
        "walls": [
            {"name": "side", "type": "rectangle", "material": "steel", "origin": [-0.05, 0.02, 0.0], "edge1": [0.1, 0, 0], "edge2": [0, 0, 0.03]},
            {"name": "floor", "type": "rectangle", "material": "steel", "origin": [-0.05, -0.05, 0.0], "edge1": [0.1, 0, 0], "edge2": [0, 0.1, 0]},
        ],
        "domain": {"lower": [-0.06, -0.06, -0.01], "upper": [0.06, 0.06, 0.05]},
        "record_contacts": True,
    }


@pytest.mark.parametrize("engine", engine_params())
def test_pressed_spheres_read_back_the_force_the_law_gives(engine: str, tmp_path: Path) -> None:
    """At rest the linear law's force is k_n δ (the dashpot term vanishes with the speed), δ taken from
    the recorded positions, and it carries the weight m g. Tolerance 0.5 %: the bodies are at rest to
    1e-6 m/s, and YADE's forces are those of the step before the frame (Δt ~ 1e-5 s)."""
    case = parse_case(pressed_case(engine))
    run_case(case, tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / "results.h5")
    recorded = trajectory.contacts
    assert recorded is not None and recorded.n_frames == trajectory.n_frames
    assert np.nanmax(np.abs(trajectory.velocity[-1])) < 1e-5
    rows = recorded.frame(-1 % recorded.n_frames)
    body, wall = recorded.body[rows], recorded.wall[rows]
    normal, tangential, point = recorded.normal_force[rows], recorded.tangential_force[rows], recorded.point[rows]
    weight = trajectory.mass[1] * G
    position = trajectory.position[-1]

    pair = np.flatnonzero((np.sort(body, axis=1) == [0, 1]).all(axis=1))
    assert len(pair) == 1 and wall[pair[0]] == -1
    k = pair[0]
    on_lower = normal[k] if body[k, 0] == 0 else -normal[k]  # the force on the glued sphere
    overlap = 2 * RADIUS - np.linalg.norm(position[1] - position[0])
    assert on_lower[2] == pytest.approx(-weight, rel=5e-3)
    assert np.linalg.norm(normal[k]) == pytest.approx(KN_SPHERES * overlap, rel=5e-3)
    assert np.linalg.norm(tangential[k]) < 1e-6 * weight
    assert point[k] == pytest.approx([0.0, 0.0, 3 * RADIUS], abs=RADIUS / 100)

    on_floor = np.flatnonzero(body[:, 0] == 2)
    assert len(on_floor) == 1
    k = on_floor[0]
    assert body[k, 1] == -1 and wall[k] == 1  # the floor, second in the case's walls
    assert normal[k][2] == pytest.approx(weight, rel=5e-3)
    assert np.linalg.norm(normal[k]) == pytest.approx(KN_FLOOR * (RADIUS - position[2, 2]), rel=5e-3)
    assert point[k] == pytest.approx([0.03, 0.0, 0.0], abs=RADIUS / 100)

    with h5py.File(tmp_path / "run" / "results.h5") as store:
        assert store["frames/contact_count"][-1].tolist() == [1, 1, 1]
        assert store["frames/normal_force_sum"][-1] == pytest.approx([weight, weight, weight], rel=5e-3)
        assert store["contacts/coordination"][-1] == pytest.approx(2 / 3)
        assert store["contacts/branch"][rows][pair[0]] == pytest.approx((position[1] - position[0]) * (1 if body[pair[0], 0] == 0 else -1), abs=1e-9)
    assert set(CONTACT_LAYOUT) <= set(layout(tmp_path / "run" / "results.h5"))


@pytest.mark.parametrize("engine", engine_params())
def test_a_dropped_brick_shows_its_contact_episode_and_rests_on_four_corners(engine: str, tmp_path: Path) -> None:
    """The study's rounded brick (1 mm corners) dropped flat from 10 mm. The impact lasts about 0.4 ms
    (π √(m / 4 k_n)), so frames every 0.1 ms catch it: the first frame with a contact comes at the
    free-fall time √(2h/g) = 45.2 ms (within one frame after it), a rebound gives a second contact
    episode, and at rest the brick stands on its four lowest corner spheres, whose normal forces
    carry m g (1 %: at rest, the summed force equals the weight to the residual speed's dashpot term)."""
    gap = 0.010
    case = parse_case({
        "name": "brick_on_plate",
        "engine": engine,
        "time": {"duration": 0.3, "output_interval": 1e-4},
        "materials": [{"name": "brick", "density": 1700.0}, {"name": "board", "density": 1400.0}],
        "contacts": [{"materials": ["brick", "board"], "en2": 0.1, "mu": 0.46, "kn": 1e5, "kt_over_kn": 0.42},
                     {"materials": ["brick", "brick"], "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}],
        "shapes": [{"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008, "rounding": 0.001}],
        "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": [0.0, 0.0, 0.004 + gap]}]},
        "walls": [{"name": "plate", "type": "rectangle", "material": "board", "origin": [-0.1, -0.1, 0.0], "edge1": [0.2, 0, 0], "edge2": [0, 0.2, 0]}],
        "domain": {"lower": [-0.12, -0.12, -0.01], "upper": [0.12, 0.12, 0.05]},
        "record_contacts": True,
    })
    run_case(case, tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / "results.h5")
    with h5py.File(tmp_path / "run" / "results.h5") as store:
        count, force = store["frames/contact_count"][:, 0], store["frames/normal_force_sum"][:, 0]
    touching = count > 0
    starts = np.flatnonzero(touching[1:] & ~touching[:-1]) + 1  # the first frame of each contact episode
    fall = math.sqrt(2 * gap / G)
    assert 0.0 <= trajectory.time[starts[0]] - fall <= 1.01e-4
    assert len(starts) >= 2
    assert count[-1] == 4
    assert force[-1] == pytest.approx(trajectory.mass[0] * G, rel=1e-2)
    rows = trajectory.contacts.frame(trajectory.n_frames - 1)
    assert set(trajectory.contacts.wall[rows]) == {0}


def test_an_engine_without_contact_output_refuses_record_contacts_by_name() -> None:
    data = pressed_case("cocd")
    data["walls"] = data["walls"][1:]
    with pytest.raises(CaseError, match=r"record_contacts: cocd does not record contacts; engines that can: liggghts, yade"):
        parse_case(data)


def _constructed() -> tuple[Contacts, np.ndarray]:
    """Three bodies over two frames: frame 0 has bodies 0–1 touching at two sphere pairs and body 2
    on wall 1; frame 1 has 1–2 touching once."""
    position = np.array([[[0.0, 0, 0], [0.02, 0, 0], [0.05, 0, 0]], [[0.0, 0, 0], [0.02, 0, 0], [0.04, 0, 0]]])
    frames = [
        np.array([[0, 1, -1, 0.01, 0, 0, -1.0, 0, 0, 0, 0.1, 0],
                  [1, 0, -1, 0.01, 0, 0.001, 2.0, 0, 0, 0, 0, 0],
                  [2, -1, 1, 0.05, 0, -0.005, 0, 0, 3.0, 0, 0, 0]]),
        np.array([[1, 2, -1, 0.03, 0, 0, 0, 0, -4.0, 0, 0, 0]]),
    ]
    return Contacts.from_frames(frames), position


def test_per_body_counts_and_force_sums_count_both_bodies_of_a_pair() -> None:
    recorded, _ = _constructed()
    count, force = recorded.per_body(3)
    assert count.tolist() == [[2, 2, 1], [0, 1, 1]]
    assert force.tolist() == [[3.0, 3.0, 3.0], [0.0, 4.0, 4.0]]


def test_coordination_counts_touching_body_pairs_once_and_leaves_walls_out() -> None:
    recorded, position = _constructed()
    assert recorded.coordination(position) == pytest.approx([2 / 3, 2 / 3])
    position[1, 2] = np.nan  # a body lost by the engine is not counted
    assert recorded.coordination(position)[1] == pytest.approx(1.0)


def test_branch_vectors_join_centres_or_reach_the_wall_contact_point() -> None:
    recorded, position = _constructed()
    branch = recorded.branch(position)
    assert np.allclose(branch, [[0.02, 0, 0], [-0.02, 0, 0], [0.0, 0, -0.005], [0.02, 0, 0]])


def test_force_chains_add_the_sphere_contacts_of_two_bodies() -> None:
    recorded, position = _constructed()
    segments, force = derived.force_chains(recorded, position, frame=0)
    assert force.tolist() == [3.0]
    assert segments.tolist() == [[[0.0, 0, 0], [0.02, 0, 0]]]


def test_contacts_validate_against_the_trajectory() -> None:
    recorded, _ = _constructed()
    recorded.validate(2, 3)
    with pytest.raises(ValueError, match="over 3 frames"):
        recorded.validate(3, 3)
    with pytest.raises(ValueError, match="not in the trajectory"):
        recorded.validate(2, 2)


def test_liggghts_rows_drop_duplicates_clumps_own_spheres_and_untouching_pairs_and_name_walls_by_case_index() -> None:
    atom_slot = np.array([-1, 0, 0, 1, 1])  # atoms 1, 2 → body 0; atoms 3, 4 → body 1
    #                  id1 id2 per  force      normal      point
    pairs = np.array([[1, 3, 0, 0, 0, -2, 0, 0, -2, 0, 0, 0.01],
                      [3, 1, 0, 0, 0, 2, 0, 0, 2, 0, 0, 0.01],  # the same pair, from another process
                      [1, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],  # one clump's own spheres
                      [2, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]])  # close, not touching: no force
    #                  wall point   atom centre  mesh tri atom  force        normal
    walls = np.array([[0, 0, 0, 0, 0, 0.005, 1, 7, 4, 0.5, 0, 3.0, 0, 0, 3.0]])
    rows = contact_rows(pairs, walls, atom_slot, wall_index=[0, 2])
    assert rows[:, :3].tolist() == [[0, 1, -1], [1, -1, 2]]
    assert rows[1, 6:12].tolist() == [0, 0, 3.0, 0.5, 0, 0]


def test_local_dump_reader_keeps_empty_frames_and_the_first_copy_of_a_step(tmp_path: Path) -> None:
    def block(step: int, rows: list[str]) -> str:
        return (f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{len(rows)}\nITEM: BOX BOUNDS ff ff ff\n0 1\n0 1\n0 1\n"
                f"ITEM: ENTRIES c_a[1] c_a[2]\n" + "".join(r + "\n" for r in rows))

    path = tmp_path / "local.dump"
    path.write_text(block(0, []) + block(10, ["1 2"]) + block(10, []) + block(20, ["3 4", "5 6"]) + "ITEM: TIMESTEP\n30\nITEM: NUMB")
    found = read_local_dump(path)
    assert sorted(found) == [0, 10, 20]
    assert found[0].shape == (0, 2) and found[10].tolist() == [[1, 2]] and found[20].shape == (2, 2)


def test_the_force_chain_picture_is_drawn_from_recorded_contacts(tmp_path: Path) -> None:
    """Constructed frames (two bodies touching at two sphere pairs, a third on a wall): the report's
    picture is written, and its pairs are the touching bodies."""
    from orchestrator.results import Trajectory
    from orchestrator.studies.avalanche.report import plot_force_chains

    recorded, position = _constructed()
    n = position.shape[1]
    zeros = np.zeros_like(position)
    trajectory = Trajectory(np.array([0.0, 1.0]), np.arange(n), np.array(["brick"] * n), np.full(n, 6.2e-3), np.full(n, 0.0162),
                            np.ones((n, 3)), position, zeros, zeros, np.tile([1.0, 0, 0, 0], (2, n, 1)), contacts=recorded)
    plot_force_chains(trajectory, tmp_path / "chains.png", frame=0)
    assert (tmp_path / "chains.png").stat().st_size > 10_000
