"""Wall geometry shared by both engines: every wall becomes a list of triangles.

LIGGGHTS reads them as an ASCII STL mesh, YADE as facets, so both engines see identical surfaces.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Sequence

import meshio
import numpy as np

from orchestrator import physics
from orchestrator.case import Case, CaseError, Domain, MeshWall, RectangleWall, Wall
from orchestrator.validation import read_capped


def rectangle_triangles(wall: RectangleWall) -> np.ndarray:
    """Two triangles (2, 3, 3) covering the rectangle origin + s·edge1 + t·edge2, s, t ∈ [0, 1]."""
    o = np.asarray(wall.origin, dtype=float)
    a = np.asarray(wall.edge1, dtype=float)
    b = np.asarray(wall.edge2, dtype=float)
    return np.array([[o, o + a, o + a + b], [o, o + a + b, o + b]])


# A mesh is read whole into memory and checked triangle by triangle (vectorised): a binary STL of a
# million triangles is 50 MB and takes about a second. Larger files or counts are refused.
MAX_MESH_BYTES = 128 * 2**20
MAX_TRIANGLES = 2_000_000
# Every vertex of a scaled mesh lies within the case's coordinate range (case.Coordinate).
MAX_COORDINATE = 1e4
# LIGGGHTS stops on a triangle with an angle closer to 180° than its mesh curvature (1 - 1e-5 as a
# cosine: 0.256°), measured 2026-12-01 on a sliver of 179.9°: "Fix mesh: Bad mesh, cannot continue".
MAX_ANGLE_DEG = 180.0 - float(np.degrees(np.arccos(1.0 - 1e-5)))
_VERTEX = re.compile(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)")


def mesh_triangles(wall: MeshWall, case_dir: Path) -> np.ndarray:
    """Triangles (t, 3, 3) of an STL file (ASCII or binary), scaled by `wall.scale`; CaseError naming
    the wall when the file is not a regular file of at most MAX_MESH_BYTES, holds no or more than
    MAX_TRIANGLES triangles, a vertex that is not finite or beyond MAX_COORDINATE once scaled, or a
    triangle of zero area or with an angle above MAX_ANGLE_DEG (an engine would stop on it)."""
    path = case_dir / wall.file
    field = f"walls.{wall.name}.file"
    try:
        data = read_capped(path, "STL mesh", MAX_MESH_BYTES)
    except CaseError as error:
        raise CaseError(f"{field}: {error}") from None
    triangles = _parse_stl(data)
    if triangles is None or not len(triangles):
        raise CaseError(f"{field}: {path} holds no triangles (not an ASCII or binary STL mesh)")
    if len(triangles) > MAX_TRIANGLES:
        raise CaseError(f"{field}: {path} holds {len(triangles)} triangles; allowed: at most {MAX_TRIANGLES}")
    finite = np.isfinite(triangles).all(axis=(1, 2))
    if not finite.all():
        raise CaseError(f"{field}: triangle {int(np.argmin(finite))} of {path} has a vertex that is not a finite number; "
                        "allowed: finite coordinates")
    triangles = triangles * wall.scale
    reach = float(np.abs(triangles).max())
    if reach > MAX_COORDINATE:
        raise CaseError(f"walls.{wall.name}.scale: {wall.scale!r} puts a vertex {reach:.3g} m from the origin; allowed: every "
                        f"vertex within {MAX_COORDINATE:g} m (a scale of at most {wall.scale * MAX_COORDINATE / reach:.3g})")
    flat = np.flatnonzero(triangle_areas(triangles) <= 1e-12 * _longest_edges(triangles) ** 2)
    if len(flat):
        raise CaseError(f"{field}: triangle {int(flat[0])} of {path} has zero area ({len(flat)} such triangle{'s' if len(flat) > 1 else ''}); "
                        "remove degenerate triangles from the mesh")
    widest = _largest_angles(triangles)
    if widest.max() > MAX_ANGLE_DEG:
        worst = int(np.argmax(widest))
        raise CaseError(f"{field}: triangle {worst} of {path} is a sliver (an angle of {widest[worst]:.4f}°); allowed: every angle "
                        f"below {MAX_ANGLE_DEG:.2f}° (the mesh wall stops the engine otherwise)")
    return triangles


def _parse_stl(data: bytes) -> np.ndarray | None:
    """(t, 3, 3) float vertices of a binary STL (its size matches its triangle count, as meshio tells
    the two apart) or an ASCII one (its `vertex x y z` lines); None when neither."""
    if len(data) >= 84:
        count = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if 84 + 50 * count == len(data):
            record = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])
            return np.frombuffer(data, dtype=record, offset=84)["vertices"].astype(float)
    found = _VERTEX.findall(data)
    if not found or len(found) % 3:
        return None
    try:
        return np.array(found).astype(float).reshape(-1, 3, 3)
    except ValueError:
        return None


def triangle_areas(triangles: np.ndarray) -> np.ndarray:
    """(t,) areas of (t, 3, 3) triangles."""
    return 0.5 * np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]), axis=1)


def _largest_angles(triangles: np.ndarray) -> np.ndarray:
    """(t,) largest interior angle of each triangle, degrees (no zero-length edges)."""
    after, before = np.roll(triangles, -1, axis=1) - triangles, np.roll(triangles, 1, axis=1) - triangles
    cosines = np.einsum("tvk,tvk->tv", after, before) / (np.linalg.norm(after, axis=2) * np.linalg.norm(before, axis=2))
    return np.degrees(np.arccos(np.clip(cosines.min(axis=1), -1.0, 1.0)))


def _longest_edges(triangles: np.ndarray) -> np.ndarray:
    return np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)


def wall_triangles(wall: Wall, case_dir: Path) -> np.ndarray:
    if isinstance(wall, RectangleWall):
        return rectangle_triangles(wall)
    return mesh_triangles(wall, case_dir)


def write_ascii_stl(path: Path, triangles: np.ndarray) -> None:
    """ASCII STL, the only STL flavour LIGGGHTS' `fix mesh/surface` reads."""
    points = triangles.reshape(-1, 3)
    cells = [("triangle", np.arange(len(points)).reshape(-1, 3))]
    meshio.write_points_cells(path, points, cells, file_format="stl", binary=False)


def automatic_domain(case: Case, triangles: list[np.ndarray], end_time: float, table: Sequence[physics.BodyInfo] | None = None) -> Domain:
    """A box holding every body and wall, padded so that bodies do not leave it in normal use.

    Padding: 10 % of the extent, 5 radii and the distance the fastest initial body covers in the
    run on every side, and, for a case without walls, along gravity the free-fall distance over the
    run so that its bodies stay inside.
    A case can always give `domain:` explicitly.
    """
    table = physics.bodies(case) if table is None else table
    centres = np.array([b.position for b in table])
    radii = np.array([b.radius for b in table])
    points = [centres - radii[:, None], centres + radii[:, None]] + [t.reshape(-1, 3) for t in triangles]
    cloud = np.concatenate(points)
    lower, upper = cloud.min(axis=0), cloud.max(axis=0)
    extent = float(np.max(upper - lower))
    speed = float(np.max(np.linalg.norm([b.velocity for b in table], axis=1)))
    pad = 0.1 * extent + 5.0 * float(radii.max()) + speed * end_time
    lower, upper = lower - pad, upper + pad
    gravity = np.asarray(case.gravity)
    # Walls catch the bodies: then the box ends at the walls plus padding. A deep box is not free:
    # LIGGGHTS bins all of it (a 6 m deep box of 4 mm spheres took 1 GB and minutes per command).
    fall = 0.0 if case.walls else 0.5 * float(np.linalg.norm(gravity)) * end_time**2
    if np.linalg.norm(gravity) > 0:
        direction = gravity / np.linalg.norm(gravity)
        lower = lower + np.minimum(direction, 0.0) * fall
        upper = upper + np.maximum(direction, 0.0) * fall
    return Domain(lower=tuple(float(v) for v in lower), upper=tuple(float(v) for v in upper))
