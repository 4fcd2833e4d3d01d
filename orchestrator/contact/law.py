"""Pure-Python reference of one bilinear contact (Richefeu et al. 2012): overlap history in, force out.

The compiled LIGGGHTS model (custom_contact/normal_model_bilinear.h) must reproduce this step by step;
the tests feed both the same overlap sequence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class BilinearNormal:
    """Normal force of one contact. Loading: f += k_n Δh; unloading: f = e_n² k_n h; f ≥ 0; reset on loss."""

    kn: float
    en2: float
    force: float = 0.0
    overlap: float = 0.0

    def step(self, overlap: float) -> float:
        if overlap <= 0.0:
            self.force, self.overlap = 0.0, 0.0  # contact lost: history reset
            return 0.0
        if overlap >= self.overlap:
            force = self.force + self.kn * (overlap - self.overlap)
        else:
            force = self.en2 * self.kn * overlap
        self.force, self.overlap = max(force, 0.0), overlap
        return self.force


def tangential_step(force: np.ndarray, velocity: np.ndarray, dt: float, kt: float, mu: float, normal_force: float) -> np.ndarray:
    """Incremental tangential spring capped by Coulomb: f_t += k_t v_t Δt, then |f_t| ≤ μ f_n.

    `force` must already be rotated into the current contact plane (the engines do that each step).
    """
    trial = np.asarray(force, dtype=float) + kt * np.asarray(velocity, dtype=float) * dt
    magnitude = float(np.linalg.norm(trial))
    limit = mu * normal_force
    return trial * (limit / magnitude) if magnitude > limit and magnitude > 0.0 else trial
