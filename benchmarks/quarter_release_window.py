"""Cost per step of the two one-particle bricks side by side on the avalanche: the first BENCH_WINDOW
(default 0.3) simulated seconds of the quarter set-up's release (cases/avalanche/random_pour_quarter.yaml),
the superquadric and the rounded box, each from its own packing, on 1 and 2 LIGGGHTS processes.

While the bricks are still packed the contacts are densest, so this window is where a brick's contact
search costs most; `full_scale_avalanche.py` gives the whole run. Each kind runs at its own automatic
step, so the figures compare the cost of one step; the record gives both steps and the wall time per
simulated second beside it.

Run: .venv/bin/python benchmarks/quarter_release_window.py → docs/benchmarks/quarter_release_window.json
and a markdown table on stdout. Packings are made once (2 processes) under BENCH_OUTPUT (default
runs/quarter-window/packings) and reused. Time it with nothing else running.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from full_scale_avalanche import stage_record  # noqa: E402
from orchestrator.engines import RunOptions  # noqa: E402
from orchestrator.studies.avalanche.study import load_study, run_study  # noqa: E402

STUDY = REPO / "cases" / "avalanche" / "random_pour_quarter.yaml"
RESULT = REPO / "docs" / "benchmarks" / "quarter_release_window.json"
KINDS = ("superquadric", "rounded_box")


def window_study(kind: str, window: float):
    """The quarter study with brick `kind`, its release cut to `window` s and run to the end."""
    study = load_study(STUDY)
    data = study.model_dump(mode="json", exclude_unset=True)
    data["brick"] = {**data.get("brick", {}), "kind": kind}
    data["release"] = {**data["release"], "duration": window}
    data["release"].pop("stop_at_rest", None)
    return type(study).model_validate(data)


def main() -> None:
    window = float(os.environ.get("BENCH_WINDOW", "0.3"))
    outdir = Path(os.environ.get("BENCH_OUTPUT", REPO / "runs" / "quarter-window"))
    rows = []
    for kind in KINDS:
        study = window_study(kind, window)
        for processes in (2, 1):  # 2 first: the packing is made on 2 processes, then reused
            run_dir = outdir / f"{kind}-{processes}"
            run_study(study, run_dir, packings=outdir / "packings",
                      options=RunOptions(mpi_processes=processes, default_grid="1 * 1", checkpoint_interval=0))
            stage = stage_record(run_dir / "run")
            row = {"kind": kind, "processes": processes, "dt_s": stage["dt_s"], "steps": stage["steps"],
                   "simulated_s": stage["simulated_s"], "engine_wall_s": stage["engine_wall_s"],
                   "ms_per_step": 1e3 * stage["engine_wall_s"] / stage["steps"],
                   "wall_s_per_simulated_s": stage["engine_wall_s"] / stage["simulated_s"]}
            rows.append(row)
            print(row, flush=True)
    record = {"date": time.strftime("%Y-%m-%d"), "what": f"the first {window} s of the quarter set-up's release "
              "(cases/avalanche/random_pour_quarter.yaml), each kind from its own packing, nothing else running",
              "machine": {"platform": platform.platform(), "cpus": os.cpu_count()}, "rows": rows}
    RESULT.write_text(json.dumps(record, indent=2) + "\n")
    by = {(r["kind"], r["processes"]): r for r in rows}
    print("| processes | superquadric ms/step | rounded box ms/step | ratio | s per simulated s (sq / rb) |\n|---|---|---|---|---|")
    for processes in (1, 2):
        sq, rb = by[("superquadric", processes)], by[("rounded_box", processes)]
        print(f"| {processes} | {sq['ms_per_step']:.2f} | {rb['ms_per_step']:.2f} | {rb['ms_per_step'] / sq['ms_per_step']:.2f} | "
              f"{sq['wall_s_per_simulated_s']:.0f} / {rb['wall_s_per_simulated_s']:.0f} |")


if __name__ == "__main__":
    main()
