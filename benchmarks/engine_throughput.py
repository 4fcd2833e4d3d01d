"""Engine throughput on the brick avalanche: cost per step against the number of bricks, per engine.

Run: .venv/bin/python benchmarks/engine_throughput.py  → docs/benchmarks/engine_throughput.json and a
markdown table on stdout. Environment: BENCH_SIZES (bricks, comma-separated; default 95,380,1520),
BENCH_ENGINES (default liggghts,yade), BENCH_YADE_MAX (largest size run on YADE; default 380).

Method. For each engine and size, the packing stage of a random pour in the full-scale release box
(on 1.5 m boards: see study_of)
(bricks rained from a loose grid, 4 × 2 × 1 clumps, bilinear law, Table 1 constants, the default
step of 100 per contact) runs twice, for T1 and T2 = 2 T1 simulated seconds. The difference of the two
wall times over the difference of their step counts is the cost of one step, free of start-up
(deck parsing, clump insertion, result collection); start-up = wall(T1) − steps(T1) × cost. Early
in a pour most bricks are airborne, so contacts are fewer than in a dense flow: the per-step cost is
a lower bound for the release (on the 1.5 m boards the box also overhangs the shortened slope, so
this set-up only holds for the short windows measured here). `benchmarks/flow_throughput.py`
measures the dense flow instead, per brick resolution, law and process count. The full-scale projection multiplies the per-step cost, extrapolated
linearly in the number of bricks from the two largest sizes, by the steps of the preset study.
"""

from __future__ import annotations

import json
import os
import platform
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator import physics  # noqa: E402
from orchestrator.studies.avalanche.study import AvalancheStudy, load_study, packing_case
from orchestrator.validation import with_engine  # noqa: E402
from orchestrator.runner import run_case  # noqa: E402

FULL_SCALE = REPO / "cases" / "avalanche" / "random_pour_full.yaml"


def study_of(bricks: int, engine: str, settle_time: float) -> AvalancheStudy:
    """The full-scale random pour with `bricks` bricks (its box, its density) and a short settle."""
    full = load_study(FULL_SCALE)
    volume = full.packing.volume * bricks / full.brick_count
    packing = full.packing.model_copy(update={"volume": volume, "settle_time": settle_time})
    # Boards of 1.5 m instead of 3 × 4 m: the pour stays in the box, and LIGGGHTS' memory and start-up
    # grow with the simulation box (measured: 4.1 GB and 13 s to start at full board size, 95 bricks).
    geometry = full.geometry.model_copy(update={"board_length": 1.5, "board_width": 1.5})
    return with_engine(full, engine).model_copy(update={"packing": packing, "geometry": geometry})


def timed_run(study: AvalancheStudy, directory: Path) -> tuple[float, int, int]:
    """(wall seconds, steps, spheres) of the packing stage of `study`."""
    case = packing_case(study).model_copy(update={"save_state": False})
    started = time.perf_counter()
    run_case(case, directory, directory / "run")
    wall = time.perf_counter() - started
    spheres = sum(case.shape(c.shape).clump(case.material(c.material).density).n_spheres for c in case.bodies.clumps)
    return wall, physics.schedule(case).total_steps, spheres


def measure(engine: str, bricks: int, scratch: Path, short: float) -> dict[str, float]:
    first = timed_run(study_of(bricks, engine, short), scratch / f"{engine}-{bricks}-1")
    second = timed_run(study_of(bricks, engine, 2 * short), scratch / f"{engine}-{bricks}-2")
    per_step = (second[0] - first[0]) / (second[1] - first[1])
    spheres = first[2]
    return {
        "engine": engine,
        "bricks": bricks,
        "spheres": spheres,
        "dt_s": study_dt(bricks, engine),
        "seconds_per_step": per_step,
        "sphere_steps_per_s": spheres / per_step,
        "startup_s": first[0] - first[1] * per_step,
        "wall_per_simulated_s": per_step / study_dt(bricks, engine),
        "peak_rss_children_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0,
    }


def study_dt(bricks: int, engine: str) -> float:
    return physics.schedule(packing_case(study_of(bricks, engine, 0.01))).dt


def projection(rows: list[dict[str, float]], engine: str) -> dict[str, float] | None:
    """Full-scale study wall time from the per-step cost, linear in the brick count (two largest sizes)."""
    mine = sorted((r for r in rows if r["engine"] == engine), key=lambda r: r["bricks"])
    if len(mine) < 2:
        return None
    a, b = mine[-2], mine[-1]
    full = load_study(FULL_SCALE)
    slope = (b["seconds_per_step"] - a["seconds_per_step"]) / (b["bricks"] - a["bricks"])
    per_step = b["seconds_per_step"] + slope * (full.brick_count - b["bricks"])
    steps = (full.packing.settle_time + full.release.duration) / a["dt_s"]
    return {"engine": engine, "bricks": full.brick_count, "seconds_per_step": per_step, "steps": steps, "projected_wall_h": per_step * steps / 3600.0}


def main() -> None:
    sizes = [int(s) for s in os.environ.get("BENCH_SIZES", "95,380,1520").split(",")]
    engines = os.environ.get("BENCH_ENGINES", "liggghts,yade").split(",")
    yade_max = int(os.environ.get("BENCH_YADE_MAX", 380))
    short = float(os.environ.get("BENCH_SIM_TIME", 0.01))
    scratch = Path(tempfile.mkdtemp(prefix="demorch-throughput-"))
    rows = []
    try:
        for engine in engines:
            for bricks in sizes:
                if engine == "yade" and bricks > yade_max:
                    continue
                rows.append(measure(engine, bricks, scratch, short))
                print(json.dumps(rows[-1]), flush=True)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    projections = [p for p in (projection(rows, e) for e in engines) if p]
    result = {"machine": f"{platform.machine()} {os.cpu_count()} CPUs, {platform.platform()}", "simulated_s": [short, 2 * short], "rows": rows, "full_scale": projections}
    out = REPO / "docs" / "benchmarks"
    out.mkdir(parents=True, exist_ok=True)
    (out / "engine_throughput.json").write_text(json.dumps(result, indent=2) + "\n")
    print("| engine | bricks | spheres | Δt (s) | ms per step | sphere-steps/s | start-up (s) | wall per simulated s |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['engine']} | {r['bricks']} | {r['spheres']} | {r['dt_s']:.3g} | {1e3 * r['seconds_per_step']:.3f} | "
            f"{r['sphere_steps_per_s']:.3g} | {r['startup_s']:.1f} | {r['wall_per_simulated_s']:.0f} s |"
        )
    for p in projections:
        print(f"\nfull scale on {p['engine']}: {p['bricks']} bricks, {p['steps']:.3g} steps × {1e3 * p['seconds_per_step']:.2f} ms ≈ {p['projected_wall_h']:.1f} h (projection)")


if __name__ == "__main__":
    main()
