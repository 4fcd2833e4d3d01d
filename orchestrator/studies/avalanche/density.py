"""The packing's search for its apparent density: μ brick/brick while packing, varied in a bounded search.

The 2012 study (Richefeu et al., section 4; science brief) launched its bricks into the box, varied the
contact parameters over several trials until the pile's bulk volume was 40 l (1000 kg/m³), then
restored Table 1 for the flow. Here one parameter varies, the brick/brick friction while packing: a
rougher contact leaves a looser pile. Each trial is a whole packing (content-addressed, so a campaign
or a rerun reuses every trial it needs); the search stops at the first trial within the tolerance,
or after `max_trials`, keeping the closest.

The next μ: the secant through the two trials closest to the target, kept inside the bracket that the
trials so far define (bisection when the secant leaves it); after one trial, a slope measured on pours
in an eighth of the experiment's floor (2026-11-30, docs/studies/avalanche.md: 958, 1037, 1134 kg/m³
at μ 0.86, 0.5, 0.3), a relative change of about −0.3 per unit of μ.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

# d(ρ/ρ_target)/dμ of a pour, for the step after the first trial (see the module docstring).
RELATIVE_SLOPE = -0.3
SAME_MU = 1e-3  # two trials closer than this in μ are one: the search has nowhere left to go


@dataclass(frozen=True)
class Trial:
    """One packing of the search: μ brick/brick while packing, the apparent density it reached
    (kg/m³), its directory, whether it was already there, its wall time (s), and what an earlier
    attempt of the same packing left, set aside (its record's `set_aside`)."""

    mu: float
    apparent_density: float
    directory: str
    reused: bool
    wall_s: float
    set_aside: dict[str, str] | None = None  # an earlier packing of this id that no longer stood: where it went, why

    def off(self, target: float) -> float:
        """Relative miss of the target density (signed)."""
        return self.apparent_density / target - 1.0

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


def next_mu(trials: list[Trial], target: float, bounds: tuple[float, float]) -> float | None:
    """The μ of the next trial, or None when no untried μ inside `bounds` can get closer.

    The density falls as μ rises: a trial too dense bounds μ from below, one too loose from above.
    """
    low = max([t.mu for t in trials if t.apparent_density > target], default=bounds[0])
    high = min([t.mu for t in trials if t.apparent_density < target], default=bounds[1])
    if low >= high:
        return None
    nearest = sorted(trials, key=lambda t: abs(t.off(target)))[:2]
    if len(nearest) == 2 and abs(nearest[0].mu - nearest[1].mu) > SAME_MU and nearest[0].apparent_density != nearest[1].apparent_density:
        a, b = nearest
        guess = a.mu + (target - a.apparent_density) * (b.mu - a.mu) / (b.apparent_density - a.apparent_density)
    else:
        a = nearest[0]
        guess = a.mu + a.off(target) / -RELATIVE_SLOPE
    if not low < guess < high or not bounds[0] <= guess <= bounds[1]:
        guess = (low + high) / 2.0
    guess = min(max(guess, bounds[0]), bounds[1])
    if any(abs(guess - t.mu) < SAME_MU for t in trials):
        return None
    return guess


def closest(trials: list[Trial], target: float) -> Trial:
    """The trial nearest the target density (the first of equals)."""
    return min(trials, key=lambda t: abs(t.off(target)))
