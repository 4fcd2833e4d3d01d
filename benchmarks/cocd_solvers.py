"""COCD: seconds per time step against the number of grains, per solver, 2D and 3D.

Run: .venv/bin/python benchmarks/cocd_solvers.py → docs/benchmarks/cocd_solvers.json and a markdown
table on stdout. Environment: BENCH_2D (grain counts, default 500,2000,8000), BENCH_3D (default
500,2000), BENCH_STEPS (timed steps per point, default 5), BENCH_SOLVERS (default clarabel,scs,piqp).

Method. A column of the requested number of grains (d = 2 mm ± 10 %, the collapse defaults) stands
on a rough bed behind the gate's position, packed on a loose lattice and settled by 40 COCD steps
(Clarabel), then released: the gate is gone, so the next steps have a dense, collapsing column with
its full contact network. Each solver then runs BENCH_STEPS steps from that same state; the figure
is the mean solver time per step (the k-d tree and assembly are reported apart), with the contact
count and iterations. PIQP takes 2D only (its constraints are linear). Published (MOSEK interior
point, 2 × 8-core Xeon): 2D N = 8308 → 8.85 s/step, 3D N = 122 932 → 270 s/step at tolerance 1e-5.
"""

from __future__ import annotations

import copy
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.engines.cocd.solver import Scene, Walls, step  # noqa: E402
from orchestrator.studies.collapse.spec import parse_collapse
from orchestrator.studies.collapse.cases import preparation_case  # noqa: E402
from orchestrator.physics import sphere_mass  # noqa: E402

RESULT = REPO / "docs" / "benchmarks" / "cocd_solvers.json"


def column_scene(grains: int, dimension: int) -> Scene:
    """A column of about `grains` grains (aspect ratio 0.7) on the rough bed, as the collapse study rains it."""
    d = 0.002
    width = 0.008
    per_area = 0.82 / (np.pi * d**2 / 4) if dimension == 2 else 0.62 * width / (np.pi * d**3 / 6)
    area = grains / 1.2 / per_area  # the rain overfills by 20 %
    length = float(np.sqrt(area / 0.7))
    study = parse_collapse({"name": "bench", "engine": "cocd", "dimension": dimension,
                            "column": {"length": length, "height": 0.7 * length, "width": width},
                            "channel": {"slope_deg": 0.0, "length": 2 * length}})
    case = preparation_case(study)
    spheres = case.bodies.spheres
    materials = {m.name: k for k, m in enumerate(case.materials)}
    walls = [w for w in case.walls]
    return Scene(
        position=np.array([s.position for s in spheres], float),
        velocity=np.zeros((len(spheres), 3)),
        spin=np.zeros((len(spheres), 3)),
        radius=np.array([s.radius for s in spheres]),
        mass=np.array([sphere_mass(s, case.material(s.material).density) for s in spheres]),
        material=np.array([materials[s.material] for s in spheres]),
        fixed=np.array([s.fixed for s in spheres]),
        mu=np.full((len(materials), len(materials)), 0.3),
        walls=Walls(origin=np.array([w.origin for w in walls], float), edge1=np.array([w.edge1 for w in walls], float),
                    edge2=np.array([w.edge2 for w in walls], float), mu=np.full((len(walls), len(materials)), 0.3),
                    names=[w.name for w in walls], active=np.array([w.name != "gate" for w in walls])),
        gravity=np.array([0.0, 0.0, -9.81]),
        planar=dimension == 2,
    )


def settle(scene: Scene, steps: int) -> None:
    gate = scene.walls.active.copy()
    scene.walls.active[:] = True  # settle behind the gate
    for _ in range(steps):
        step(scene, 1e-3)
    scene.walls.active[:] = gate


def measure(scene: Scene, solver: str, steps: int) -> dict[str, float]:
    stats = []
    started = time.perf_counter()
    for _ in range(steps):
        stats.append(step(scene, 1e-3, solver, 1e-6 if solver == "scs" else 1e-8))
    wall = (time.perf_counter() - started) / steps
    solve = float(np.mean([s.solve_s for s in stats]))
    return {"solver": solver, "seconds_per_step": wall, "solver_seconds_per_step": solve, "other_seconds_per_step": wall - solve,
            "contacts": float(np.mean([s.contacts for s in stats])), "iterations": float(np.mean([s.iterations for s in stats]))}


def main() -> None:
    sizes = {2: [int(n) for n in os.environ.get("BENCH_2D", "500,2000,8000").split(",") if n],
             3: [int(n) for n in os.environ.get("BENCH_3D", "500,2000").split(",") if n]}
    steps = int(os.environ.get("BENCH_STEPS", "5"))
    solvers = os.environ.get("BENCH_SOLVERS", "clarabel,scs,piqp").split(",")
    rows = []
    for dimension, counts in sizes.items():
        for grains in counts:
            base = column_scene(grains, dimension)
            settle(base, 40)
            for solver in solvers:
                if solver == "piqp" and dimension == 3:
                    continue
                scene = copy.deepcopy(base)
                row = {"dimension": dimension, "grains": int((~scene.fixed).sum()), "glued": int(scene.fixed.sum()), **measure(scene, solver, steps)}
                rows.append(row)
                print(json.dumps(row), flush=True)
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps({"machine": {"platform": platform.platform(), "cpus": os.cpu_count()}, "steps": steps, "rows": rows}, indent=2) + "\n")
    print("| dim | grains | solver | s per step | solver s | contacts | iterations |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['dimension']}D | {r['grains']} | {r['solver']} | {r['seconds_per_step']:.3f} | {r['solver_seconds_per_step']:.3f} | {r['contacts']:.0f} | {r['iterations']:.0f} |")


if __name__ == "__main__":
    main()
