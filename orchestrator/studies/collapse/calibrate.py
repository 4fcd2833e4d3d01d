"""Calibrate the grain friction μ on a horizontal collapse against the quasi-2D scaling law.

Lube et al. (2005): ΔL/L0 ≈ 1.2 a for a column of aspect ratio a = H0/R0 ≲ 2.3 in a channel; the
band is ± 20 % (a secondary-source value, `reference.toml` [collapse.scaling.horizontal]). ΔL is the
runout from the gate, L0 = R0. The runout falls as μ grows, so μ is bisected (grain/grain and
grain/wall alike, as in the study) until ΔL/L0 is within `tolerance` of the law's centre, or the
budget of runs is spent; the μ whose runout is nearest the centre is reported. Every run keeps its
directory (mu-<value>), so an interrupted calibration reuses what it had; all share one preparation.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

from orchestrator.engines import RunOptions
from orchestrator.studies.collapse.spec import CollapseStudy
from orchestrator.studies.collapse.study import run_collapse

QUASI_2D_COEFFICIENT = 1.2
BAND = 0.20


def target_runout(study: CollapseStudy) -> float:
    """ΔL/L0 of the quasi-2D law for this column's aspect ratio."""
    return QUASI_2D_COEFFICIENT * study.column.height / study.column.length


def with_mu(study: CollapseStudy, mu: float) -> CollapseStudy:
    contacts = study.contacts.model_copy(update={"mu": mu, "mu_wall": None})
    return study.model_copy(update={"contacts": contacts})


def calibrate_mu(
    study: CollapseStudy,
    outdir: Path,
    mu_range: tuple[float, float] = (0.1, 0.9),
    tolerance: float = 0.05,
    max_runs: int = 8,
    on_run: Callable[[float, float], None] | None = None,
    options: RunOptions | None = None,
) -> dict[str, Any]:
    """Bisect μ in `mu_range` for ΔL/L0 = 1.2 a. Returns the history, the chosen μ and whether it is in the band.
    options: how the engines run (MPI processes)."""
    target = target_runout(study)
    low, high = mu_range
    history: list[dict[str, float]] = []
    for _ in range(max_runs):
        mu = round(0.5 * (low + high), 4)
        report = run_collapse(with_mu(study, mu), outdir / f"mu-{mu:.4f}", preparations=outdir / "preparations", options=options)
        ratio = report["runout_over_R0"]
        history.append({"mu": mu, "runout_over_R0": ratio, "at_rest": bool(report["front"]["at_rest"])})
        if on_run:
            on_run(mu, ratio)
        if abs(ratio - target) <= tolerance * target:
            break
        if ratio > target:
            low = mu
        else:
            high = mu
    best = min(history, key=lambda entry: abs(entry["runout_over_R0"] - target))
    result = {
        "engine": study.engine.value,
        "aspect_ratio": study.column.height / study.column.length,
        "target_runout_over_R0": target,
        "band": [target * (1 - BAND), target * (1 + BAND)],
        "mu": best["mu"],
        "runout_over_R0": best["runout_over_R0"],
        "in_band": abs(best["runout_over_R0"] - target) <= BAND * target,
        "history": history,
    }
    (outdir / "calibration.json").write_text(json.dumps(result, indent=2) + "\n")
    return result
