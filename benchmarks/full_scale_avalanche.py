"""An avalanche set-up measured end to end: the full-scale random pour (cases/avalanche/random_pour_full.yaml)
by default, or any study given, e.g. the quarter set-up (cases/avalanche/random_pour_quarter.yaml).

Run: .venv/bin/python benchmarks/full_scale_avalanche.py [STUDY.yaml] → docs/benchmarks/full_scale.json,
the study's report (plots, HTML) under runs/full-scale/, and a progress log in runs/full-scale/progress.log.
It takes an hour or more: it is a measurement, not a test. Environment: BENCH_OUTPUT (study
directory, default runs/full-scale), BENCH_RESULT (the JSON), BENCH_ENGINE (override the study's
engine); DEMORCH_LIGGGHTS_MPI and DEMORCH_LIGGGHTS_GRID as for any run (the studies' default grid
splits across the flow: see studies/avalanche/study.py, AvalancheKind.processor_grid).

Why a script of its own: the figure users ask for is the wall time of the real thing (packing plus
release, until the deposit is at rest), with its steps per second and peak memory, on this machine.
The throughput benchmark only extrapolates that from short runs of smaller pours.
"""

from __future__ import annotations

import json
import os
import platform
import resource
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator import physics  # noqa: E402
from orchestrator.studies.avalanche.study import AvalancheStudy, load_study, run_study  # noqa: E402
from orchestrator.studies.seeds import member_seeds  # noqa: E402
from orchestrator.validation import with_engine  # noqa: E402
from orchestrator.engines import RunOptions  # noqa: E402
from orchestrator.results import read_results  # noqa: E402
from orchestrator.rundir import saved_case  # noqa: E402

STUDY = REPO / "cases" / "avalanche" / "random_pour_full.yaml"
RESULT = Path(os.environ.get("BENCH_RESULT", REPO / "docs" / "benchmarks" / "full_scale.json"))


def progress_logger(log: Path, started: float) -> Callable[[str], Callable[[float, float], None]]:
    """A progress factory for run_study that appends one line per simulated 1 % to `log`."""

    def stage(name: str) -> Callable[[float, float], None]:
        last = [-1]

        def report(done: float, total: float) -> None:
            percent = int(100 * done / total) if total else 100
            if percent > last[0]:
                last[0] = percent
                with log.open("a") as stream:
                    stream.write(f"{time.perf_counter() - started:9.1f} s  {name:8s} {percent:3d} %  ({done:.3f} / {total:.3f} s)\n")

        return report

    return stage


def stage_record(rundir: Path) -> dict[str, float]:
    """Steps, simulated time and engine wall time of one finished stage (run.json, case.json, results.h5): a stage
    that stopped at rest ran fewer steps than its schedule."""
    record = json.loads((rundir / "run.json").read_text())
    schedule = physics.schedule(saved_case(rundir))
    attrs = read_results(rundir / "results.h5").attrs
    simulated = float(attrs.get("stopped_at_rest", schedule.end_time))
    return {"steps": round(simulated / schedule.dt), "dt_s": schedule.dt, "simulated_s": simulated,
            "stopped_at_rest": "stopped_at_rest" in attrs, "engine_wall_s": record.get("engine_wall_time_s"),
            "wall_s": record.get("wall_time_s")}


def front_on_flat(front: dict[str, list[float]], every: float = 0.05) -> list[list[float]]:
    """[x, velocity] of the front on the flat board every `every` m (m, m/s): the velocity when the
    front first reaches each x, read off the front curve (report["front"])."""
    position, velocity = np.asarray(front["position"], dtype=float), np.asarray(front["velocity"], dtype=float)
    reached = np.fmax.accumulate(np.nan_to_num(position, nan=-np.inf))
    rows = []
    for x in np.arange(0.0, float(reached.max()) + 1e-9, every):
        first = int(np.argmax(reached >= x))
        rows.append([round(float(x), 3), round(float(velocity[first]), 4)])
    return rows


def main() -> None:
    """One record per seed: a study with `seeds:` is measured seed after seed (each in its own study
    directory, outdir/seed-N, and its own record, RESULT's name with _seedN), never two at once."""
    study_path = Path(sys.argv[1]) if len(sys.argv) > 1 else STUDY
    study = with_engine(load_study(study_path), os.environ.get("BENCH_ENGINE"))
    outdir = Path(os.environ.get("BENCH_OUTPUT", REPO / "runs" / "full-scale"))
    if study.seeds is None:
        measure(study, study_path, outdir, RESULT)
        return
    for seed in member_seeds(study.seed, study.seeds):
        member = study.model_copy(update={"seed": seed, "seeds": None})
        measure(member, study_path, outdir / f"seed-{seed}", RESULT.with_name(f"{RESULT.stem}_seed{seed}{RESULT.suffix}"))


def measure(study: AvalancheStudy, study_path: Path, outdir: Path, result_path: Path) -> None:
    """Run (or reuse) one study of one seed in `outdir` and write its record to `result_path`."""
    outdir.mkdir(parents=True, exist_ok=True)
    log = outdir / "progress.log"
    started = time.perf_counter()
    report = run_study(study, outdir, progress=progress_logger(log, started), packings=outdir / "packings")
    wall = time.perf_counter() - started
    release = read_results(outdir / "run" / "results.h5")
    speeds = np.linalg.norm(release.velocity[-1], axis=1)
    packing_dir = Path(report["packing"]["directory"])
    stages = {"packing": stage_record(packing_dir), "release": stage_record(outdir / "run")}
    trials = report["packing"].get("trials", [])
    # A stage made before (a reused packing, a finished release) counts with its recorded wall time;
    # the packing's time is that of all its density trials.
    ran_all = not report["finished_before"] and not any(t["reused"] for t in trials) and not report["packing"].get("reused")
    if not ran_all:
        wall = sum(t["wall_s"] for t in trials) + (stages["release"]["wall_s"] or 0.0)
    result = {
        "study": str(study_path.relative_to(REPO) if study_path.is_relative_to(REPO) else study_path),
        "date": time.strftime("%Y-%m-%d"),
        "seed": study.seed,
        "engine": study.engine.value,
        "bricks": release.n_bodies,
        "brick_kind": study.brick_spec.kind,
        "wall_s": wall,
        **stages,
        "peak_rss_children_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0 if ran_all else None,
        "final_max_speed_m_s": float(speeds.max()),
        "final_mean_speed_m_s": float(speeds.mean()),
        "deposit": report["deposit"],
        "front": {key: value for key, value in report.get("front", {}).items() if not isinstance(value, list)},
        "apparent_density": report["packing"]["apparent_density"],
        "packing_trials": trials,
        "packing_wall_s": sum(t["wall_s"] for t in trials),
        "initial": report.get("initial"),
        "overlaps": report.get("overlaps"),  # the packing's and the release's overlap audits (post.overlaps)
        "front_on_flat_every_5cm": front_on_flat(report["front"]),
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "python": platform.python_version()},
        "mpi_processes": RunOptions().processes(),
        "processor_grid": RunOptions(default_grid="1 * 1").grid(),
    }
    steps = (result["packing"]["steps"] or 0) + (result["release"]["steps"] or 0)
    result["steps_per_s"] = steps / wall if steps else None
    result_path.parent.mkdir(parents=True, exist_ok=True)
    result_path.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
