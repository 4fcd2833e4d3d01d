"""Strong scaling of one avalanche release on 1 and 2 MPI processes (LIGGGHTS): the quarter set-up
(cases/avalanche/random_pour_quarter.yaml) by default, or any LIGGGHTS study given.

Run: .venv/bin/python benchmarks/strong_scaling.py [STUDY.yaml] → docs/benchmarks/strong_scaling.json
and a table on stdout. Give the machine to it (two ranks sharing a core with anything else slow
several-fold). Environment: BENCH_OUTPUT (directory, default runs/strong-scaling; the packing is made
once, on the largest process count, and shared), BENCH_RESULT (the JSON), BENCH_PROCESSES (default 1,2).

Method. The packing is made once; then the same release (its trap opened, run until the deposit is at
rest) runs on each process count from that packing, each in its own directory. A release goes in
sub-runs of one output interval; LIGGGHTS prints each sub-run's own time loop ("Loop time of … for N
steps"), so the engine's cost is read per stretch of the flow, not only in total: the speed-up is given
per step (the runs part ways, as any two chaotic runs do, and come to rest at different steps) over
the steps both ran: for the whole of them, their first and last tenths (the packed start and the
deposit coming to rest) and the rest (the mass flowing), from the loop times; and end to end, the
loops of those steps plus the release's overhead (its wall time less all its loops: start-up, the
set-up of each sub-run, the rest checks, writing the results) pro rata to them.
"""

from __future__ import annotations

import json
import os
import platform
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.engines import RunOptions  # noqa: E402
from orchestrator.engines.liggghts import adapter as liggghts  # noqa: E402
from orchestrator.studies.avalanche.study import KIND, load_study, run_study  # noqa: E402

STUDY = REPO / "cases" / "avalanche" / "random_pour_quarter.yaml"
RESULT = Path(os.environ.get("BENCH_RESULT", REPO / "docs" / "benchmarks" / "strong_scaling.json"))
PHASES = {"start (first tenth)": (0.0, 0.1), "flow": (0.1, 0.9), "end (last tenth)": (0.9, 1.0), "whole release": (0.0, 1.0)}


def loop_times(rundir: Path) -> list[tuple[float, int]]:
    """(seconds, steps) of each time loop of a finished LIGGGHTS run, in order, over all its logs."""
    loops: list[tuple[float, int]] = []
    for log in sorted(rundir.glob("log.liggghts*")):
        loops += liggghts.loop_times(log.read_text())
    return [loop for loop in loops if loop[1] > 0]


def phase_costs(loops: list[tuple[float, int]], common: int) -> dict[str, dict[str, float]]:
    """Engine seconds, steps and ms per step in each phase of PHASES, as fractions of the first `common`
    steps (those every process count ran: the runs part ways and come to rest at different steps)."""
    costs = {}
    for name, (low, high) in PHASES.items():
        seconds = steps = done = 0
        for loop_seconds, loop_steps in loops:
            middle = (done + loop_steps / 2) / common
            done += loop_steps
            if low <= middle < high:
                seconds += loop_seconds
                steps += loop_steps
        costs[name] = {"engine_s": seconds, "steps": steps, "ms_per_step": 1e3 * seconds / steps if steps else None}
    return costs


def main() -> None:
    study_path = Path(sys.argv[1]) if len(sys.argv) > 1 else STUDY
    study = load_study(study_path)
    counts = [int(n) for n in os.environ.get("BENCH_PROCESSES", "1,2").split(",")]
    outdir = Path(os.environ.get("BENCH_OUTPUT", REPO / "runs" / "strong-scaling"))
    packings = outdir / "packings"
    runs, loops = {}, {}
    # The packing on the largest count first (it is shared: its run id does not depend on processes).
    for count in sorted(counts, reverse=True):
        rundir = outdir / f"mpi{count}"
        options = RunOptions(mpi_processes=count, default_grid=KIND.processor_grid)
        report = run_study(study, rundir, packings=packings, options=options)
        record = json.loads((rundir / "run" / "run.json").read_text())
        loops[count] = loop_times(rundir / "run")
        runs[count] = {"wall_s": record.get("wall_time_s"), "engine_wall_s": record.get("engine_wall_time_s"),
                       "steps": sum(steps for _, steps in loops[count]), "deposit": report["deposit"], "grid": options.grid()}
    common = min(run["steps"] for run in runs.values())
    for count, run in runs.items():
        run["phases"] = phase_costs(loops[count], common)
        # End to end over the common steps: their loops, plus the release's own overhead (its wall time
        # less all its loops: start-up, set-ups between sub-runs, rest checks, results) pro rata.
        overhead = run["wall_s"] - sum(seconds for seconds, _ in loops[count])
        run["overhead_s"] = overhead
        run["ms_per_step_end_to_end"] = 1e3 * (run["phases"]["whole release"]["engine_s"] + overhead * common / run["steps"]) / common
    base = min(counts)
    for count, run in runs.items():
        run["speed_up"] = {name: runs[base]["phases"][name]["ms_per_step"] / phase["ms_per_step"]
                           for name, phase in run["phases"].items() if phase["ms_per_step"]}
        run["speed_up"]["end to end"] = runs[base]["ms_per_step_end_to_end"] / run["ms_per_step_end_to_end"]
    result = {"study": str(study_path.relative_to(REPO) if study_path.is_relative_to(REPO) else study_path),
              "bricks": study.brick_count, "brick_kind": study.brick_spec.kind, "base_processes": base,
              "common_steps": common, "runs": {str(count): run for count, run in sorted(runs.items())},
              "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "python": platform.python_version()}}
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps(result, indent=2) + "\n")
    print(f"ms per step over the first {common} steps (speed-up against {base} process)")
    print(f"| processes | {' | '.join(PHASES)} | end to end |\n|---|{'---|' * (len(PHASES) + 1)}")
    for count, run in sorted(runs.items()):
        cells = [f"{run['phases'][name]['ms_per_step']:.2f} ({run['speed_up'][name]:.2f} ×)" for name in PHASES]
        end = run["speed_up"]["end to end"]
        print(f"| {count} | {' | '.join(cells)} | {run['ms_per_step_end_to_end']:.2f} ({end:.2f} ×) |")

if __name__ == "__main__":
    main()
