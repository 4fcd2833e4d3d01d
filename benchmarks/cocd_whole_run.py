"""COCD: one 2D collapse released from one prepared state on each solver; runouts at 1 s side by side.

Run: .venv/bin/python benchmarks/cocd_whole_run.py [STUDY.yaml] → docs/benchmarks/cocd_whole_run.json
and a markdown table on stdout. Default study: cases/collapse/disc2d22_bed5mm.yaml (the study's 2D
22° collapse on a 5 mm bed at a fifth of its scale, ≈ 3 400 grains), released for 1 s. Environment:
BENCH_RUNS (solver:tolerance pairs, default mehrotra:1e-8,clarabel:1e-8,clarabel:1e-10,piqp:1e-8,mehrotra:1e-10).

Method. The study runs once on the first solver (its rain and its release); each other solver
then runs the same release case, from the same prepared state, with only `cocd.solver` and
`cocd.tolerance` changed, and is measured by the study's own measure (front r_f on slices of one
grain diameter). Clarabel at 1e-10 is the reference. A granular flow amplifies any difference
(round-off, a solver's tolerance) tenfold every 0.01 s or so, so the spread between Clarabel at
1e-8 and at 1e-10 is the yardstick for "the same runout": a single release is reproducible only
to that spread.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.case import parse_case  # noqa: E402
from orchestrator.results import read_results  # noqa: E402
from orchestrator.runner import run_case  # noqa: E402
from orchestrator.studies.collapse.spec import load_collapse, parse_collapse  # noqa: E402
from orchestrator.studies.collapse.study import measure, run_collapse  # noqa: E402

RESULT = REPO / "docs" / "benchmarks" / "cocd_whole_run.json"
WORK = Path(os.environ.get("BENCH_WORK", "/tmp/demorch-cocd-whole-run"))


def front_at(report: dict, instant: float) -> float:
    """r_f (m) at the frame nearest `instant` (s)."""
    times = np.asarray(report["front"]["time"])
    return float(report["front"]["position"][int(np.argmin(np.abs(times - instant)))])


def main() -> None:
    source = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "cases" / "collapse" / "disc2d22_bed5mm.yaml"
    runs = [(pair.split(":")[0], float(pair.split(":")[1]))
            for pair in os.environ.get("BENCH_RUNS", "mehrotra:1e-8,clarabel:1e-8,clarabel:1e-10,piqp:1e-8,mehrotra:1e-10").split(",")]
    data = load_collapse(source).model_dump(mode="json")
    data["release"]["duration"] = 1.0
    solver, tolerance = runs[0]
    study = parse_collapse({**data, "cocd": {"solver": solver, "tolerance": tolerance}}, str(source))
    started = time.perf_counter()
    report = run_collapse(study, WORK / "first", preparations=WORK / "preparations")
    rows = [{"solver": solver, "tolerance": tolerance, "release_and_rain_s": time.perf_counter() - started, "report": report}]
    release = json.loads((WORK / "first" / "run" / "case.json").read_text())
    for solver, tolerance in runs[1:]:
        directory = WORK / f"{solver}_{tolerance:g}"
        started = time.perf_counter()
        run_case(parse_case({**release, "cocd": {"solver": solver, "tolerance": tolerance}}), WORK, directory)
        glued = np.asarray(json.loads((directory / "cocd.json").read_text())["bodies"])[:, 12] == 1.0
        rows.append({"solver": solver, "tolerance": tolerance, "release_s": time.perf_counter() - started,
                     "report": measure(study, read_results(directory / "results.h5"), glued)[0]})
    r0 = study.column.length
    table = []
    for row in rows:
        report = row.pop("report")
        row.update({"runout_over_R0_at_1s": report["runout"] / r0,
                    "front_over_R0": {f"{t:g}": front_at(report, t) / r0 for t in (0.25, 0.5, 0.75, 1.0)}})
        table.append(row)
    reference = next(r for r in table if r["solver"] == "clarabel" and r["tolerance"] == 1e-10)["runout_over_R0_at_1s"]
    for row in table:
        row["difference_from_reference"] = row["runout_over_R0_at_1s"] / reference - 1.0
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps({"machine": {"platform": platform.platform(), "cpus": os.cpu_count()}, "study": str(source.relative_to(REPO)),
                                  "R0": r0, "rows": table}, indent=2) + "\n")
    print("| solver | tolerance | r_f/R0 at 0.25 / 0.5 / 0.75 / 1 s | against Clarabel 1e-10 at 1 s |")
    print("|---|---|---|---|")
    for row in table:
        fronts = " / ".join(f"{v:.2f}" for v in row["front_over_R0"].values())
        print(f"| {row['solver']} | {row['tolerance']:g} | {fronts} | {100 * row['difference_from_reference']:+.1f} % |")


if __name__ == "__main__":
    main()
