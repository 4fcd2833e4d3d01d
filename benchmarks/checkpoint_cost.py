"""What checkpoints cost: the same run without checkpoints, with the default (one per tenth of the
run) and with one at every frame, per engine.

Cases: 50 of the study's rounded bricks rained onto a floor and settling for 0.5 s, a frame every
2 ms (LIGGGHTS, YADE; 800 spheres), 100 spheres falling into a heap, a frame every 10 ms (cocd).
Each configuration runs `REPEATS` times, interleaved, and the median wall time counts. Runs of
this size scatter by about ±10 % on this machine, more than ten checkpoints cost, so the cost of
one checkpoint is taken from the run with one at every frame (250 on the piles):
(every frame − none) / checkpoints. The default's overhead is ten of those over the run.

Run: .venv/bin/python benchmarks/checkpoint_cost.py → docs/benchmarks/checkpoint_cost.json and a
markdown table on stdout. Environment: BENCH_ENGINES (default liggghts,yade,cocd), BENCH_REPEATS
(default 3).
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator import physics  # noqa: E402
from orchestrator.case import Case, parse_case  # noqa: E402
from orchestrator.engines import RunOptions, get_adapter  # noqa: E402
from orchestrator.engines.options import CHECKPOINTS_PER_RUN  # noqa: E402
from orchestrator.runner import run_case  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from brick_cost import pile  # noqa: E402

DURATION = 0.5


def heap(count: int = 100) -> Case:
    rng = np.random.default_rng(3)
    grid = np.array([(x, y, z) for z in range(count // 25 + 1) for y in range(5) for x in range(5)][:count], dtype=float)
    centres = 0.01 * grid + [-0.02, -0.02, 0.006] + rng.uniform(-0.0005, 0.0005, (count, 3))
    spheres = [{"material": "glass", "radius": 0.004, "position": [float(v) for v in c]} for c in centres]
    return parse_case({
        "name": "heap", "engine": "cocd", "time": {"duration": DURATION, "output_interval": 0.01},
        "materials": [{"name": "glass", "density": 2500.0}, {"name": "steel", "density": 7800.0}],
        "contacts": [{"materials": ["glass", "glass"], "en2": 0.5, "mu": 0.3, "kn": 1e4, "kt_over_kn": 0.5},
                     {"materials": ["glass", "steel"], "en2": 0.5, "mu": 0.3, "kn": 1e4, "kt_over_kn": 0.5}],
        "bodies": {"spheres": spheres},
        "walls": [{"type": "rectangle", "name": "floor", "material": "steel", "origin": [-0.5, -0.5, 0], "edge1": [1.0, 0, 0], "edge2": [0, 1.0, 0]}],
        "domain": {"lower": [-0.5, -0.5, -0.01], "upper": [0.5, 0.5, 0.1]},  # spheres roll: cocd has no rolling resistance
    })


def framed(case: Case, interval: float) -> Case:
    data = case.model_dump(mode="json")
    data["time"]["output_interval"] = interval
    return parse_case(data)


def timed(case: Case, interval: float) -> tuple[float, int]:
    """Wall time of one run and the number of checkpoints it wrote."""
    options = RunOptions(checkpoint_interval=interval)
    adapter = get_adapter(case.engine.value, options)
    plan = physics.schedule(case)
    every = adapter.checkpoint_steps(case, plan)
    with tempfile.TemporaryDirectory() as scratch:
        started = time.perf_counter()
        run_case(case, Path(scratch), Path(scratch) / "run", adapter=adapter)
        seconds = time.perf_counter() - started
    return seconds, 0 if every is None else plan.total_steps // every


def main() -> None:
    engines = os.environ.get("BENCH_ENGINES", "liggghts,yade,cocd").split(",")
    repeats = int(os.environ.get("BENCH_REPEATS", "3"))
    configurations = {"none": 0.0, "default (10 per run)": DURATION / 10, "every frame": 1e-9}
    rows = []
    for engine in engines:
        case = heap() if engine == "cocd" else framed(pile(engine, 0.001, duration=DURATION), 0.002)
        seconds: dict[str, list[float]] = {label: [] for label in configurations}
        written: dict[str, int] = {}
        for _ in range(repeats):
            for label, interval in configurations.items():
                wall, count = timed(case, interval)
                seconds[label].append(wall)
                written[label] = count
        median = {label: statistics.median(values) for label, values in seconds.items()}
        dense = "every frame"
        per_checkpoint = (median[dense] - median["none"]) / max(written[dense], 1)
        default_cost = 100.0 * CHECKPOINTS_PER_RUN * per_checkpoint / median["none"]
        rows.append({
            "engine": engine, "case": case.name, "spheres": sum(1 for _ in case.bodies.spheres) or 16 * len(case.bodies.clumps),
            "wall_s": {label: round(value, 3) for label, value in median.items()},
            "runs_s": {label: [round(v, 3) for v in values] for label, values in seconds.items()},
            "checkpoints": written,
            "default_measured_percent": round(100.0 * (median["default (10 per run)"] / median["none"] - 1.0), 2),
            "seconds_per_checkpoint": round(per_checkpoint, 4),
            "default_overhead_percent": round(default_cost, 2),
        })
        print(f"{engine}: {rows[-1]}", flush=True)
    out = REPO / "docs" / "benchmarks" / "checkpoint_cost.json"
    out.write_text(json.dumps({"measured": time.strftime("%Y-%m-%d"), "machine": platform.processor() or platform.machine(),
                               "cpus": os.cpu_count(), "duration_s": DURATION, "repeats": repeats, "rows": rows}, indent=2) + "\n")
    print("| engine | case | none (s) | default (s) | every frame (s) | s per checkpoint | default overhead |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        wall, count = row["wall_s"], row["checkpoints"]["every frame"]
        print(f"| {row['engine']} | {row['case']} | {wall['none']:.2f} | {wall['default (10 per run)']:.2f} | {wall['every frame']:.2f} ({count}) | "
              f"{row['seconds_per_checkpoint']:.4f} | {row['default_overhead_percent']:.2f} % |")


if __name__ == "__main__":
    main()
