"""Wall geometry shared by both engines: every wall becomes a list of triangles.

LIGGGHTS reads them as an ASCII STL mesh, YADE as facets, so both engines see identical surfaces.
"""

from __future__ import annotations

import warnings

from pathlib import Path
from typing import Sequence

import meshio
import numpy as np

from orchestrator import physics
from orchestrator.case import Case, CaseError, Domain, MeshWall, RectangleWall, Wall


def rectangle_triangles(wall: RectangleWall) -> np.ndarray:
    """Two triangles (2, 3, 3) covering the rectangle origin + s·edge1 + t·edge2, s, t ∈ [0, 1]."""
    o = np.asarray(wall.origin, dtype=float)
    a = np.asarray(wall.edge1, dtype=float)
    b = np.asarray(wall.edge2, dtype=float)
    return np.array([[o, o + a, o + a + b], [o, o + a + b, o + b]])


def mesh_triangles(wall: MeshWall, case_dir: Path) -> np.ndarray:
    """Triangles of an STL file (ASCII or binary), scaled by `wall.scale`."""
    path = (case_dir / wall.file).resolve()
    try:
        with warnings.catch_warnings():
            # meshio first reads an ASCII STL as binary (its triangle count overflows): a warning of
            # meshio's own format detection, not a problem of the file.
            warnings.simplefilter("ignore", RuntimeWarning)
            mesh = meshio.read(path, file_format="stl")
    except (OSError, meshio.ReadError, ValueError) as error:
        raise CaseError(f"walls.{wall.name}.file: cannot read STL mesh {path} ({error})") from None
    triangles = [block.data for block in mesh.cells if block.type == "triangle"]
    if not triangles:
        raise CaseError(f"walls.{wall.name}.file: {path} holds no triangles")
    indices = np.concatenate(triangles)
    return mesh.points[indices] * wall.scale


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
