"""ParaView series (orchestrator.post.paraview, `demorch paraview`): every body's surface per frame, read
back with meshio against the trajectory, and the recorded contacts as lines."""

from __future__ import annotations

import json
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest
from click.testing import CliRunner

from orchestrator.case import Case, parse_case
from orchestrator.cli.main import main
from orchestrator.post.paraview import KINDS, RESOLUTION, write_series
from orchestrator.results import RESULTS, Trajectory, read_results, write_results
from orchestrator.runner import run_case
from orchestrator.shapes.clump import unit_sphere_mesh
from tests.conftest import assert_one_line_error, pile_case, requires_yade, run_cli


def collection(path: Path) -> list[tuple[float, str, Path]]:
    """(time s, part name, file) of each dataset of a .pvd; the part number is the name's index in KINDS."""
    root = ET.parse(path).getroot()
    assert root.get("type") == "Collection"
    datasets = [(float(d.get("timestep")), d.get("name"), path.parent / d.get("file")) for d in root.iter("DataSet")]
    for d in root.iter("DataSet"):
        assert d.get("part") == str(KINDS.index(d.get("name")) if d.get("name") in KINDS else 0)
    return datasets


def body_cells(mesh: meshio.Mesh, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """(triangles (m, 3), body (m,)) of one kind's piece of a frame read back: one triangle block."""
    assert [block.type for block in mesh.cells] == ["triangle"]
    assert set(mesh.cell_data["kind"][0]) == {KINDS.index(kind)}
    return mesh.cells[0].data, mesh.cell_data["body"][0]


def triangles_per_body(case: Case) -> np.ndarray:
    """(bodies,) triangles of each body's mesh at the default resolution."""
    sphere = len(unit_sphere_mesh(RESOLUTION["sphere"])[1])
    shapes = [case.shape(c.shape).body(case.material(c.material).density) for c in case.bodies.clumps]
    return np.array([sphere] * len(case.bodies.spheres) + [len(s.surface_mesh(RESOLUTION[s.kind])[1]) for s in shapes])


@pytest.fixture(scope="module")
def mixed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Four of the pile's bricks (a symmetric 4 × 2 × 1 clump) and a sphere dropped on the floor, contacts
    recorded: 0.1 s, six frames, about 2 s on YADE (the engine that mixes spheres and clumps)."""
    data = json.loads(pile_case("yade", count=4, duration=0.1).model_dump_json())
    data["time"]["output_interval"] = 0.02
    data["record_contacts"] = True
    data["bodies"]["spheres"] = [{"material": "brick", "radius": 0.006, "position": [0.1, 0.1, 0.006]}]
    directory = tmp_path_factory.mktemp("mixed")
    run_case(parse_case(data), directory, directory / "run")
    return directory / "run"


@requires_yade
@pytest.mark.engine
def test_every_frame_holds_every_body_surface_where_the_trajectory_puts_it(mixed_run: Path, tmp_path: Path) -> None:
    """Each frame is one .pvd dataset per kind, each read by meshio as one triangle block holding
    bodies × triangles per mesh of them; the vertex mean of a body's triangles is its centre (symmetric brick and sphere:
    1e-6 m); the velocity at each vertex is its body's."""
    code, output, _, _ = run_cli(["paraview", str(mixed_run.parent), "--out", str(tmp_path)])
    assert code == 0, output
    assert f"bodies: {tmp_path / 'bodies.pvd'}" in output and "(6 frames of 1 sphere, 4 clumps)" in output
    trajectory = read_results(mixed_run / RESULTS)
    case = parse_case(json.loads((mixed_run / "case.json").read_text()))
    datasets = collection(tmp_path / "bodies.pvd")
    assert len(datasets) == 2 * trajectory.n_frames == len(list(tmp_path.glob("bodies_*.vtu")))
    assert [name for _, name, _ in datasets] == ["sphere", "clump"] * trajectory.n_frames  # one part per kind and frame
    expected_triangles = triangles_per_body(case)
    for index, (time, kind, path) in enumerate(datasets):
        frame = index // 2
        assert time == pytest.approx(trajectory.time[frame], abs=1e-12)
        assert path.name == f"bodies_{kind}_{frame:05d}.vtu"
        mesh = meshio.read(path)
        triangles, body = body_cells(mesh, kind)
        mine = np.flatnonzero([k < len(case.bodies.spheres) if kind == "sphere" else k >= len(case.bodies.spheres)
                               for k in range(trajectory.n_bodies)])
        assert len(triangles) == expected_triangles[mine].sum()
        assert np.bincount(body, minlength=trajectory.n_bodies)[mine].tolist() == expected_triangles[mine].tolist()
        velocity = mesh.point_data["velocity"]
        for k in mine:
            vertices = np.unique(triangles[body == k])
            assert mesh.points[vertices].astype(float).mean(axis=0) == pytest.approx(trajectory.position[frame, k], abs=1e-6)
            assert velocity[vertices] == pytest.approx(np.broadcast_to(trajectory.velocity[frame, k], (len(vertices), 3)), rel=1e-6, abs=1e-9)


@requires_yade
@pytest.mark.engine
def test_recorded_contacts_are_lines_with_their_normal_force(mixed_run: Path, tmp_path: Path) -> None:
    """Body pairs centre to centre, wall contacts centre to contact point, |normal force| per line;
    a frame without contacts is an empty piece (frame 0 here: everything starts in the air)."""
    trajectory = read_results(mixed_run / RESULTS)
    series = write_series(parse_case(json.loads((mixed_run / "case.json").read_text())), trajectory, tmp_path, stride=2)
    assert series.frames == [0, 2, 4, 5]
    contacts = trajectory.contacts
    assert contacts is not None and series.contacts is not None
    datasets = collection(series.contacts)
    assert [path.name for _, _, path in datasets] == [f"contacts_{f:05d}.vtu" for f in series.frames]
    seen = 0
    for frame, (_, _, path) in zip(series.frames, datasets):
        rows = contacts.frame(frame)
        pairs, pair_force = contacts.touching_pairs(frame)
        walls = contacts.body[rows, 1] < 0
        if rows.stop == rows.start:
            assert ET.parse(path).getroot().find("UnstructuredGrid/Piece").get("NumberOfCells") == "0"
            continue
        mesh = meshio.read(path)
        ends = mesh.points[mesh.cells[0].data].astype(float)  # (lines, 2, 3)
        force = mesh.cell_data["normal_force"][0]
        assert len(force) == len(pairs) + walls.sum()
        assert force == pytest.approx(np.concatenate([pair_force, np.linalg.norm(contacts.normal_force[rows][walls], axis=1)]))
        assert ends[len(pairs):, 0] == pytest.approx(trajectory.position[frame, contacts.body[rows][walls, 0]], abs=1e-6)
        assert ends[len(pairs):, 1] == pytest.approx(contacts.point[rows][walls], abs=1e-6)
        assert mesh.cell_data["wall"][0].tolist() == [-1] * len(pairs) + contacts.wall[rows][walls].tolist()
        seen += len(force)
    assert seen > 0


def superquadric_brick(frames: int = 1, turn_deg: float = 90.0) -> tuple[Case, Trajectory]:
    """The study's brick as a superquadric, turned `turn_deg` about z, at (1, 2, 3) m, moving at (0.5, 0, -1) m/s."""
    case = parse_case({
        "name": "one_brick", "engine": "liggghts",
        "time": {"duration": 0.1, "output_interval": 0.01},
        "materials": [{"name": "brick", "density": 1700.0}],
        "contacts": [{"materials": ["brick", "brick"], "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}],
        "shapes": [{"name": "brick", "kind": "superquadric", "length": 0.031, "width": 0.015, "thickness": 0.008}],
        "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": [1.0, 2.0, 3.0]}]},
    })
    half = math.radians(turn_deg) / 2.0
    quaternion = np.array([math.cos(half), 0.0, 0.0, math.sin(half)])
    trajectory = Trajectory(time=np.arange(frames) * 0.01, ids=np.arange(1), material=np.array(["brick"]), mass=np.full(1, 6.2e-3),
                            radius=np.full(1, 0.0173), inertia=np.full((1, 3), 1e-7),
                            position=np.tile([[[1.0, 2.0, 3.0]]], (frames, 1, 1)), velocity=np.tile([[[0.5, 0.0, -1.0]]], (frames, 1, 1)),
                            angular_velocity=np.zeros((frames, 1, 3)), orientation=np.tile(quaternion, (frames, 1, 1)))
    return case, trajectory


def test_a_superquadric_brick_turned_a_quarter_about_z_lies_along_y(tmp_path: Path) -> None:
    case, trajectory = superquadric_brick()
    series = write_series(case, trajectory, tmp_path)
    assert series.contacts is None and not list(tmp_path.glob("contacts*"))  # no contacts recorded, no contact series
    assert series.kinds == {"superquadric": 1}
    mesh = meshio.read(collection(series.bodies)[0][2])
    triangles, body = body_cells(mesh, "superquadric")
    assert set(body) == {0}
    assert len(triangles) == len(case.shape("brick").body(1700.0).surface_mesh(RESOLUTION["superquadric"])[1])
    extent = np.ptp(mesh.points.astype(float), axis=0)
    assert extent == pytest.approx([0.015, 0.031, 0.008], rel=1e-3)  # the long side along y, the width along x
    assert mesh.points.astype(float).mean(axis=0) == pytest.approx([1.0, 2.0, 3.0], abs=1e-6)
    assert mesh.point_data["velocity"] == pytest.approx(np.broadcast_to([0.5, 0.0, -1.0], (len(mesh.points), 3)))


def test_stride_keeps_every_kth_frame_and_the_last(tmp_path: Path) -> None:
    case, trajectory = superquadric_brick(frames=6)
    series = write_series(case, trajectory, tmp_path, stride=4)
    assert series.frames == [0, 4, 5]
    assert [(t, p.name) for t, _, p in collection(series.bodies)] == [(0.0, "bodies_superquadric_00000.vtu"), (0.04, "bodies_superquadric_00004.vtu"),
                                                                      (0.05, "bodies_superquadric_00005.vtu")]


def test_a_lost_body_is_left_out_of_its_frames(tmp_path: Path) -> None:
    case, trajectory = superquadric_brick(frames=2)
    trajectory.position[1] = np.nan
    series = write_series(case, trajectory, tmp_path)
    assert len(meshio.read(tmp_path / "bodies_superquadric_00000.vtu").points) > 0
    piece = ET.parse(tmp_path / "bodies_superquadric_00001.vtu").getroot().find("UnstructuredGrid/Piece")
    assert (piece.get("NumberOfPoints"), piece.get("NumberOfCells")) == ("0", "0") and len(series.frames) == 2


def saved_run(directory: Path, case: Case, trajectory: Trajectory) -> Path:
    directory.mkdir()
    (directory / "case.json").write_text(case.model_dump_json())
    write_results(directory / RESULTS, trajectory)
    return directory


def test_the_command_prints_the_collection_and_errors_are_one_line(tmp_path: Path) -> None:
    case, trajectory = superquadric_brick(frames=3)
    run = saved_run(tmp_path / "run", case, trajectory)
    result = CliRunner().invoke(main, ["paraview", str(run), "--stride", "2"])
    assert result.exit_code == 0, result.output
    assert result.output.strip() == f"bodies: {run / 'paraview' / 'bodies.pvd'} (2 frames of 1 superquadric)"

    other, _ = superquadric_brick(frames=3)
    data = json.loads(other.model_dump_json())
    data["bodies"]["clumps"] *= 2
    mismatched = saved_run(tmp_path / "mismatched", parse_case(data), trajectory)
    assert_one_line_error(*run_cli(["paraview", str(mismatched)]), expected_code=5, field="bodies: results.h5 holds 1, its case 2")
    empty = tmp_path / "empty"
    empty.mkdir()
    assert_one_line_error(*run_cli(["paraview", str(empty)]), expected_code=2, field="has no results.h5")
    assert_one_line_error(*run_cli(["paraview", str(run), "--stride", "0"]), expected_code=2, field="--stride")
    (run / "case.json").write_text("{")
    assert_one_line_error(*run_cli(["paraview", str(run)]), expected_code=5, field="case.json cannot be read")


def test_links_in_the_output_directory_are_replaced_never_followed(tmp_path: Path) -> None:
    """A symbolic or hard link under an output file's name (or a link as the default paraview/) is
    removed and a new file written in its place: nothing outside the output directory changes."""
    case, trajectory = superquadric_brick(frames=2)
    run = saved_run(tmp_path / "run", case, trajectory)
    outside = tmp_path / "outside.txt"
    outside.write_text("precious")
    out = tmp_path / "out"
    out.mkdir()
    (out / "bodies.pvd").symlink_to(outside)
    (out / "bodies_superquadric_00001.vtu").symlink_to(outside)
    os.link(outside, out / "bodies_superquadric_00000.vtu")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (run / "paraview").symlink_to(elsewhere, target_is_directory=True)
    for arguments in (["--out", str(out)], []):
        result = CliRunner().invoke(main, ["paraview", str(run), *arguments])
        assert result.exit_code == 0, result.output
    assert outside.read_text() == "precious" and not list(elsewhere.iterdir())
    for directory in (out, run / "paraview"):
        assert not directory.is_symlink() and not any(p.is_symlink() for p in directory.iterdir())
        assert [p.name for _, _, p in collection(directory / "bodies.pvd")] == ["bodies_superquadric_00000.vtu", "bodies_superquadric_00001.vtu"]
    assert len(meshio.read(out / "bodies_superquadric_00000.vtu").points) > 0

