"""The flow's time step chosen by convergence: the quarter set-up's deposit at 1×, 1.5× and 2× the
default step over three seeds (campaigns/avalanche/quarter_step_study.yaml), beside a flat brick's
rebound on a brick at those steps.

Run, after the campaign (about 75 min on 2 processes):
  demorch --mpi 2 campaign run campaigns/avalanche/quarter_step_study.yaml -j 1 -o runs/campaigns/quarter_step_study
  .venv/bin/python benchmarks/step_study.py runs/campaigns/quarter_step_study
→ docs/benchmarks/step_study.json and step_study.png (BENCH_RESULT to change the JSON's path).

The criterion (docs/benchmarks.md, "The step study"): a step is admissible when the mean of every
deposit metric over the seeds stays within the seed-to-seed range of the default step's seeds, and a
flat brick-on-brick rebound (rounded box, Table 1's brick/brick constants, 0.5 m/s, no gravity) stays
within 2 % of its converged value (the same at a twentieth of the default step).
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.case import parse_case  # noqa: E402
from orchestrator.engines import RunOptions  # noqa: E402
from orchestrator.physics import schedule  # noqa: E402
from orchestrator.results import RELEASE_DIR, read_results  # noqa: E402
from orchestrator.runner import run_case  # noqa: E402
from orchestrator.studies import brick_drop, brick_pair  # noqa: E402

RESULT = Path(os.environ.get("BENCH_RESULT", REPO / "docs" / "benchmarks" / "step_study.json"))
METRICS = {"deposit.length": "L (m)", "deposit.runout": "R (m)", "deposit.width": "W (m)", "deposit.height": "H (m)",
           "deposit.x_cm": "X_CM (m)", "deposit.travel_angle_cm_deg": "φ_CM (°)", "deposit.fahrboschung_deg": "φ_app (°)"}
FACTOR = "release.time_safety_factor"
DEFAULT = 0.02  # LIGGGHTS' default for the bilinear law (physics.default_safety_factor)
IMPACT_SPEED = 0.5  # m/s


def pair_rebound(safety_factor: float) -> tuple[float, float]:
    """(Δt, rebound ratio) of a flat rounded box thrown at IMPACT_SPEED on an aligned fixed one."""
    case = brick_pair.pair_case("liggghts", brick_drop.study_brick(kind="rounded_box"), "aligned", 0.0, duration=0.01)
    data = case.model_dump(mode="json", exclude_none=True)
    data["gravity"] = [0.0, 0.0, 0.0]
    data["time"] = {"duration": 0.01, "output_interval": 0.0005, "safety_factor": safety_factor}
    data["bodies"]["clumps"][1]["velocity"] = [0.0, 0.0, -IMPACT_SPEED]
    case = parse_case(data)
    with tempfile.TemporaryDirectory() as scratch:
        run_case(case, Path(scratch), Path(scratch) / RELEASE_DIR, options=RunOptions(mpi_processes=1))
        final = read_results(Path(scratch) / RELEASE_DIR / "results.h5")
    return schedule(case).dt, float(final.velocity[-1, 1, 2]) / IMPACT_SPEED


def main(campaign_dir: Path) -> None:
    # each point's parameters (points.json) and its finished study's report (runs/<id>/report.json)
    points = json.loads((campaign_dir / "points.json").read_text())
    deposits: dict[str, dict[str, dict[str, float]]] = {}
    for run, parameters in points.items():
        report_path = campaign_dir / "runs" / run / "report.json"
        if not report_path.is_file():
            continue
        deposit = json.loads(report_path.read_text())["deposit"]
        factor = f"{float(parameters[FACTOR]):g}"
        for metric in METRICS:
            deposits.setdefault(factor, {}).setdefault(metric, {})[str(parameters["seed"])] = float(deposit[metric.split(".")[1]])
    factors = sorted(float(f) for f in deposits)
    reference = deposits[f"{DEFAULT:g}"]
    verdicts: dict[str, dict[str, bool]] = {}
    for factor, values in deposits.items():
        verdicts[factor] = {metric: bool(min(reference[metric].values()) <= np.mean(list(v.values())) <= max(reference[metric].values()))
                            for metric, v in values.items()}
    converged_dt, converged = pair_rebound(DEFAULT / 20.0)
    rebounds = {}
    for factor in factors:
        dt, ratio = pair_rebound(factor)
        rebounds[f"{factor:g}"] = {"dt_s": dt, "rebound": ratio, "off_converged": ratio / converged - 1.0}
    admissible = [f for f in deposits if all(verdicts[f].values()) and abs(rebounds[f]["off_converged"]) <= 0.02]
    record = {
        "date": time.strftime("%Y-%m-%d"),
        "campaign": str(campaign_dir),
        "criterion": "mean over seeds within the default step's seed range, every metric; brick-on-brick rebound within 2 % of converged",
        "deposits": deposits,
        "mean_within_default_range": verdicts,
        "pair_rebound": {"converged": {"dt_s": converged_dt, "rebound": converged}, **rebounds},
        "admissible": admissible,
        "largest_admissible": max(admissible, key=float) if admissible else None,
    }
    RESULT.write_text(json.dumps(record, indent=1) + "\n")
    figure(record, RESULT.with_suffix(".png"))
    print(json.dumps({k: record[k] for k in ("mean_within_default_range", "pair_rebound", "largest_admissible")}, indent=1))


def figure(record: dict, path: Path) -> None:
    """One panel per deposit metric: each seed's value (dots) and the mean (bar) at each step factor,
    the default step's seed range shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    factors = sorted(record["deposits"], key=float)
    fig, axes = plt.subplots(2, 4, figsize=(13, 6))
    for ax, (metric, label) in zip(axes.flat, METRICS.items()):
        default = list(record["deposits"][f"{DEFAULT:g}"][metric].values())
        ax.axhspan(min(default), max(default), color="0.85", label="seed range at 1×")
        for x, factor in enumerate(factors):
            values = list(record["deposits"][factor][metric].values())
            ax.plot([x] * len(values), values, "o", color="C0", alpha=0.7)
            ax.hlines(np.mean(values), x - 0.25, x + 0.25, color="C3", lw=2)
        ax.set_xticks(range(len(factors)), [f"{float(f) / DEFAULT:g}×" for f in factors])
        ax.set_title(label)
    rebound = axes.flat[-1]
    converged = record["pair_rebound"]["converged"]["rebound"]
    rebound.plot(range(len(factors)), [100 * record["pair_rebound"][f]["off_converged"] for f in factors], "s-", color="C2")
    rebound.axhline(2.0, color="C3", ls="--")
    rebound.set_xticks(range(len(factors)), [f"{float(f) / DEFAULT:g}×" for f in factors])
    rebound.set_title(f"brick-on-brick rebound, % off converged ({converged:.4f})")
    axes.flat[0].legend(fontsize=8)
    fig.suptitle("Quarter set-up, rounded box: deposit over seeds (dots), their mean (bar), at 1×, 1.5×, 2× the default step")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main(Path(sys.argv[1]))
