"""Engine throughput in a dense flow: brick resolution × contact law × processes, LIGGGHTS settings,
and a sphere collapse, per engine.

Run: .venv/bin/python benchmarks/flow_throughput.py  → docs/benchmarks/flow_throughput.json and
markdown tables on stdout. Give the machine to it (MPI ranks sharing a core slow several-fold).
Environment: BENCH_SWEEPS (default variants,settings,collapse), BENCH_ENGINES (default
liggghts,yade), BENCH_BRICKS (default 190), BENCH_LAYOUTS (default 4x2x1,6x3x2), BENCH_YADE_LAYOUTS
(default 4x2x1: a YADE packing of finer bricks takes tens of minutes here), BENCH_LAWS
(default bilinear,linear), BENCH_PROCESSES (LIGGGHTS; default 1,2), BENCH_WINDOW (simulated
seconds of flow measured; default 0.1).

Method. The bricks are settled once per resolution, law and engine (the full-scale box and boards,
Table 1 constants, 0.6 s or until at rest; the process counts share it), then the box opens and the first BENCH_WINDOW seconds of the release run: the bricks
pour out together, touching, as in the full-scale flow. The cost of a step is the engine's own time
loop over its step count (LIGGGHTS' "Loop time" lines, YADE's DEMORCH_LOOP_SECONDS): deck parsing,
clump insertion, MPI start and result collection are left out, and nothing is differenced (an
earlier method took the difference of two pour lengths; the cost per step rises as a pour fills
its box, which made its start-up come out negative).

`settings` varies LIGGGHTS' neighbour skin (in largest radii) and the output interval on the
4 × 2 × 1 bilinear flow; `collapse` times a half-size horizontal sphere collapse (R0 = 5 cm,
≈ 1 100 column grains and the glued bed) on each engine, LIGGGHTS on 1 and 2 processes.
"""

from __future__ import annotations

import json
import os
import platform
import re
import shutil
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator import physics  # noqa: E402
from orchestrator.case import RestStop  # noqa: E402
from orchestrator.studies.avalanche.study import AvalancheStudy, ContactSpec, packing_case, load_study, packing_state_file, release_case
from orchestrator.validation import with_engine  # noqa: E402
from orchestrator.studies.collapse.spec import load_collapse
from orchestrator.studies.collapse.cases import preparation_case  # noqa: E402
from orchestrator.studies.collapse.cases import release_case as collapse_release_case  # noqa: E402
from orchestrator.validation import with_engine as collapse_with_engine  # noqa: E402
from orchestrator.engines.liggghts import adapter as liggghts  # noqa: E402
from orchestrator.engines import RunOptions  # noqa: E402
from orchestrator.results import read_results  # noqa: E402
from orchestrator.runner import ensure_run  # noqa: E402
from orchestrator.results import RESULTS
from orchestrator.runner import run_case  # noqa: E402

FULL_SCALE = REPO / "cases" / "avalanche" / "random_pour_full.yaml"
HORIZONTAL = REPO / "cases" / "collapse" / "horizontal.yaml"
YADE_LOOP = re.compile(r"^DEMORCH_LOOP_SECONDS (\S+) steps (\d+)", re.MULTILINE)


def flow_study(bricks: int, engine: str, layout: tuple[int, int, int], law: str, window: float) -> AvalancheStudy:
    """The full-scale random pour (its box and boards) with `bricks` bricks, released for `window` s."""
    full = load_study(FULL_SCALE)
    packing = full.packing.model_copy(update={
        "volume": full.packing.volume * bricks / full.brick_count,
        "settle_time": 0.6,
        "stop_at_rest": RestStop(speed=0.01, after=0.4),
        # LIGGGHTS restarts need the packing's law in the flow (see AvalancheStudy's check)
        "contacts": ContactSpec(law=law),
    })
    release = full.release.model_copy(update={"duration": window, "stop_at_rest": None})
    return with_engine(full, engine).model_copy(update={
        "packing": packing, "release": release,
        "brick": full.brick.model_copy(update={"layout": layout}), "contacts": ContactSpec(law=law),
    })


def loop_time(rundir: Path, engine: str) -> tuple[float, int]:
    """(seconds, steps) of the engine's own time loop in a finished run."""
    if engine == "liggghts":
        runs = liggghts.loop_times((rundir / "log.liggghts").read_text())
    else:
        runs = YADE_LOOP.findall((rundir / "engine.log").read_text())
    if not runs:
        raise RuntimeError(f"no loop time in {rundir}")
    return sum(float(s) for s, _ in runs), sum(int(n) for _, n in runs)


def across_the_flow(processes: int) -> RunOptions:
    """LIGGGHTS on `processes` MPI ranks, the box split across the flow."""
    return RunOptions(mpi_processes=processes, default_grid="1 * 1")


def row(label: dict[str, object], rundir: Path, engine: str, spheres: int, dt: float) -> dict[str, object]:
    seconds, steps = loop_time(rundir, engine)
    per_step = seconds / steps
    result = {**label, "engine": engine, "spheres": spheres, "dt_s": dt, "steps": steps, "loop_s": seconds,
              "seconds_per_step": per_step, "sphere_steps_per_s": spheres / per_step, "wall_per_simulated_s": per_step / dt}
    print(json.dumps(result), flush=True)
    return result


def release_window(study: AvalancheStudy, scratch: Path, name: str, processes: int, adapter: object = None) -> tuple[Path, int, float]:
    """Run the release window of `study` (packing cached in scratch/packings); (run dir, spheres, Δt)."""
    packing_dir, _ = ensure_run(packing_case(study), scratch / "packings", "packing", lambda d: packing_state_file(study, d))
    packed = read_results(packing_dir / RESULTS)
    case = release_case(study, packed, packing_state_file(study, packing_dir))
    rundir = scratch / name
    shutil.rmtree(rundir, ignore_errors=True)
    run_case(case, scratch, rundir, adapter=adapter, options=across_the_flow(processes))
    spheres = sum(case.shape(c.shape).clump(case.material(c.material).density).n_spheres for c in case.bodies.clumps)
    return rundir, spheres, physics.schedule(case).dt


def variants(engines: list[str], bricks: int, layouts: list[tuple[int, int, int]], yade_layouts: list[tuple[int, int, int]],
             laws: list[str], processes: list[int], window: float, scratch: Path) -> list[dict[str, object]]:
    rows = []
    for engine in engines:
        for layout in layouts if engine == "liggghts" else yade_layouts:
            for law in laws:
                for count in processes if engine == "liggghts" else [1]:
                    label = {"sweep": "variants", "bricks": bricks, "layout": list(layout), "law": law, "processes": count}
                    name = f"{engine}-{'x'.join(map(str, layout))}-{law}-{count}"
                    rundir, spheres, dt = release_window(flow_study(bricks, engine, layout, law, window), scratch, name, count)
                    rows.append(row(label, rundir, engine, spheres, dt))
    return rows


def settings(bricks: int, window: float, scratch: Path) -> list[dict[str, object]]:
    """LIGGGHTS skin (largest radii) and output interval on the 4 × 2 × 1 bilinear flow, one process."""
    rows = []
    base = flow_study(bricks, "liggghts", (4, 2, 1), "bilinear", window)
    for skin in (0.5, 1.0, 2.0):
        rundir, spheres, dt = release_window(base, scratch, f"skin-{skin}", 1, adapter=liggghts.LiggghtsAdapter(skin_radii=skin))
        rows.append(row({"sweep": "settings", "skin_radii": skin, "output_interval": base.release.output_interval}, rundir, "liggghts", spheres, dt))
    for interval in (0.005, 0.001):
        study = base.model_copy(update={"release": base.release.model_copy(update={"output_interval": interval})})
        rundir, spheres, dt = release_window(study, scratch, f"output-{interval}", 1)
        rows.append(row({"sweep": "settings", "skin_radii": liggghts.deck.SKIN_RADII, "output_interval": interval}, rundir, "liggghts", spheres, dt))
    return rows


def collapse(engines: list[str], processes: list[int], window: float, scratch: Path) -> list[dict[str, object]]:
    """Half-size horizontal sphere collapse: the first `window` s after the gate opens, per engine."""
    rows = []
    for engine in engines:
        full = collapse_with_engine(load_collapse(HORIZONTAL), engine)
        column = full.column.model_copy(update={"length": 0.05, "height": 0.035})
        study = full.model_copy(update={"column": column, "channel": full.channel.model_copy(update={"length": 0.2}),
                                        "release": full.release.model_copy(update={"duration": window})})
        prepared = preparation_case(study)
        directory, _ = ensure_run(prepared, scratch / "preparations", "preparation")
        case = collapse_release_case(study, prepared, read_results(directory / RESULTS))
        for count in processes if engine == "liggghts" else [1]:
            rundir = scratch / f"collapse-{engine}-{count}"
            shutil.rmtree(rundir, ignore_errors=True)
            run_case(case, scratch, rundir, options=across_the_flow(count))
            mobile = sum(not s.fixed for s in case.bodies.spheres)
            label = {"sweep": "collapse", "grains": mobile, "glued": len(case.bodies.spheres) - mobile, "processes": count}
            rows.append(row(label, rundir, engine, len(case.bodies.spheres), physics.schedule(case).dt))
    return rows


def main() -> None:
    sweeps = os.environ.get("BENCH_SWEEPS", "variants,settings,collapse").split(",")
    engines = os.environ.get("BENCH_ENGINES", "liggghts,yade").split(",")
    bricks = int(os.environ.get("BENCH_BRICKS", 190))
    layouts = [tuple(int(n) for n in text.split("x")) for text in os.environ.get("BENCH_LAYOUTS", "4x2x1,6x3x2").split(",")]
    yade_layouts = [tuple(int(n) for n in text.split("x")) for text in os.environ.get("BENCH_YADE_LAYOUTS", "4x2x1").split(",")]
    laws = os.environ.get("BENCH_LAWS", "bilinear,linear").split(",")
    processes = [int(n) for n in os.environ.get("BENCH_PROCESSES", "1,2").split(",")]
    window = float(os.environ.get("BENCH_WINDOW", 0.1))
    scratch = Path(tempfile.mkdtemp(prefix="demorch-flow-"))
    rows: list[dict[str, object]] = []
    try:
        if "variants" in sweeps:
            rows += variants(engines, bricks, layouts, yade_layouts, laws, processes, window, scratch)
        if "settings" in sweeps:
            rows += settings(bricks, window, scratch)
        if "collapse" in sweeps:
            rows += collapse(engines, processes, window, scratch)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    result = {"machine": f"{platform.machine()} {os.cpu_count()} CPUs, {platform.platform()}", "window_s": window, "rows": rows}
    out = REPO / "docs" / "benchmarks"
    out.mkdir(parents=True, exist_ok=True)
    name = "flow_throughput.json" if set(sweeps) >= {"variants", "settings", "collapse"} else f"flow_throughput_{'_'.join(sweeps)}.json"
    (out / name).write_text(json.dumps(result, indent=2) + "\n")
    print("| sweep | engine | set-up | processes | spheres | Δt (s) | ms per step | sphere-steps/s | wall per simulated s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if r["sweep"] == "variants":
            setup = f"{' × '.join(map(str, r['layout']))} bricks, {r['law']}"
        elif r["sweep"] == "settings":
            setup = f"skin {r['skin_radii']} r, output every {r['output_interval']} s"
        else:
            setup = f"collapse, {r['grains']} grains + {r['glued']} glued"
        print(f"| {r['sweep']} | {r['engine']} | {setup} | {r['processes'] if 'processes' in r else 1} | {r['spheres']} | {r['dt_s']:.3g} | "
              f"{1e3 * r['seconds_per_step']:.3f} | {r['sphere_steps_per_s']:.3g} | {r['wall_per_simulated_s']:.0f} s |")


if __name__ == "__main__":
    main()
