"""Cost per step of the rounded-box brick (pair_style roundedbox) against the superquadric, LIGGGHTS.

A pile of BENCH_BRICKS (default 600) study bricks rained from a loose grid onto a board and settling
for BENCH_DURATION (default 0.6 s: most of it a pile in contact) simulated seconds, Table 1's
constants, on 1 and 2 processes.
Both kinds run the same step (the superquadric's automatic one unless BENCH_STEP is given), so the
wall time per step compares the contact search and forces alone; each kind's own automatic step is
reported beside it (the rounded box's is shorter: a face on a face is up to 16 contact points).

Run: .venv/bin/python benchmarks/rounded_box_cost.py → docs/benchmarks/rounded_box_cost.json and a
markdown table on stdout. Time it with nothing else running.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator import physics  # noqa: E402
from orchestrator.case import Case, parse_case  # noqa: E402
from orchestrator.engines import RunOptions  # noqa: E402
from orchestrator.runner import run_case  # noqa: E402
from orchestrator.studies import brick_drop  # noqa: E402
from orchestrator.studies.avalanche.packing import loose_grid  # noqa: E402

KINDS = ("superquadric", "rounded_box")


def pile(kind: str, count: int, duration: float, step: float | str = "auto") -> Case:
    shape = brick_drop.study_brick(kind=kind)
    body = parse_case(_case(shape, [], [], duration, step)).shape("brick").body(1700.0)
    positions, orientations = loose_grid(body, count, (-0.21, -0.21, 0.001), (12, 12), seed=7)  # 144 a layer
    return parse_case(_case(shape, positions.tolist(), orientations.tolist(), duration, step))


def _case(shape: dict, positions: list, orientations: list, duration: float, step: float | str) -> dict:
    table1 = {"law": "bilinear", "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}
    board = {"law": "bilinear", "en2": 0.53, "mu": 0.46, "kn": 1e5, "kt_over_kn": 0.42}
    return {"name": "pile", "engine": "liggghts", "time": {"duration": duration, "output_interval": 0.05, "step": step},
            "materials": [{"name": "brick", "density": 1700.0}, {"name": "board", "density": 1400.0}],
            "contacts": [{"materials": ["brick", "brick"], **table1}, {"materials": ["brick", "board"], **board}],
            "shapes": [shape],
            "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": p, "orientation": q}
                                  for p, q in zip(positions, orientations)] or
                       [{"shape": "brick", "material": "brick", "position": [0.0, 0.0, 0.01]}]},
            "walls": [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.5, -0.5, 0.0],
                       "edge1": [1.0, 0.0, 0.0], "edge2": [0.0, 1.0, 0.0]}],
            "domain": {"lower": [-0.5, -0.5, -0.05], "upper": [0.5, 0.5, 1.0]}}


def main() -> None:
    count = int(os.environ.get("BENCH_BRICKS", "600"))
    duration = float(os.environ.get("BENCH_DURATION", "0.6"))
    own_steps = {kind: physics.time_step(pile(kind, count, duration)) for kind in KINDS}
    step = float(os.environ.get("BENCH_STEP", own_steps["superquadric"]))
    rows = []
    for processes in (1, 2):
        for kind in KINDS:
            case = pile(kind, count, duration, step)
            plan = physics.schedule(case)
            with tempfile.TemporaryDirectory() as scratch:
                started = time.perf_counter()
                run_case(case, Path(scratch), Path(scratch) / "run", options=RunOptions(mpi_processes=processes, checkpoint_interval=0))
                wall = time.perf_counter() - started
            rows.append({"kind": kind, "processes": processes, "bricks": count, "dt_s": step, "own_dt_s": own_steps[kind],
                         "steps": plan.total_steps, "wall_s": wall, "ms_per_step": 1e3 * wall / plan.total_steps})
            print(rows[-1], flush=True)
    record = {"date": time.strftime("%Y-%m-%d"), "machine": platform.node(), "cpus": os.cpu_count(), "rows": rows}
    (REPO / "docs" / "benchmarks" / "rounded_box_cost.json").write_text(json.dumps(record, indent=2) + "\n")
    print("| kind | processes | own Δt (µs) | steps of Δt | wall (s) | ms per step |\n|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['kind']} | {r['processes']} | {1e6 * r['own_dt_s']:.2f} | {r['steps']} | {r['wall_s']:.1f} | {r['ms_per_step']:.3f} |")


if __name__ == "__main__":
    main()
