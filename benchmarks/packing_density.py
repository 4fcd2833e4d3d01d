"""The apparent density the full-scale packings reach, against the experiment's.

Run: .venv/bin/python benchmarks/packing_density.py [STUDY.yaml ...] → docs/benchmarks/packing_density.json
(one entry per study, merged into what the file already holds). Default studies: the random pour
(`cases/avalanche/random_pour_full_kn2e4.yaml`) and the ordered pile (`ordered_pile_full.yaml`).
Only the packing stage runs, into BENCH_OUTPUT (default runs/packing-density), and a packing made
there before is reused. DEMORCH_LIGGGHTS_MPI and DEMORCH_LIGGGHTS_GRID as for any run.

The targets (Manzella & Labiouse 2009): 1000 kg/m³ poured, 1600 piled, in the 40-l release box; the
2012 study reached them by changing contact parameters while packing. A measurement, not a test: a
pour of 6 403 rounded bricks takes 52 min on 2 cores (2026-11-30).
"""

from __future__ import annotations

import datetime
import json
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.engines import RunOptions  # noqa: E402
from orchestrator.results import read_results  # noqa: E402
from orchestrator.runner import ensure_run  # noqa: E402
from orchestrator.studies.avalanche.geometry import apparent_density  # noqa: E402
from orchestrator.studies.avalanche.study import KIND, load_study, packing_case  # noqa: E402

STUDIES = [REPO / "cases" / "avalanche" / "random_pour_full_kn2e4.yaml", REPO / "cases" / "avalanche" / "ordered_pile_full.yaml"]
RESULT = Path(os.environ.get("BENCH_RESULT", REPO / "docs" / "benchmarks" / "packing_density.json"))


def measure(study_path: Path, root: Path) -> dict[str, object]:
    """Pack one study (or reuse its packing under `root`) and read the density of its last frame."""
    study = load_study(study_path)
    started = time.perf_counter()
    options = RunOptions(default_grid=KIND.processor_grid)
    directory, reused = ensure_run(packing_case(study), root, KIND.preparation, lambda d: KIND.state_file(study, d), None, None, options)
    wall = time.perf_counter() - started
    packed = read_results(directory / "results.h5")
    density = apparent_density(study.geometry.build(), packed.position[-1], packed.orientation[-1], study.brick_spec.build())
    record = json.loads((directory / "run.json").read_text())
    return {
        "date": datetime.date.today().isoformat(),
        "engine": study.engine.value,
        "kind": study.packing.kind,
        "bricks": packed.n_bodies,
        "packing_contacts": (study.packing.contacts or study.contacts).model_dump(),
        "brick_brick_mu_while_packing": study.packing.brick_brick_mu,
        "simulated_s": float(packed.time[-1]),
        "wall_s": None if reused else wall,
        "engine_wall_s": record.get("engine_wall_time_s"),
        "mpi_processes": options.processes(),
        "apparent_density": density,
        "target": study.target_density,
        "off": density / study.target_density - 1.0,
    }


def main() -> None:
    paths = [Path(p) for p in sys.argv[1:]] or STUDIES
    root = Path(os.environ.get("BENCH_OUTPUT", REPO / "runs" / "packing-density"))
    results = json.loads(RESULT.read_text()) if RESULT.exists() else {}
    for path in paths:
        name = str(path.resolve().relative_to(REPO)) if path.resolve().is_relative_to(REPO) else str(path)
        results[name] = measure(path, root)
        print(name, json.dumps(results[name], indent=2), flush=True)
        RESULT.parent.mkdir(parents=True, exist_ok=True)
        RESULT.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
