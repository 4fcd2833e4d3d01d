"""Cost of the study's rounded brick against the plain 4 × 2 × 1 clump: 50 bricks rained onto a
floor and settling for 1 s (bilinear law, Table 1 constants, automatic step), per engine.

Run: .venv/bin/python benchmarks/brick_cost.py  → docs/benchmarks/brick_cost.json and a markdown
table on stdout. Environment: BENCH_ENGINES (default liggghts,yade).

The rounded brick has 16 spheres (8 more, 1 mm, in the corners) against 8, but its flat face lands
on four of them, not eight, so the automatic step (which divides the brick's mass by the spheres on
its largest face) is √2 longer. Reported: the step, the steps, the wall time and the wall time per
simulated second.
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
from orchestrator.shapes.clump import BrickClump  # noqa: E402
from orchestrator.case import Case, parse_case  # noqa: E402
from orchestrator.runner import run_case  # noqa: E402
from orchestrator.studies.avalanche.packing import loose_grid  # noqa: E402

BRICKS = {"plain 4 × 2 × 1": 0.0, "rounded (study's brick)": 0.001}


def pile(engine: str, rounding: float, count: int = 50, duration: float = 1.0) -> Case:
    shape = {"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008, "layout": [4, 2, 1], "rounding": rounding}
    grid = BrickClump(0.031, 0.015, 0.008, 1700.0, (4, 2, 1), rounding=rounding)
    positions, orientations = loose_grid(grid, count, (-0.08, -0.08, 0.001), (5, 5), seed=7)
    return parse_case({
        "name": "pile", "engine": engine, "time": {"duration": duration, "output_interval": 0.02},
        "materials": [{"name": "brick", "density": 1700.0}, {"name": "board", "density": 1400.0}],
        "contacts": [{"materials": ["brick", "brick"], "law": "bilinear", "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27},
                     {"materials": ["brick", "board"], "law": "bilinear", "en2": 0.53, "mu": 0.46, "kn": 1e5, "kt_over_kn": 0.42}],
        "shapes": [shape],
        "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": p.tolist(), "orientation": q.tolist()}
                              for p, q in zip(positions, orientations)]},
        "walls": [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.3, -0.3, 0], "edge1": [0.6, 0, 0], "edge2": [0, 0.6, 0]}],
    })


def main() -> None:
    engines = os.environ.get("BENCH_ENGINES", "liggghts,yade").split(",")
    rows = []
    for engine in engines:
        for label, rounding in BRICKS.items():
            case = pile(engine, rounding)
            plan = physics.schedule(case)
            with tempfile.TemporaryDirectory() as scratch:
                started = time.perf_counter()
                run_case(case, Path(scratch), Path(scratch) / "run")
                wall = time.perf_counter() - started
            rows.append({"engine": engine, "brick": label, "spheres_per_brick": len(case.shape("brick").clump(1700.0).radii),
                         "dt_s": plan.dt, "steps": plan.total_steps, "wall_s": wall, "wall_per_simulated_s": wall / case.time.duration})
            print(rows[-1], flush=True)
    record = {"date": time.strftime("%Y-%m-%d"), "machine": platform.node(), "cpus": os.cpu_count(), "rows": rows}
    out = REPO / "docs" / "benchmarks" / "brick_cost.json"
    out.write_text(json.dumps(record, indent=2) + "\n")
    print("| engine | brick | spheres | Δt (µs) | steps | wall (s) |\n|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['engine']} | {r['brick']} | {r['spheres_per_brick']} | {1e6 * r['dt_s']:.2f} | {r['steps']} | {r['wall_s']:.1f} |")


if __name__ == "__main__":
    main()
