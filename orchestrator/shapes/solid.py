"""What the kinds that are one body share: one particle, sized by its bounding radius, with the true
brick's volume, mass and inertia: a length × width ×
thickness box whose edges and corners are rounded at `rounding` (the 2012 study's brick: 31 × 15 ×
8 mm, 1 mm), in closed form (shapes/rigid.py `rounded_box_moments`), whatever surface the kind
gives it (the superquadric's own, or the rounded box itself). A given mass or inertia wins.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from orchestrator.shapes.rigid import inertia_tensor, rounded_box_moments


class OneBodyBrick:
    """Mixin of a body-shape dataclass with fields length, width, thickness (m), density (kg/m³),
    rounding (m), mass_given (kg or None) and inertia_given ((3,) kg m² or None)."""

    length: float
    width: float
    thickness: float
    density: float
    rounding: float
    mass_given: float | None
    inertia_given: tuple[float, float, float] | None

    @property
    def half_axes(self) -> np.ndarray:
        """(3,) outer half extents (m) along the length, width and thickness."""
        return np.array([self.length, self.width, self.thickness]) / 2.0

    @cached_property
    def _moments(self) -> tuple[float, np.ndarray]:
        volume, _, covariance = rounded_box_moments(2.0 * self.half_axes, self.rounding)
        return volume, covariance

    @property
    def volume(self) -> float:
        """The true brick's volume (m³), which sets its mass at the material's density."""
        return self._moments[0]

    @property
    def mass(self) -> float:
        return self.mass_given if self.mass_given is not None else self.density * self.volume

    @cached_property
    def inertia_tensor(self) -> np.ndarray:
        """(3, 3) inertia about the centre of mass in the brick axes (diagonal), kg m²."""
        return inertia_tensor(self._moments[1], self.mass, self.volume, self.inertia_given)

    @property
    def principal_inertia(self) -> np.ndarray:
        return np.diag(self.inertia_tensor).copy()

    @property
    def centroid_offset(self) -> np.ndarray:
        return np.zeros(3)

    @property
    def sweep(self) -> tuple[np.ndarray, float] | None:
        """(inner half extents (3,) m, sweep radius m) of a sphere-swept box; None: not one."""
        return None

    @property
    def particles(self) -> int:
        """Particles the engine moves for this body: one."""
        return 1

    @property
    def radius(self) -> float:
        """m, the particle's radius: the bounding radius (one body, one particle)."""
        return self.bounding_radius  # type: ignore[attr-defined]

    @property
    def skin_length(self) -> float:
        """m, what neighbour skins are a multiple of: the bounding radius (a kind may take less)."""
        return self.bounding_radius  # type: ignore[attr-defined]
