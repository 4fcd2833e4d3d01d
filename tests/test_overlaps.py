"""No brick passes through another: the rounded box's contact under random encounters, the exact
overlap measure, and the overlap audit of every run of shaped bodies.

The bound the contact must keep (stated from the law): a sub-contact stores at most the kinetic
energy E the pair brings (relative translation in the centre-of-mass frame and both spins; the law
only dissipates), so no overlap exceeds √(2E / k_n), whatever the pose: one sub-contact taking all
of it is the deepest case. Sampling the overlap every 50 µs of a contact lasting about 1.8 ms
under-reads a maximum by less than 0.1 %; the test allows 5 % for the step's own error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from orchestrator.case import CaseError, parse_case
from orchestrator.engines import RunOptions
from orchestrator.post import overlaps
from orchestrator.results import RELEASE_DIR, read_results
from orchestrator.rundir import read_record
from orchestrator.runner import run_case
from orchestrator.shapes.rigid import quaternion_matrices
from orchestrator.shapes.overlap import box_overlap, pair_overlap, probe_depth, swept_box_overlap
from orchestrator.shapes.rounded_box import brick_rounded_box
from orchestrator.studies import brick_drop

from conftest import requires_liggghts

BRICK = brick_drop.study_brick(kind="rounded_box")
SHAPE = brick_rounded_box(0.031, 0.015, 0.008, 1700.0, 0.001, BRICK["mass"], tuple(BRICK["inertia"]))
INNER, ROUNDING = SHAPE.sweep
KN = 2e4  # N/m: the quarter preset's, the softest the studies use (the deepest overlaps)
LAW = {"law": "bilinear", "en2": 0.13, "mu": 0.86, "kn": KN, "kt_over_kn": 0.27}
I3 = np.eye(3)[None]


def _pair(centre_b, rotation_b=I3) -> float:
    return float(swept_box_overlap(np.zeros((1, 3)), I3, INNER, ROUNDING, np.asarray([centre_b], float), rotation_b, INNER, ROUNDING)[0])


def test_the_exact_overlap_of_two_rounded_boxes_in_poses_worked_by_hand() -> None:
    # face on face: 8 mm apart they touch; 0.5 mm closer they overlap by 0.5 mm; at 5.5 mm the inner boxes meet and pass 0.5 mm
    assert _pair([0.0, 0.0, 0.008]) == pytest.approx(0.0, abs=1e-15)
    assert _pair([0.0, 0.0, 0.0075]) == pytest.approx(0.0005, abs=1e-15)
    assert _pair([0.0, 0.0, 0.0055]) == pytest.approx(0.0025, abs=1e-15)
    # corner to corner along the diagonal: the two inner corners 1 mm apart, r_A + r_B = 2 mm
    corner = INNER / np.linalg.norm(INNER)
    assert _pair(2.0 * INNER + 0.001 * corner) == pytest.approx(0.001, abs=1e-12)
    # crossed at 90° about z, edge on edge (each turned 45° about its long axis): the inner edges 1.5 mm apart
    turn = Rotation.from_euler("x", 45, degrees=True)
    ra, rb = turn.as_matrix()[None], (Rotation.from_euler("z", 90, degrees=True) * turn).as_matrix()[None]
    edge = (INNER[1] + INNER[2]) / np.sqrt(2.0)  # how far the turned brick's top long edge stands above its axis
    gap = 2 * edge + 0.0015
    assert float(swept_box_overlap(np.zeros((1, 3)), ra, INNER, ROUNDING, np.array([[0.0, 0.0, gap]]), rb, INNER, ROUNDING)[0]) \
        == pytest.approx(0.0005, abs=1e-12)


def test_the_exact_overlap_is_the_depth_no_probe_exceeds_and_no_outer_box_falls_short_of() -> None:
    """On 3 000 random poses: no point of one brick lies deeper in the other than the overlap (the
    least translation parting them), and the overlap never exceeds the outer boxes' (they hold the bricks)."""
    rng = np.random.default_rng(7)
    p = 3000
    ra, rb = Rotation.random(p, random_state=rng).as_matrix(), Rotation.random(p, random_state=rng).as_matrix()
    ca, cb = np.zeros((p, 3)), rng.uniform(-0.025, 0.025, (p, 3))
    exact = pair_overlap(SHAPE, SHAPE, ca, ra, cb, rb)
    probes = np.maximum(probe_depth(SHAPE, SHAPE, ca, ra, cb, rb), probe_depth(SHAPE, SHAPE, cb, rb, ca, ra))
    outer = box_overlap(ca, ra, np.broadcast_to(SHAPE.half_axes, (p, 3)), cb, rb, np.broadcast_to(SHAPE.half_axes, (p, 3)))
    touching = exact > 0
    assert touching.sum() > 500
    assert np.all(exact[touching] >= probes[touching] - 1e-12)
    assert np.all(exact <= outer + 1e-12)


def _encounters(count: int, speed_max: float, seed: int, spacing: float = 0.12) -> tuple[list[dict], np.ndarray]:
    """`count` pairs of bricks on a grid straddling x = 0 and y = 0 (the processors' split), each pair
    0.3 mm apart along a random direction, in random orientations, closing at 0.2 to `speed_max` m/s
    with a random sliding part and spins of about 30 rad/s; returns the bodies and each pair's
    kinetic energy in its centre-of-mass frame (J)."""
    rng = np.random.default_rng(seed)
    qa, qb = (np.roll(Rotation.random(count, random_state=rng).as_quat(), 1, axis=1) for _ in range(2))
    ra, rb = quaternion_matrices(qa), quaternion_matrices(qb)
    u = rng.normal(size=(count, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    low, high = np.zeros(count), np.full(count, 2.0 * SHAPE.bounding_radius + 1e-3)
    for _ in range(50):  # bisection: the distance along u at which the two just touch
        middle = 0.5 * (low + high)
        apart = swept_box_overlap(np.zeros((count, 3)), ra, INNER, ROUNDING, u * middle[:, None], rb, INNER, ROUNDING) <= 0
        low, high = np.where(apart, low, middle), np.where(apart, middle, high)
    side = int(np.ceil(np.sqrt(count)))
    grid = (np.stack([np.arange(count) % side, np.arange(count) // side, np.zeros(count)], axis=1) - [(side - 1) / 2, (side - 1) / 2, 0]) * spacing
    speed = rng.uniform(0.2, speed_max, count)
    slide = rng.normal(size=(count, 3))
    slide -= np.einsum("pk,pk->p", slide, u)[:, None] * u
    slide *= (rng.uniform(0.0, 0.5, count) * speed / np.maximum(np.linalg.norm(slide, axis=1), 1e-12))[:, None]
    va = (u * speed[:, None] + slide) / 2.0
    wa, wb = rng.normal(size=(count, 3)) * 30.0, rng.normal(size=(count, 3)) * 30.0
    inertia = np.asarray(BRICK["inertia"])
    spin = lambda r, w: 0.5 * np.einsum("pk,k,pk->p", np.einsum("pji,pj->pi", r, w), inertia, np.einsum("pji,pj->pi", r, w))  # noqa: E731
    energy = 0.25 * SHAPE.mass * np.sum((2 * va) ** 2, axis=1) + spin(ra, wa) + spin(rb, wb)
    bodies = []
    for k in range(count):
        for centre, q, v, w in ((grid[k], qa[k], va[k], wa[k]), (grid[k] + u[k] * (high[k] + 3e-4), qb[k], -va[k], wb[k])):
            bodies.append({"shape": "brick", "material": "brick", "position": centre.tolist(), "orientation": q.tolist(),
                           "velocity": v.tolist(), "angular_velocity": w.tolist()})
    return bodies, energy


def _fuzz_case(bodies: list[dict], extent: float, walls: list[dict] | None = None, kn: float = KN, duration: float = 0.01,
               output_interval: float = 5e-5):
    return parse_case({
        "name": "contact_fuzz", "engine": "liggghts", "gravity": [0.0, 0.0, 0.0],
        "time": {"duration": duration, "output_interval": output_interval},
        "materials": [{"name": "brick", "density": 1700.0}],
        "contacts": [{"materials": ["brick", "brick"], **{**LAW, "kn": kn}}],
        "shapes": [BRICK], "bodies": {"clumps": bodies}, "walls": walls or [],
        "domain": {"lower": [-extent, -extent, -0.1], "upper": [extent, extent, 0.1]}})


def _pair_overlaps(directory: Path, pairs: int) -> np.ndarray:
    """(frames, pairs) exact overlap of bodies 2k and 2k + 1 in every saved frame (m)."""
    trajectory = read_results(directory / "results.h5")
    out = np.empty((trajectory.n_frames, pairs))
    for f in range(trajectory.n_frames):
        r = quaternion_matrices(trajectory.orientation[f])
        p = trajectory.position[f]
        out[f] = swept_box_overlap(p[0::2], r[0::2], INNER, ROUNDING, p[1::2], r[1::2], INNER, ROUNDING)
    return out


def _fuzz(tmp_path: Path, count: int, speed_max: float, seed: int, processes: int) -> None:
    bodies, energy = _encounters(count, speed_max, seed)
    extent = int(np.ceil(np.sqrt(count))) * 0.06 + 0.1
    options = RunOptions(mpi_processes=processes, processor_grid="2 1 1" if processes == 2 else None)
    run_case(_fuzz_case(bodies, extent), tmp_path, tmp_path / RELEASE_DIR, options=options)
    depth = _pair_overlaps(tmp_path / RELEASE_DIR, count)
    bound = np.sqrt(2.0 * energy / KN)
    deepest = depth.max(axis=0)
    assert np.all(deepest <= 1.05 * bound), (deepest / bound).max()
    # the fastest encounters drive the inner boxes into each other (beyond r_A + r_B): they must come apart again
    assert (deepest > 2 * ROUNDING).any() or speed_max < 6.0
    assert depth[-1].max() < 2 * ROUNDING  # nobody is left inside another
    audit = read_record(tmp_path / RELEASE_DIR)["overlaps"]
    assert audit["pairs"]["overlap_m"] == pytest.approx(depth.max(), rel=1e-9)


@pytest.mark.engine
@requires_liggghts
@pytest.mark.parametrize("processes", [1, 2])
def test_random_brick_encounters_up_to_8_m_s_keep_the_laws_bound_and_part(processes: int, tmp_path: Path) -> None:
    """200 encounters, 0.2–8 m/s (beyond 6 m/s a corner goes past the two roundings), on 1 and 2
    processes (the grid straddles the split): every pair's deepest overlap within √(2E/k_n)."""
    _fuzz(tmp_path, 200, 8.0, seed=processes, processes=processes)


@pytest.mark.slow
@pytest.mark.engine
@requires_liggghts
@pytest.mark.parametrize("processes", [1, 2])
def test_thousands_of_random_brick_encounters_keep_the_laws_bound_and_part(processes: int, tmp_path: Path) -> None:
    _fuzz(tmp_path, 3000, 8.0, seed=10 + processes, processes=processes)


@pytest.mark.engine
@requires_liggghts
def test_bricks_thrown_at_a_wall_up_to_8_m_s_bounce_back_off_it(tmp_path: Path) -> None:
    """100 bricks, random orientations and spins, thrown at a plate at 0.5–8 m/s (the fastest drive a
    corner past the plate's plane): each comes back on its own side, none deeper than √(2E/k_n)."""
    rng = np.random.default_rng(3)
    count = 100
    q = np.roll(Rotation.random(count, random_state=rng).as_quat(), 1, axis=1)
    lowest = -SHAPE.lowest_points(quaternion_matrices(q))  # centre height at which each just touches z = 0
    side = 10
    xy = (np.stack([np.arange(count) % side, np.arange(count) // side], axis=1) - (side - 1) / 2) * 0.05
    speed = rng.uniform(0.5, 8.0, count)
    spin = rng.normal(size=(count, 3)) * 30.0
    bodies = [{"shape": "brick", "material": "brick", "position": [xy[k, 0], xy[k, 1], lowest[k] + 3e-4], "orientation": q[k].tolist(),
               "velocity": [0.0, 0.0, -speed[k]], "angular_velocity": spin[k].tolist()} for k in range(count)]
    plate = [{"type": "rectangle", "name": "plate", "material": "brick", "origin": [-0.4, -0.4, 0.0],
              "edge1": [0.8, 0.0, 0.0], "edge2": [0.0, 0.8, 0.0]}]
    run_case(_fuzz_case(bodies, 0.45, plate), tmp_path, tmp_path / RELEASE_DIR)
    trajectory = read_results(tmp_path / RELEASE_DIR / "results.h5")
    rotations = quaternion_matrices(trajectory.orientation.reshape(-1, 4)).reshape(trajectory.n_frames, count, 3, 3)
    depth = -(trajectory.position[..., 2] + np.stack([SHAPE.lowest_points(r) for r in rotations]))
    inertia = np.asarray(BRICK["inertia"])
    local = np.einsum("pji,pj->pi", quaternion_matrices(q), spin)
    energy = 0.5 * SHAPE.mass * speed**2 + 0.5 * np.einsum("pk,k,pk->p", local, inertia, local)
    assert (depth.max(axis=0) > ROUNDING).any()  # some corners went past the plane
    assert np.all(depth.max(axis=0) <= 1.05 * np.sqrt(2.0 * energy / KN))
    assert np.all(trajectory.position[-1, :, 2] > 0.0)  # every brick on its own side
    audit = read_record(tmp_path / RELEASE_DIR)["overlaps"]
    assert audit["walls"]["overlap_m"] == pytest.approx(depth.max(), rel=1e-6)


@pytest.mark.engine
@requires_liggghts
def test_a_run_that_ends_with_bricks_inside_each_other_warns_and_is_refused_as_a_packing(tmp_path: Path) -> None:
    """Two bricks on a very soft contact (k_n 1 N/m) meeting face on at 0.5 m/s: 16 sub-contacts hold
    them by ω = √(16 k_n / (m/2)) = 71 rad/s, so 15 ms in (mid-impact) they are about 5 mm inside
    each other: run.json's audit names them nested and warns, and a study refuses to release from
    that state, in one line."""
    bodies = [{"shape": "brick", "material": "brick", "position": [0.0, 0.0, z], "velocity": [0.0, 0.0, v]}
              for z, v in ((0.0, 0.25), (0.0083, -0.25))]
    run_case(_fuzz_case(bodies, 0.1, kn=1.0, duration=0.015, output_interval=1e-3), tmp_path, tmp_path / RELEASE_DIR)
    record = read_record(tmp_path / RELEASE_DIR)
    audit = record["overlaps"]
    assert audit["nested_pairs"] == 1 and audit["nested_at_end"] == 1
    assert audit["nested"][0]["bodies"] == [0, 1] and audit["nested"][0]["overlap_m"] > 0.003
    assert any("bodies 0 and 1 overlap by" in w for w in record["warnings"])
    message = overlaps.refusal(audit, "packing here")
    assert message is not None and "\n" not in message and "bodies 0 and 1" in message

    from orchestrator.studies import base
    from orchestrator.studies.avalanche.study import KIND

    packed = read_results(tmp_path / RELEASE_DIR / "results.h5")
    with pytest.raises(CaseError, match="nested in its last frame"):
        base._refuse_nested(KIND, None, tmp_path / RELEASE_DIR, packed)  # type: ignore[arg-type]


def test_the_audit_of_synthetic_frames_finds_the_pair_the_time_and_the_wall() -> None:
    """Three bricks, two frames: in the second, bricks 1 and 2 are 2.5 mm into each other (face on
    face, 5.5 mm apart) and brick 0 1.5 mm into the floor; the floor is gone after 0.05 s."""
    floor = np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]], [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]], dtype=float)
    position = np.array([[[0.0, 0.0, 0.0045], [0.1, 0.0, 0.1], [0.1, 0.0, 0.11]],
                         [[0.0, 0.0, 0.0025], [0.1, 0.0, 0.1], [0.1, 0.0, 0.1055]]])
    orientation = np.tile([1.0, 0.0, 0.0, 0.0], (2, 3, 1))
    record = overlaps.audit([SHAPE] * 3, 0, np.array([0.0, 0.1]), position, orientation, [("floor", floor, None)])
    assert record["pairs"] == {"overlap_m": pytest.approx(0.0025), "time_s": 0.1, "bodies": [1, 2]}
    assert record["walls"] == {"overlap_m": pytest.approx(0.0015), "time_s": 0.1, "body": 0, "wall": "floor"}
    assert record["per_frame"]["pair_m"][0] is None and record["per_frame"]["wall_m"][0] == pytest.approx(-0.0005)
    assert record["nested_pairs"] == 1 and record["nested_at_end"] == 1
    gone = overlaps.audit([SHAPE] * 3, 0, np.array([0.0, 0.1]), position, orientation, [("floor", floor, 0.05)])
    assert gone["walls"]["time_s"] == 0.0 and gone["per_frame"]["wall_m"][1] is None


@pytest.mark.engine
@requires_liggghts
def test_a_brick_across_a_walls_rim_is_not_thrown_out(tmp_path: Path) -> None:
    """A brick lying across the end of a wall (a finite rectangle), its centre 0.5 mm beside the
    wall's plane, two of its vertices over the wall and 2.5 mm past its plane: nothing can tell the
    wall's side there, so it is not pushed (a full-scale release threw such bricks out of the box at
    16 m/s); it stays at rest."""
    turn = Rotation.from_euler("x", 90, degrees=True)  # thickness along y, across the wall's plane (y = 0)
    bodies = [{"shape": "brick", "material": "brick", "position": [0.005, 0.0005, 0.0], "orientation": list(np.roll(turn.as_quat(), 1))}]
    wall = [{"type": "rectangle", "name": "side", "material": "brick", "origin": [-0.1, 0.0, -0.1],
             "edge1": [0.1, 0.0, 0.0], "edge2": [0.0, 0.0, 0.2]}]
    run_case(_fuzz_case(bodies, 0.2, wall, duration=0.02, output_interval=1e-3), tmp_path, tmp_path / RELEASE_DIR)
    trajectory = read_results(tmp_path / RELEASE_DIR / "results.h5")
    assert np.linalg.norm(trajectory.velocity[:, 0], axis=1).max() < 1e-6
