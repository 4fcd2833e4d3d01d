"""Campaign orchestration overhead and parallel efficiency, and index speed at 10 000 runs.

Run: .venv/bin/python benchmarks/campaign_overhead.py  → writes docs/benchmarks/campaign_overhead.json
and prints a markdown table. Measured on the machine it runs on (its CPU count is recorded).

- overhead per run = wall time of a campaign of N runs with -j 1, minus the engines' own wall time
  (each run.json's engine_wall_time_s), divided by N; compared with a 30 s run (target ≤ 2 %).
- parallel efficiency on 2 workers = T(-j 1) / (2 × T(-j 2)) for the same runs (target ≥ 90 %).
- index: build_index over 10 000 synthetic completed runs (run.json + points), seconds.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.campaign import store  # noqa: E402
from orchestrator.campaign.execute import run_campaign  # noqa: E402


def campaign(directory: Path, runs: int, duration: float) -> Path:
    base = yaml.safe_load((REPO / "cases" / "free_fall.yaml").read_text())
    base["time"]["duration"] = duration
    (directory / "base.yaml").write_text(yaml.safe_dump(base))
    gravities = [-9.81 + 0.01 * i for i in range(runs)]
    spec = {"name": "bench", "base": "base.yaml", "designs": [{"kind": "grid", "parameters": {"gravity.2": gravities}}]}
    path = directory / "campaign.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


def timed_campaign(path: Path, out: Path, jobs: int) -> tuple[float, float]:
    started = time.perf_counter()
    run_campaign(path, out, jobs=jobs)
    wall = time.perf_counter() - started
    engine = sum(json.loads((d / "run.json").read_text())["engine_wall_time_s"] for d in (out / "runs").iterdir())
    return wall, engine


def index_speed(directory: Path, runs: int = 10_000) -> float:
    points = {}
    record = json.loads(next((directory / "j1" / "runs").iterdir()).joinpath("run.json").read_text())
    for i in range(runs):
        identifier = f"{i:016x}"
        run = directory / "big" / "runs" / identifier
        run.mkdir(parents=True)
        (run / "run.json").write_text(json.dumps(record))
        points[identifier] = {"gravity.2": -9.81 + i * 1e-4}
    store.write_points(directory / "big", points)
    started = time.perf_counter()
    table = store.build_index(directory / "big")
    assert len(table) == runs
    return time.perf_counter() - started


def main() -> None:
    runs, duration = int(os.environ.get("BENCH_RUNS", 12)), float(os.environ.get("BENCH_DURATION", 0.5))
    scratch = Path(tempfile.mkdtemp(prefix="demorch-bench-"))
    try:
        path = campaign(scratch, runs, duration)
        serial_wall, serial_engine = timed_campaign(path, scratch / "j1", 1)
        parallel_wall, _ = timed_campaign(path, scratch / "j2", 2)
        overhead = (serial_wall - serial_engine) / runs
        result = {
            "machine": f"{platform.machine()} {os.cpu_count()} CPUs, {platform.platform()}",
            "runs": runs,
            "engine": "liggghts",
            "mean_engine_wall_time_s": serial_engine / runs,
            "overhead_per_run_s": overhead,
            "overhead_share_of_30s_run": overhead / 30.0,
            "serial_wall_s": serial_wall,
            "parallel_wall_s_2_workers": parallel_wall,
            "parallel_efficiency_2_workers": serial_wall / (2.0 * parallel_wall),
            "index_10000_runs_s": index_speed(scratch),
        }
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    out = REPO / "docs" / "benchmarks"
    out.mkdir(parents=True, exist_ok=True)
    (out / "campaign_overhead.json").write_text(json.dumps(result, indent=2) + "\n")
    print("| quantity | value | target |\n|---|---|---|")
    print(f"| orchestration overhead per run | {result['overhead_per_run_s']:.3f} s ({100 * result['overhead_share_of_30s_run']:.2f} % of a 30 s run) | ≤ 2 % |")
    print(f"| parallel efficiency, 2 workers | {100 * result['parallel_efficiency_2_workers']:.1f} % | ≥ 90 % |")
    print(f"| index of 10 000 runs | {result['index_10000_runs_s']:.2f} s | fast |")
    print(f"| machine | {result['machine']} | |")


if __name__ == "__main__":
    main()
