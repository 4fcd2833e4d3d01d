"""Campaign orchestration overhead and parallel efficiency, and index speed at 10 000 runs.

Run: .venv/bin/python benchmarks/campaign_overhead.py  → writes docs/benchmarks/campaign_overhead.json
and prints a markdown table. Measured on the machine it runs on (its CPU count is recorded).

- overhead per run = wall time of a campaign of N runs with -j 1, minus the engines' own wall time
  (each run.json's engine_wall_time_s), divided by N; compared with a 30 s run (target ≤ 2 %).
- parallel efficiency on 2 workers = T(-j 1) / (2 × T(-j 2)) for the same runs (target ≥ 90 %).
  Two sets: short runs (a 0.5 s free fall, ≈ 0.4 s of engine time each: the worst case, where
  starting the worker pool weighs most) and long runs (the sphere-slope case over 9 s, ≈ 15 s each,
  closer to real campaign runs). BENCH_RUNS and BENCH_LONG_DURATION change them.
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


def campaign(directory: Path, runs: int, duration: float, base_case: str = "free_fall.yaml") -> Path:
    """N runs of a base case that differ only in gravity (so each is a distinct content-addressed run)."""
    directory.mkdir(parents=True, exist_ok=True)
    base = yaml.safe_load((REPO / "cases" / base_case).read_text())
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


def measure(scratch: Path, runs: int, duration: float, base_case: str) -> dict[str, float]:
    path = campaign(scratch, runs, duration, base_case)
    serial_wall, serial_engine = timed_campaign(path, scratch / "j1", 1)
    parallel_wall, _ = timed_campaign(path, scratch / "j2", 2)
    overhead = (serial_wall - serial_engine) / runs
    return {
        "case": base_case,
        "runs": runs,
        "simulated_s": duration,
        "mean_engine_wall_time_s": serial_engine / runs,
        "overhead_per_run_s": overhead,
        "overhead_share_of_30s_run": overhead / 30.0,
        "serial_wall_s": serial_wall,
        "parallel_wall_s_2_workers": parallel_wall,
        "parallel_efficiency_2_workers": serial_wall / (2.0 * parallel_wall),
    }


def main() -> None:
    runs = int(os.environ.get("BENCH_RUNS", 8))
    long_duration = float(os.environ.get("BENCH_LONG_DURATION", 9.0))
    scratch = Path(tempfile.mkdtemp(prefix="demorch-bench-"))
    try:
        short = measure(scratch / "short", runs, 0.5, "free_fall.yaml")
        long = measure(scratch / "long", runs, long_duration, "sphere_slope.yaml")
        result = {
            "machine": f"{platform.machine()} {os.cpu_count()} CPUs, {platform.platform()}",
            "engine": "liggghts",
            "short_runs": short,
            "long_runs": long,
            "index_10000_runs_s": index_speed(scratch / "short"),
        }
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    out = REPO / "docs" / "benchmarks"
    out.mkdir(parents=True, exist_ok=True)
    (out / "campaign_overhead.json").write_text(json.dumps(result, indent=2) + "\n")
    print("| quantity | short runs | long runs | target |\n|---|---|---|---|")
    print(f"| engine time per run | {short['mean_engine_wall_time_s']:.2f} s | {long['mean_engine_wall_time_s']:.2f} s | |")
    print(
        f"| orchestration overhead per run | {short['overhead_per_run_s']:.3f} s ({100 * short['overhead_share_of_30s_run']:.2f} % of 30 s)"
        f" | {long['overhead_per_run_s']:.3f} s ({100 * long['overhead_share_of_30s_run']:.2f} % of 30 s) | ≤ 2 % of a 30 s run |"
    )
    print(f"| parallel efficiency, 2 workers | {100 * short['parallel_efficiency_2_workers']:.1f} % | {100 * long['parallel_efficiency_2_workers']:.1f} % | ≥ 90 % |")
    print(f"| index of 10 000 runs | {result['index_10000_runs_s']:.2f} s | | fast |")
    print(f"| machine | {result['machine']} | | |")


if __name__ == "__main__":
    main()
