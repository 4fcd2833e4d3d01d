"""What recording body states costs inside YADE, against the bare run (target ≤ 10 %).

Run: .venv/bin/python benchmarks/yade_recording.py  → docs/benchmarks/yade_recording.json and a table.

The case: the packing stage of a random pour of N bricks (4 × 2 × 1 clumps) in the full-scale release
box on 1.5 m boards, 0.1 simulated seconds. Recorded: one frame per `output_interval` (the YADE
script's in-loop PyRunner writes every body's state to frames.npy). Bare: the same run with one
interval as long as the run (two frames: start and end). Cost = (recorded − bare) / bare, for the
default interval of the avalanche studies (0.02 s) and a ten times denser one (0.002 s); each
configuration runs BENCH_REPEATS times (default 3) and its fastest run counts.
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

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from engine_throughput import study_of  # noqa: E402

from orchestrator.studies.avalanche.study import packing_case  # noqa: E402
from orchestrator.runner import run_case  # noqa: E402

DURATION = 0.1
REPEATS = int(os.environ.get("BENCH_REPEATS", 3))


def wall_time(bricks: int, interval: float, directory: Path) -> float:
    case = packing_case(study_of(bricks, "yade", DURATION))
    case = case.model_copy(update={"time": case.time.model_copy(update={"output_interval": interval})})
    started = time.perf_counter()
    run_case(case, directory, directory / "run")
    return time.perf_counter() - started


def main() -> None:
    sizes = [int(s) for s in os.environ.get("BENCH_SIZES", "95,380").split(",")]
    scratch = Path(tempfile.mkdtemp(prefix="demorch-yade-rec-"))
    rows = []
    try:
        for bricks in sizes:
            # Run-to-run noise here is ±10 %: each configuration runs REPEATS times, interleaved,
            # and the fastest of each counts.
            timings: dict[float, list[float]] = {DURATION: [], 0.02: [], 0.002: []}
            for repeat in range(REPEATS):
                for interval in timings:
                    timings[interval].append(wall_time(bricks, interval, scratch / f"{bricks}-{interval}-{repeat}"))
            bare = min(timings[DURATION])
            for interval in (0.02, 0.002):
                recorded = min(timings[interval])
                rows.append({"bricks": bricks, "output_interval_s": interval, "frames": round(DURATION / interval) + 1,
                             "bare_s": bare, "recorded_s": recorded, "cost": (recorded - bare) / bare})
                print(json.dumps(rows[-1]), flush=True)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    out = REPO / "docs" / "benchmarks"
    out.mkdir(parents=True, exist_ok=True)
    result = {"machine": f"{platform.machine()} {os.cpu_count()} CPUs, {platform.platform()}", "simulated_s": DURATION, "rows": rows}
    (out / "yade_recording.json").write_text(json.dumps(result, indent=2) + "\n")
    print("| bricks | output interval | frames | bare run | with recording | recording cost |\n|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['bricks']} | {r['output_interval_s']} s | {r['frames']} | {r['bare_s']:.1f} s | {r['recorded_s']:.1f} s | {100 * r['cost']:+.1f} % |")


if __name__ == "__main__":
    main()
