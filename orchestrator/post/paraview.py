"""ParaView time series of a run: every body's surface frame by frame, and its recorded contacts.

`write_series(case, trajectory, outdir, stride)` writes into `outdir`
    bodies.pvd          ParaView's collection: per written frame, one <DataSet timestep="t (s)" part="p"
                        name="kind" file="…"/> per body kind present in the run (sphere, then the
                        shape kinds: part = its index in KINDS), which ParaView shows as one block per
                        kind (colour or hide the kinds apart in its Multiblock Inspector)
    bodies_KIND_FFFFF.vtu   frame F, the bodies of one kind: their surfaces as one `triangle` cell
                        block (what meshio.read gives back); point data `velocity` (m/s, the body's
                        centre velocity at each of its vertices), cell data `body` (the body's index
                        in results.h5) and `kind` (its index in KINDS). A body lost by the engine (NaN
                        position) is left out of the frames where it is lost (a kind with no body left
                        is an empty piece). One file per kind because a .vtu keeps cells, not blocks:
                        its readers (meshio's, ParaView's) join the cells of one type into one block.
    contacts.pvd, contacts_FFFFF.vtu   only when the run recorded contacts (`record_contacts`):
                        `line` cells, one per touching body pair (centre to centre; the |normal force|
                        of its sphere contacts summed, as in post/contacts.force_chains) and one per
                        wall contact (the body's centre to the contact point); cell data
                        `normal_force` (N) and `wall` (the wall's index in the case's `walls`, -1 for
                        a body pair). A frame without contacts is an empty piece.

Surfaces are sampled coarsely (RESOLUTION): a sphere, and each sphere of a clump, at 8 latitudes
(114 vertices, 224 triangles), a superquadric at 12 (530 vertices, 1056 triangles). Points and
velocities are float32 (about 1e-7 relative: 0.1 µm at 1 m), connectivity int32; meshio
compresses every array (zlib). Size and time a frame, measured 2026-12-02 on 2 shared cores
(docs/results.md, benchmarks/paraview_export.py): the study's brick (16 spheres: 1824 vertices,
3584 triangles) takes 46 kB a frame, so the demo's 96 bricks 4.4 MB in 0.41 s and 6400 bricks
294 MB in 47 s (2.6 GB of memory); at 4 latitudes 11 kB a brick (68 MB, 7.2 s for 6400); a
superquadric brick 14 kB (89 MB, 7.8 s for 6400).
"""

from __future__ import annotations

import contextlib
import io
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import meshio
import numpy as np

from orchestrator.case import Case
from orchestrator.post.contacts import force_chains
from orchestrator.results import Contacts, Trajectory, safe_output_path
from orchestrator.shapes import KINDS as SHAPE_KINDS
from orchestrator.shapes.clump import unit_sphere_mesh
from orchestrator.shapes.rigid import quaternion_matrices

KINDS = ("sphere", *SHAPE_KINDS)  # the parts of a frame, in this order
RESOLUTION = {"sphere": 8, **{name: kind.mesh_resolution for name, kind in SHAPE_KINDS.items()}}  # latitudes of a surface mesh, per kind
BODIES, CONTACTS = "bodies", "contacts"  # the two series' names: NAME.pvd, NAME_FFFFF.vtu


@dataclass(frozen=True)
class BodyGroup:
    """Bodies of one kind whose surfaces are one mesh, scaled: every sphere, or the bodies of one shape."""

    kind: str
    bodies: np.ndarray  # (B,) int, indices in results.h5
    vertices: np.ndarray  # (n, 3) m, body frame (about the centre of mass), before scaling
    triangles: np.ndarray  # (m, 3) int, into vertices
    scale: np.ndarray  # (B,) each body's factor on `vertices` (a sphere's radius, m; 1 for a shape)


def body_groups(case: Case, resolution: dict[str, int] | None = None) -> list[BodyGroup]:
    """The case's bodies grouped by mesh, in KINDS order: body i of results.h5 is the i-th sphere,
    then the (i − spheres)-th clump (case.Bodies). `resolution`: latitudes per kind (RESOLUTION)."""
    latitudes = {**RESOLUTION, **(resolution or {})}
    groups = []
    spheres = case.bodies.spheres
    if spheres:
        unit, triangles = unit_sphere_mesh(latitudes["sphere"])
        groups.append(BodyGroup("sphere", np.arange(len(spheres)), unit, triangles, np.array([s.radius for s in spheres])))
    members: dict[str, list[int]] = {}
    for i, clump in enumerate(case.bodies.clumps):
        members.setdefault(clump.shape, []).append(len(spheres) + i)
    for name, bodies in members.items():
        material = case.bodies.clumps[bodies[0] - len(spheres)].material  # the mesh does not depend on it
        body = case.shape(name).body(case.material(material).density)
        vertices, triangles = body.surface_mesh(latitudes[body.kind])
        groups.append(BodyGroup(body.kind, np.array(bodies), vertices, triangles, np.ones(len(bodies))))
    return sorted(groups, key=lambda group: KINDS.index(group.kind))


def _rotations(orientation: np.ndarray) -> np.ndarray:
    """(B, 3, 3) rotation matrices of (B, 4) quaternions (w, x, y, z); the identity where the engine
    tracks none (NaN: LIGGGHTS spheres)."""
    tracked = np.isfinite(orientation).all(axis=1) & (np.abs(orientation).sum(axis=1) > 0.0)
    return quaternion_matrices(np.where(tracked[:, None], orientation, [1.0, 0.0, 0.0, 0.0]))


def surfaces(groups: list[BodyGroup], position: np.ndarray, orientation: np.ndarray, velocity: np.ndarray) -> dict[str, meshio.Mesh]:
    """One frame's surfaces, one mesh per kind of `groups` (KINDS order): position (bodies, 3) m,
    orientation (bodies, 4) (w, x, y, z), velocity (bodies, 3) m/s. Each mesh: points (Σ B n, 3), one
    `triangle` cell block; empty when every body of its kind is lost."""
    parts: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]] = {group.kind: [] for group in groups}
    for group in groups:
        present = np.isfinite(position[group.bodies]).all(axis=1)
        bodies, scale = group.bodies[present], group.scale[present]
        if not len(bodies):
            continue
        n, m = len(group.vertices), len(group.triangles)
        turned = np.einsum("bij,nj->bni", _rotations(orientation[bodies]), group.vertices) * scale[:, None, None]
        offset = sum(len(points) for points, *_ in parts[group.kind])
        starts = (offset + n * np.arange(len(bodies))).astype(np.int32)
        parts[group.kind].append(((position[bodies][:, None, :] + turned).reshape(-1, 3).astype(np.float32),
                                  np.repeat(velocity[bodies].astype(np.float32), n, axis=0),
                                  (group.triangles.astype(np.int32)[None, :, :] + starts[:, None, None]).reshape(-1, 3),
                                  np.repeat(bodies.astype(np.int32), m)))
    return {kind: _kind_mesh(kind, pieces) for kind, pieces in parts.items()}


def _kind_mesh(kind: str, pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]) -> meshio.Mesh:
    """The mesh of one kind from its groups' (points, velocity, triangles, body) arrays."""
    if not pieces:
        return meshio.Mesh(np.empty((0, 3), dtype=np.float32), [])
    points, speeds, triangles, labels = (np.concatenate(column) for column in zip(*pieces))
    return meshio.Mesh(points, [meshio.CellBlock("triangle", triangles)], point_data={"velocity": speeds},
                       cell_data={"body": [labels], "kind": [np.full(len(triangles), KINDS.index(kind), dtype=np.int32)]})


def contact_lines(contacts: Contacts, position: np.ndarray, frame: int) -> meshio.Mesh:
    """One frame's contacts as `line` cells: body pairs centre to centre (|normal force| summed over
    their sphere contacts), then wall contacts from the body's centre to the contact point.
    position: the trajectory's (frames, bodies, 3) m."""
    pairs, pair_force = force_chains(contacts, position, frame)
    rows = contacts.frame(frame)
    wall = contacts.body[rows, 1] < 0
    walls = np.stack([position[frame, contacts.body[rows][wall, 0]], contacts.point[rows][wall]], axis=1)
    segments = np.concatenate([pairs, walls])  # (lines, 2, 3)
    force = np.concatenate([pair_force, np.linalg.norm(contacts.normal_force[rows][wall], axis=1)])
    index = np.concatenate([np.full(len(pairs), -1), contacts.wall[rows][wall]])
    return meshio.Mesh(segments.reshape(-1, 3).astype(np.float32),
                       [meshio.CellBlock("line", np.arange(2 * len(segments), dtype=np.int32).reshape(-1, 2))],
                       cell_data={"normal_force": [force], "wall": [index.astype(np.int32)]})


def write_collection(path: Path, entries: list[tuple[float, int, str, str]]) -> Path:
    """ParaView's collection file: (time s, part number, part name, file name relative to `path`'s
    folder) per dataset."""
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    collection = ET.SubElement(root, "Collection")
    for time, part, name, file in entries:
        ET.SubElement(collection, "DataSet", timestep=repr(float(time)), group="", part=str(part), name=name, file=file)
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path


def _write_piece(path: Path, mesh: meshio.Mesh) -> None:
    """A .vtu, compressed; an empty one as ASCII (meshio's compressed zero-length arrays are refused
    by readers), without meshio's warning that ASCII is for debugging."""
    if len(mesh.points):
        meshio.write(path, mesh, file_format="vtu")
        return
    with contextlib.redirect_stderr(io.StringIO()):
        meshio.write(path, mesh, file_format="vtu", binary=False)


@dataclass(frozen=True)
class Series:
    """What write_series wrote: the collections (None without recorded contacts), the frames, and
    how many bodies of each kind."""

    bodies: Path
    contacts: Path | None
    frames: list[int]
    kinds: dict[str, int]


def write_series(case: Case, trajectory: Trajectory, outdir: Path, stride: int = 1, resolution: dict[str, int] | None = None,
                 progress: Callable[[int, int], None] | None = None) -> Series:
    """Write the surfaces (and the contacts, when recorded) of every `stride`-th frame, the last one
    included, into `outdir` (module docstring); `progress(done, total)` after each frame. A link
    there under a file's name is replaced, never followed (results.safe_output_path).

    Raises ValueError when the trajectory and the case disagree on the number of bodies."""
    bodies = len(case.bodies.spheres) + len(case.bodies.clumps)
    if trajectory.n_bodies != bodies:
        raise ValueError(f"bodies: results.h5 holds {trajectory.n_bodies}, its case {bodies}")
    if stride < 1:
        raise ValueError(f"stride must be at least 1 (got {stride})")
    groups = body_groups(case, resolution)
    frames = sorted({*range(0, trajectory.n_frames, stride), trajectory.n_frames - 1} - {-1})
    outdir.mkdir(parents=True, exist_ok=True)
    recorded = trajectory.contacts
    written: dict[str, list[tuple[float, int, str, str]]] = {BODIES: [], CONTACTS: []}
    for done, frame in enumerate(frames, start=1):
        time = float(trajectory.time[frame])
        pieces = [(BODIES, KINDS.index(kind), kind, f"{BODIES}_{kind}_{frame:05d}.vtu", mesh)
                  for kind, mesh in surfaces(groups, trajectory.position[frame], trajectory.orientation[frame], trajectory.velocity[frame]).items()]
        if recorded is not None:
            pieces.append((CONTACTS, 0, CONTACTS, f"{CONTACTS}_{frame:05d}.vtu", contact_lines(recorded, trajectory.position, frame)))
        for series, part, name, file, mesh in pieces:
            _write_piece(safe_output_path(outdir, file), mesh)
            written[series].append((time, part, name, file))
        if progress is not None:
            progress(done, len(frames))
    kinds: dict[str, int] = {}
    for group in groups:
        kinds[group.kind] = kinds.get(group.kind, 0) + len(group.bodies)
    return Series(write_collection(safe_output_path(outdir, f"{BODIES}.pvd"), written[BODIES]),
                  write_collection(safe_output_path(outdir, f"{CONTACTS}.pvd"), written[CONTACTS]) if recorded is not None else None,
                  frames, kinds)
