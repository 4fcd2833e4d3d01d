"""The packing's density search (studies/avalanche/density.py): which μ it tries next, and when it stops."""

from __future__ import annotations

import pytest

from orchestrator.studies.avalanche.density import Trial, closest, next_mu

BOUNDS = (0.0, 2.0)


def trial(mu: float, density: float) -> Trial:
    return Trial(mu, density, f"packings/{mu}", False, 1.0)


def pour(mu: float) -> float:
    """A made-up pour whose density falls linearly with μ: 1100 kg/m³ at μ 0, 1000 at μ 0.5."""
    return 1100.0 - 200.0 * mu


def test_a_pile_too_loose_lowers_the_friction_and_one_too_dense_raises_it() -> None:
    assert next_mu([trial(0.86, 950.0)], 1000.0, BOUNDS) < 0.86
    assert next_mu([trial(0.86, 1050.0)], 1000.0, BOUNDS) > 0.86


def test_the_secant_finds_a_linear_response_on_the_third_trial() -> None:
    trials = [trial(0.86, pour(0.86))]
    while abs(trials[-1].off(1000.0)) > 0.02:
        mu = next_mu(trials, 1000.0, BOUNDS)
        assert mu is not None and len(trials) < 3
        trials.append(trial(mu, pour(mu)))
    assert trials[-1].mu == pytest.approx(0.5, abs=0.1)  # within ±2 % of 1000: μ within 0.1 of 0.5
    assert len(trials) <= 3


def test_the_search_stays_inside_its_bracket_and_bounds() -> None:
    """A secant that would jump past a trial already on the other side of the target bisects instead."""
    trials = [trial(0.86, 900.0), trial(0.3, 1030.0), trial(0.31, 1031.0)]  # noise: the two nearest rise with μ
    assert next_mu(trials, 1000.0, BOUNDS) == pytest.approx((0.31 + 0.86) / 2)  # their secant points at μ 0: bisect
    assert 0.0 <= next_mu([trial(0.05, 500.0)], 1000.0, BOUNDS) <= 0.05


def test_a_target_out_of_reach_stops_the_search_and_keeps_the_closest() -> None:
    """Frictionless and still too loose: no μ left to try; the closest trial is the one kept."""
    trials = [trial(0.86, 700.0), trial(0.0, 850.0)]
    assert next_mu(trials, 1000.0, BOUNDS) is None
    assert closest(trials, 1000.0).mu == 0.0
    assert next_mu([trial(2.0, 1200.0)], 1000.0, BOUNDS) is None  # as rough as allowed and still too dense
