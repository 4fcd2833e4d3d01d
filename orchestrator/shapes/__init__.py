"""Body shapes: what a body's shape gives the rest of the code, one kind per representation.

A case names a shape's `kind` (`shapes[i].kind`); `KINDS` maps each kind to its module's builder and
`make_shape` is the one place that picks it (an unknown kind gets one error listing the kinds).
Studies, pre-flight, plots and dumps use only the `BodyShape` protocol; how an engine realises a
kind (multisphere template, superquadric atom, YADE clump) lives in that engine's package, and each
engine declares the kinds it takes (`capabilities.Capabilities.shape_kinds`).

Kinds:
- `clump`: spheres rigidly joined (shapes/clump.py): every engine; faces are rows of spheres.
- `superquadric`: one smooth body with flat faces and rounded edges (shapes/superquadric.py).
- `rounded_box`: the 2012 study's brick, a box swept by a sphere, several contact points per touching
  face (shapes/rounded_box.py; LIGGGHTS, with custom_contact/pair_roundedbox).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Protocol

import numpy as np

from orchestrator.shapes import clump, rounded_box, superquadric


class BodyShape(Protocol):
    """What every kind of body shape gives (body frame: origin at the centre of mass, brick axes)."""

    kind: str
    mass: float  # kg, of the true solid
    volume: float  # m³, of the true solid

    @property
    def inertia_tensor(self) -> np.ndarray: ...  # (3, 3) kg m² about the centre of mass

    @property
    def principal_inertia(self) -> np.ndarray: ...  # (3,) kg m² about the brick axes

    @property
    def bounding_radius(self) -> float: ...  # m, centre to the farthest surface point

    @property
    def radius(self) -> float: ...  # m, of each particle the engine moves (a clump's largest sphere; a body's bounding sphere)

    @property
    def skin_length(self) -> float: ...  # m, what neighbour skins are a multiple of: how thick the body is

    @property
    def extent(self) -> np.ndarray: ...  # (3,) m, the centred box holding the solid

    @property
    def centroid_offset(self) -> np.ndarray: ...  # (3,) m, the centre of mass from that box's centre, body frame

    @property
    def sweep(self) -> tuple[np.ndarray, float] | None: ...  # (inner half extents (3,) m, radius m) of a sphere-swept box, else None

    @property
    def particles(self) -> int: ...  # particles the engine moves for one body (a clump's spheres; 1)

    @property
    def face_contacts(self) -> int: ...  # contacts of a flat landing (the stiffest contact is this × k_n)

    def surface_mesh(self, resolution: int = 24) -> tuple[np.ndarray, np.ndarray]: ...  # (n, 3) m, (m, 3) indices

    def lowest_points(self, rotations: np.ndarray) -> np.ndarray: ...  # (F,) m, lowest z about the centre per (F, 3, 3) rotation

    def penetration(self, points: np.ndarray) -> np.ndarray: ...  # (n,) m, depth of body-frame points inside the solid (≤ 0 outside)

    @property
    def probes(self) -> tuple[np.ndarray, np.ndarray]: ...  # spheres (n, 3) m, (n,) m whose union fills the solid to its surface (radius 0: surface points)


@dataclass(frozen=True)
class Kind:
    """One kind of body shape: its module's builder from a shape entry (bodies.BrickShape) at a
    density (kg/m³), its own checks of that entry (a one-line field error, or None), and how many
    latitudes its ParaView surface mesh gets."""

    build: Callable[[Any, float], BodyShape]
    check: Callable[[Any], str | None]
    mesh_resolution: int


KINDS: dict[str, Kind] = {
    "clump": Kind(clump.from_spec, clump.check_spec, 8),
    "superquadric": Kind(superquadric.from_spec, superquadric.no_bevel, 12),
    "rounded_box": Kind(rounded_box.from_spec, rounded_box.check_spec, 8),
}


def kind(name: str) -> Kind:
    """The kind called `name`; ValueError naming the kinds that exist when there is none."""
    try:
        return KINDS[name]
    except KeyError:
        raise ValueError(f"shapes.kind: unknown kind {name!r}; known: {sorted(KINDS)}") from None


def make_shape(spec: Any, density: float) -> BodyShape:
    """The body shape of a case's shape entry (`bodies.BrickShape`) at a material's density (kg/m³).

    Raises ValueError naming the kinds that exist when `spec.kind` is none of them."""
    return kind(spec.kind).build(spec, density)
