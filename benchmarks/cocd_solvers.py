"""COCD: seconds per time step against the number of grains, per solver, 2D and 3D.

Run: .venv/bin/python benchmarks/cocd_solvers.py → docs/benchmarks/cocd_solvers.json, a log–log plot
docs/benchmarks/cocd_solvers.png and a markdown table on stdout. Environment: BENCH_2D (grain
counts, default 2000,8308,20000,46000), BENCH_3D (default 500,2000), BENCH_STEPS (timed steps per
point, default 5), BENCH_SOLVERS (default clarabel,scs,piqp,mehrotra), BENCH_SLOW_UP_TO (grains:
above it only mehrotra runs, default 8400: Clarabel, SCS and PIQP take minutes a step beyond).
Run it with OPENBLAS_NUM_THREADS=1 for one core (the script sets it when unset).

Method. A column of the requested number of grains (d = 2 mm ± 10 %, the collapse defaults) stands
on a rough bed behind the gate's position, packed on a loose lattice and settled by 40 COCD steps
(the dimension's default solver), then released: the gate is gone, so the next steps have a dense,
collapsing column with its full contact network. Each solver then runs BENCH_STEPS steps from that
same state (mehrotra warm-starts from the step before, as in a run); the figure is the mean solver
time per step (the k-d tree and assembly are reported apart), with the contact count and
iterations. PIQP and mehrotra take 2D only (their constraints are linear). The exponent of each 2D
solver's seconds against N is fitted by least squares on the logarithms. Published (MOSEK interior
point, 2 × 8-core Xeon; reference.toml [collapse.martin2022.solver_cost]): 2D N = 8308 → 8.85 s/step,
N = 50 772 → 51.9 s/step; 3D N = 122 932 → 270 s/step at tolerance 1e-5.
"""

from __future__ import annotations

import copy
import json
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core: CHOLMOD's BLAS is threaded otherwise

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.engine_sections import COCD_PLANAR_ONLY, CocdSettings  # noqa: E402
from orchestrator.engines.cocd.solver import Scene, Walls, step  # noqa: E402
from orchestrator.studies.collapse.spec import parse_collapse  # noqa: E402
from orchestrator.studies.collapse.cases import preparation_case  # noqa: E402
from orchestrator.physics import sphere_mass  # noqa: E402
from orchestrator.studies.reference import load_reference  # noqa: E402

RESULT = REPO / "docs" / "benchmarks" / "cocd_solvers.json"
PLOT = RESULT.with_suffix(".png")


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
    solver = CocdSettings().resolved(scene.planar)
    for _ in range(steps):
        step(scene, 1e-3, solver)
    scene.walls.active[:] = gate
    scene.impulses = None  # every solver starts the timed steps alike


def measure(scene: Scene, solver: str, steps: int) -> dict[str, float]:
    stats = []
    started = time.perf_counter()
    for _ in range(steps):
        stats.append(step(scene, 1e-3, solver, 1e-6 if solver == "scs" else 1e-8))
    wall = (time.perf_counter() - started) / steps
    solve = float(np.mean([s.solve_s for s in stats]))
    return {"solver": solver, "seconds_per_step": wall, "solver_seconds_per_step": solve, "other_seconds_per_step": wall - solve,
            "contacts": float(np.mean([s.contacts for s in stats])), "iterations": float(np.mean([s.iterations for s in stats]))}


def exponents(rows: list[dict]) -> dict[str, float]:
    """Per 2D solver with two sizes or more: the slope of log(solver seconds) against log(N)."""
    fitted = {}
    for solver in sorted({r["solver"] for r in rows if r["dimension"] == 2}):
        points = [(r["grains"], r["solver_seconds_per_step"]) for r in rows if r["dimension"] == 2 and r["solver"] == solver]
        if len(points) >= 2:
            n, t = np.log(np.array(points)).T
            fitted[solver] = float(np.polyfit(n, t, 1)[0])
    return fitted


def plot(rows: list[dict], fitted: dict[str, float]) -> None:
    """Seconds per step against N (2D), log–log, each solver and the study's MOSEK points."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(6.4, 4.4))
    for solver in sorted({r["solver"] for r in rows if r["dimension"] == 2}):
        points = sorted((r["grains"], r["solver_seconds_per_step"]) for r in rows if r["dimension"] == 2 and r["solver"] == solver)
        label = f"{solver} (N^{fitted[solver]:.2f})" if solver in fitted else solver
        axes.loglog(*zip(*points), "o-", label=label + ", 1 core")
    mosek = [run for run in load_reference()["collapse"]["martin2022"]["solver_cost"]["runs"] if run[0] < 100_000]
    axes.loglog([run[0] for run in mosek], [run[1] for run in mosek], "ks", label="MOSEK, Martin et al. 2022 (16 cores)")
    axes.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axes.set_xlabel("grains N (2D)")
    axes.set_ylabel("solver seconds per step")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(PLOT, dpi=110)


def main() -> None:
    sizes = {2: [int(n) for n in os.environ.get("BENCH_2D", "2000,8308,20000,46000").split(",") if n],
             3: [int(n) for n in os.environ.get("BENCH_3D", "500,2000").split(",") if n]}
    steps = int(os.environ.get("BENCH_STEPS", "5"))
    solvers = os.environ.get("BENCH_SOLVERS", "clarabel,scs,piqp,mehrotra").split(",")
    slow_up_to = int(os.environ.get("BENCH_SLOW_UP_TO", "8400"))
    rows = []
    for dimension, counts in sizes.items():
        for grains in counts:
            base = column_scene(grains, dimension)
            settle(base, 40)
            for solver in solvers:
                if (solver in COCD_PLANAR_ONLY and dimension == 3) or (solver != "mehrotra" and grains > slow_up_to):
                    continue
                scene = copy.deepcopy(base)
                mobile = int((~scene.fixed).sum())
                row = {"dimension": dimension, "grains": mobile, "glued": int(scene.fixed.sum()), **measure(scene, solver, steps)}
                row["solver_seconds_per_grain"] = row["solver_seconds_per_step"] / mobile
                rows.append(row)
                print(json.dumps(row), flush=True)
    fitted = exponents(rows)
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps({"machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "blas_threads": os.environ["OPENBLAS_NUM_THREADS"]},
                                  "steps": steps, "rows": rows, "exponents_2d": fitted}, indent=2) + "\n")
    plot(rows, fitted)
    print("| dim | grains | solver | s per step | solver s | µs per grain | contacts | iterations |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['dimension']}D | {r['grains']} | {r['solver']} | {r['seconds_per_step']:.3f} | {r['solver_seconds_per_step']:.3f} | "
              f"{1e6 * r['solver_seconds_per_grain']:.0f} | {r['contacts']:.0f} | {r['iterations']:.0f} |")
    print("2D exponents (solver seconds ∝ N^k): " + ", ".join(f"{k} {v:.2f}" for k, v in fitted.items()))


if __name__ == "__main__":
    main()
