"""Cost per step of the rounded box (pair_style roundedbox) on a packed slab: the first steps of a
release from a settled packing, one process, so that the contact search and forces of a dense pile
are what is timed (LIGGGHTS' own "Loop time", set-up excluded).

Run: .venv/bin/python benchmarks/rounded_box_step.py STUDY.yaml PACKING_DIR [STEPS]
(PACKING_DIR: a finished packing of that study, e.g. runs/<study>/../packings/<id>; STEPS default 300)
→ docs/benchmarks/rounded_box_step.json (BENCH_RESULT to change it), with the build key of the
contact code, seconds per step, and the positions after the last step in an .npz beside it, so two
builds of the contact code can be compared to round-off (`--compare OTHER.npz`). Time it with
nothing else running.
"""

from __future__ import annotations

import json
import os
import platform
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator import physics  # noqa: E402
from orchestrator.engines import RunOptions  # noqa: E402
from orchestrator.engines.liggghts import plugin  # noqa: E402
from orchestrator.results import RELEASE_DIR, read_results  # noqa: E402
from orchestrator.runner import run_case  # noqa: E402
from orchestrator.studies.avalanche.cases import packing_state_file, release_case  # noqa: E402
from orchestrator.studies.avalanche.study import load_study  # noqa: E402

RESULT = Path(os.environ.get("BENCH_RESULT", REPO / "docs" / "benchmarks" / "rounded_box_step.json"))
LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps")


def main(arguments: list[str]) -> None:
    compare = None
    if "--compare" in arguments:
        at = arguments.index("--compare")
        compare = Path(arguments[at + 1])
        arguments = arguments[:at] + arguments[at + 2:]
    study_path, packing = Path(arguments[0]), Path(arguments[1])
    steps = int(arguments[2]) if len(arguments) > 2 else 300
    study = load_study(study_path)
    packed = read_results(packing / "results.h5")
    case = release_case(study, packed, packing_state_file(study, packing))
    dt = physics.schedule(case).dt
    duration = steps * dt
    case = case.model_copy(update={"time": case.time.model_copy(update={"duration": duration, "output_interval": duration,
                                                                        "stop_at_rest": None})})
    with tempfile.TemporaryDirectory() as scratch:
        directory = Path(scratch)
        started = time.perf_counter()
        run_case(case, directory, directory / RELEASE_DIR, options=RunOptions(mpi_processes=1))
        wall = time.perf_counter() - started
        log = (directory / RELEASE_DIR / "engine.log").read_text()
        loops = [(float(seconds), int(count)) for seconds, count in LOOP.findall(log)]
        final = read_results(directory / RELEASE_DIR / "results.h5")
    loop_s = sum(seconds for seconds, _ in loops)
    loop_steps = sum(count for _, count in loops)
    positions = final.position[-1]
    record = {
        "date": time.strftime("%Y-%m-%d"),
        "study": str(study_path),
        "packing": str(packing),
        "bricks": int(final.n_bodies),
        "steps": loop_steps,
        "dt_s": dt,
        "contact_build": plugin.build_key(plugin.SUPERQUADRIC_SOURCES),
        "seconds_per_step": loop_s / loop_steps,
        "wall_s": wall,
        "machine": {"processor": platform.processor() or platform.machine(), "cpus": os.cpu_count()},
    }
    np.savez(RESULT.with_suffix(".npz"), position=positions, orientation=final.orientation[-1])
    if compare is not None:
        other = np.load(compare)
        record["compared_with"] = str(compare)
        record["largest_position_difference_m"] = float(np.nanmax(np.abs(positions - other["position"])))
    RESULT.write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
