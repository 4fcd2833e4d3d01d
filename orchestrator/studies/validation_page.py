"""The validation page: the brick studies measured against their references, recorded from runs.

`record_runs` runs the checks on each engine and returns a record (JSON-ready): the date, the
engine versions, and per engine
- the four single-brick drops of the 2012 study (orchestrator.studies.brick_drop; reference: the
  same drops run with the study's own code, reference.toml [brick_drop.richefeu_code]), their
  metrics and the curves the figure draws;
- optionally the demo avalanche (cases/avalanche/small.yaml) over several seeds: its deposit
  metrics (reference: the demo's own slab packings released by the study's own code, reference.toml
  [avalanche.demo.richefeu_code_slab]);
- optionally `collapse`: the path of a collapse row's record (`demorch collapse record`, e.g.
  docs/collapse/disc2d22.json), rendered by studies.collapse.record.render_section.

`render_page` turns a record into the Markdown page and its figures: tables with the tolerance
and a verdict per engine. The committed docs/validation.md is render_page(docs/validation/record.json);
a test keeps them equal, so every number on the page comes from a recorded run.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from orchestrator.figures import subplots
from orchestrator.capabilities import capabilities
from orchestrator.studies import brick_drop
from orchestrator.studies.collapse.record import render_section
from orchestrator.studies.reference import demo_reference

REPO_ROOT = Path(__file__).resolve().parents[2]
CURVE_EVERY = 10  # frames of a drop (1e-4 s apart) per recorded curve point: 1 ms
DROPS = (("flat", "A"), ("flat", "B"), ("tilted", "A"), ("tilted", "B"))
DEMO_SEEDS = (2009, 2010, 2011)
DEMO_METRICS = (("length", "L (m)"), ("runout", "R (m)"), ("width", "W (m)"), ("height", "H (m)"), ("x_cm", "X_CM (m)"),
                ("travel_angle_cm_deg", "φ_CM (°)"), ("fahrboschung_deg", "φ_app (°)"))


@dataclass(frozen=True)
class DropCheck:
    """One measured quantity of a drop against the study's code: `measured(metrics)` and
    `expected(reference)` in the same unit, a miss when |measured − expected| > tolerance
    (relative when `relative`). Tolerances: the brick issue's acceptance for the compiled law."""

    label: str
    drop: str  # "flat_A", …
    measured: Callable[[dict[str, Any]], float]
    expected: Callable[[dict[str, Any]], float]
    tolerance: float
    relative: bool
    unit: str

    def passes(self, value: float, expected: float) -> bool:
        bound = self.tolerance * abs(expected) if self.relative else self.tolerance
        return math.isfinite(value) and abs(value - expected) <= bound

    @property
    def tolerance_text(self) -> str:
        return f"± {self.tolerance:.0%}" if self.relative else f"± {self.tolerance:g} {self.unit}"


def _at(key: str, index: int | None = None, scale: float = 1.0) -> Callable[[dict[str, Any]], float]:
    def pick(values: dict[str, Any]) -> float:
        value = values.get(key, math.nan)
        if index is not None:
            value = value[index] if isinstance(value, (list, tuple)) and len(value) > index else math.nan
        return float(value) * scale

    return pick


CHECKS = (
    DropCheck("flat A: 1st rebound ratio", "flat_A", _at("rebound_ratios", 0), lambda r: r["flat"]["rebound_ratio_A"][0], 0.01, True, ""),
    DropCheck("flat A: 2nd rebound ratio", "flat_A", _at("rebound_ratios", 1), lambda r: r["flat"]["rebound_ratio_A"][1], 0.01, True, ""),
    DropCheck("flat A: apex of the lowest point", "flat_A", _at("apex_lowest_point", scale=1e3), lambda r: 1e3 * r["flat"]["apex_lowest_point_A"], 0.03, True, "mm"),
    DropCheck("flat B: 1st rebound ratio", "flat_B", _at("rebound_ratios", 0), lambda r: r["flat"]["rebound_ratio_B"][0], 0.01, True, ""),
    DropCheck("flat B: 2nd rebound ratio", "flat_B", _at("rebound_ratios", 1), lambda r: r["flat"]["rebound_ratio_B"][1], 0.01, True, ""),
    DropCheck("flat B: apex of the lowest point", "flat_B", _at("apex_lowest_point", scale=1e3), lambda r: 1e3 * r["flat"]["apex_lowest_point_B"], 0.03, True, "mm"),
    DropCheck("tilted A: first contact", "tilted_A", _at("first_contact", scale=1e3), lambda r: 1e3 * r["tilted"]["first_contact_time"], 0.2, False, "ms"),
    DropCheck("tilted A: centre apex of the main rebound", "tilted_A", _at("centre_apex", scale=1e3), lambda r: 1e3 * r["tilted"]["A_centre_apex"][0], 0.10, True, "mm"),
    DropCheck("tilted A: second landing", "tilted_A", _at("second_landing", scale=1e3), lambda r: 1e3 * r["tilted"]["A_second_landing"], 5.0, False, "ms"),
    DropCheck("tilted B: at rest", "tilted_B", _at("rest_time", scale=1e3), lambda r: 1e3 * r["tilted"]["B_rest_time"], 30.0, False, "ms"),
    DropCheck("tilted B: horizontal travel", "tilted_B", _at("rest_travel", scale=1e3), lambda r: 1e3 * r["tilted"]["B_horizontal_travel"], 3.0, False, "mm"),
    DropCheck("tilted B: resting corners, mean distance to the study brick's", "tilted_B", _at("rest_corner_error", scale=1e3),
              lambda r: 0.0, 1.0, False, "mm"),
)
ROUNDED_BOX = "rounded box"  # the drops' column of an engine's rounded box: "ENGINE, rounded box"


# -- recording --------------------------------------------------------------------------------
def record_drops(engine: str, workdir: Path, kind: str = "clump") -> dict[str, Any]:
    """The four drops on one engine, of the study's brick as `kind` (the drop studies' rounded clump
    by default): {"flat_A": {"metrics": …, "time": […], "lowest": […], "centre_z": […]}, …}."""
    found: dict[str, Any] = {}
    for pose, constants in DROPS:
        key = f"{pose}_{constants}"
        metrics, drop = brick_drop.measure_drop(engine, brick_drop.study_brick(kind=kind), constants, pose == "tilted",
                                                workdir / engine / kind / key)
        every = slice(None, None, CURVE_EVERY)
        found[key] = {"metrics": _plain(metrics), "time": _rounded(drop.time[every], 4),
                      "lowest": _rounded(drop.lowest[every], 6), "centre_z": _rounded(drop.centre[every, 2], 6)}
    return found


def record_demo(engine: str, workdir: Path, seeds: tuple[int, ...] = DEMO_SEEDS) -> list[dict[str, Any]]:
    """The demo avalanche once per seed on one engine: its deposit metrics and apparent density."""
    from orchestrator.studies.avalanche.study import DEMO_STUDY as demo, load_study, run_study
    from orchestrator.validation import with_engine

    runs = []
    for seed in seeds:
        study = with_engine(load_study(demo), engine).model_copy(update={"seed": seed, "name": f"demo_{seed}"})
        report = run_study(study, workdir / engine / f"demo_{seed}", packings=workdir / "packings")
        runs.append({"seed": seed, "deposit": {k: float(report["deposit"][k]) for k, _ in DEMO_METRICS},
                     "apparent_density": float(report["packing"]["apparent_density"])})
    return runs


def record_runs(engines: dict[str, str], workdir: Path, demo: bool = False,
                progress: Callable[[str], None] = lambda stage: None) -> dict[str, Any]:
    """Run the checks on each engine (name → version). About a minute per engine for the drops;
    with `demo`, three demo avalanches per engine more (2–6 minutes each)."""
    today = dt.date.today().isoformat()
    record: dict[str, Any] = {"recorded": {name: today for name in engines}, "versions": engines, "drops": {}, "demo": {}}
    for engine in engines:
        progress(f"{engine}: single-brick drops")
        record["drops"][engine] = record_drops(engine, workdir)
        if "rounded_box" in capabilities(engine).shape_kinds:
            progress(f"{engine}: single-brick drops of the rounded box")
            record["drops"][f"{engine}, {ROUNDED_BOX}"] = record_drops(engine, workdir, "rounded_box")
        if demo:
            progress(f"{engine}: demo avalanche, seeds {', '.join(map(str, DEMO_SEEDS))}")
            record["demo"][engine] = record_demo(engine, workdir)
    return record


def merge_records(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """`new` (engines just recorded) over `old`: an engine not run again keeps its rows and its date,
    and what was recorded apart (the collapse row) stays."""
    recorded = old.get("recorded")
    if isinstance(recorded, str):  # a record of one date for all its engines
        recorded = {name: recorded for name in old.get("versions", {})}
    merged = {**old, **new}
    for key, earlier in (("recorded", recorded or {}), ("versions", old.get("versions", {})), ("drops", old.get("drops", {})),
                         ("demo", old.get("demo", {}))):
        merged[key] = {**earlier, **new.get(key, {})}
    return merged


def _measured(record: dict[str, Any]) -> str:
    """'liggghts VERSION (DATE), …': each engine with the version and the day its rows were recorded."""
    recorded = record["recorded"]
    return ", ".join(f"{name} {version} ({recorded if isinstance(recorded, str) else recorded.get(name, '?')})"
                     for name, version in record["versions"].items())


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    return float(value) if isinstance(value, (int, float, np.floating, np.integer)) else value


def _rounded(values: np.ndarray, digits: int) -> list[float]:
    return [round(float(v), digits) for v in values]


# -- the page ---------------------------------------------------------------------------------
def render_page(record: dict[str, Any], figures: Path, figures_link: str = "validation") -> str:
    """The Markdown page of a record; its figures are written into `figures` (linked as
    `figures_link`/NAME from the page)."""
    columns = list(record["drops"])  # each engine's default brick, then its rounded box where it has one
    reference = brick_drop.reference()
    lines = ["# Validation", "",
             f"Measured with `demorch validation` on {_measured(record)}"
             + ". Every number below is read from the recorded runs (`docs/validation/record.json`); "
             "the page is written from that record, never by hand. Engine parity on micro-cases "
             "(restitution, spin, friction) has its own page: [engine parity](parity.md).", ""]
    lines += ["## Single-brick drops", "",
              "The study's brick (31 × 15 × 8 mm, 1 mm rounded corners; the default brick of the brick studies) dropped on a "
              "plate, against the same drops run with the 2012 study's own code. Set A: the brick/support constants of "
              "Table 1; set B: the brick/brick constants put on the brick/plate pair. Flat: released at rest at "
              "z = 50 mm, largest face down; tilted: at z = 100 mm, turned by Ry(10°)·Rx(20°). The tolerances are "
              "those the compiled law must meet (LIGGGHTS); YADE runs the law as a calibrated dashpot, tuned for a "
              "flat landing (four corners at once), and is shown against the same tolerances. Columns named "
              f"“ENGINE, {ROUNDED_BOX}” drop the study's brick as its code models it (`kind: rounded_box`, "
              "[Bricks](bricks.md#the-rounded-box-the-studys-brick-as-the-study-models-it)).", ""]
    lines += ["| quantity | study's code | tolerance | " + " | ".join(columns) + " |", "|---|---|---|" + "---|" * len(columns)]
    for check in CHECKS:
        expected = check.expected(reference)
        cells = []
        for engine in columns:
            drops = record["drops"].get(engine, {})
            value = check.measured(drops[check.drop]["metrics"]) if check.drop in drops else math.nan
            cells.append("—" if not math.isfinite(value) else f"{value:.4g} {'✓' if check.passes(value, expected) else '✗'}")
        lines.append(f"| {check.label}{f' ({check.unit})' if check.unit else ''} | {expected:.4g} | {check.tolerance_text} | " + " | ".join(cells) + " |")
    flat = {engine: record["drops"][engine]["tilted_B"]["metrics"].get("lying_flat") for engine in columns}
    lines += ["", "Tilted B comes to rest lying flat (31 × 15 face down) in the study's code; here: "
              + ", ".join(f"{engine} {'yes' if value else 'no'}" for engine, value in flat.items()) + ".", ""]
    figures.mkdir(parents=True, exist_ok=True)
    _plot_drops(record, reference, figures / "brick_drops.png")
    lines += [f"![Single-brick drops]({figures_link}/brick_drops.png)", "",
              "Left: the brick's lowest point in the flat drop A, the study's apex after the first rebound dashed. "
              "Right: the brick's centre in the tilted drop A, the study's apex of the main rebound (cross) and second "
              "landing (dotted).", ""]
    if record.get("demo"):
        lines += _demo_section(record, figures, figures_link)
    if record.get("collapse"):  # the path (from the repository's root) of a collapse row's record
        lines += render_section(json.loads((REPO_ROOT / record["collapse"]).read_text()))
    return "\n".join(lines).rstrip() + "\n"


def _demo_section(record: dict[str, Any], figures: Path, figures_link: str) -> list[str]:
    reference = demo_reference()
    engines = [engine for engine in record["versions"] if engine in record["demo"]]
    seeds = sorted({run["seed"] for engine in engines for run in record["demo"][engine]})
    lines = ["## The demo avalanche against the study's code", "",
             f"The demo (`cases/avalanche/small.yaml`: 96 bricks, 0.4 m down the 45° slope) with seeds "
             f"{', '.join(map(str, seeds))} on each engine with its preferred brick ([Bricks](bricks.md#kinds-of-brick-clump-superquadric-or-rounded-box)), "
             f"beside the 2012 study's own code released from the demo's own slab packings (seeds "
             f"{min(reference['seeds'])}–{max(reference['seeds'])}, {reference['runs']} runs: each packing as it is and with every "
             "brick moved 1 µm, reference.toml [avalanche.demo.richefeu_code_slab]). Ranges are lowest–highest over the runs; "
             "✓: the engine's range overlaps the study code's.", "",
             "| metric | study's code | " + " | ".join(engines) + " |", "|---|---|" + "---|" * len(engines)]
    for key, label in DEMO_METRICS:
        low, high = reference[key]
        cells = []
        for engine in engines:
            values = [run["deposit"][key] for run in record["demo"][engine]]
            overlap = min(values) <= high and max(values) >= low
            cells.append(f"{min(values):.3g}–{max(values):.3g} {'✓' if overlap else '✗'}")
        lines.append(f"| {label} | {low:.3g}–{high:.3g} | " + " | ".join(cells) + " |")
    densities = {engine: [run["apparent_density"] for run in record["demo"][engine]] for engine in engines}
    lines += ["", "Apparent density of the packings (kg/m³; the experiment's random pour: 1000 in its 0.6 × 0.4 m box): "
              + ", ".join(f"{engine} {min(v):.0f}–{max(v):.0f}" for engine, v in densities.items())
              + ". The demo's box has 1/16 of that floor and packs looser; full-scale packings are on "
              "[Avalanche studies](studies/avalanche.md#packing-density).", ""]
    _plot_demo(record, reference, engines, figures / "avalanche_demo.png")
    lines += [f"![Demo deposits]({figures_link}/avalanche_demo.png)", "",
              "Each metric's runs, one row per engine and the study's code, scaled by the study code's midpoint.", ""]
    return lines


def _plot_drops(record: dict[str, Any], reference: dict[str, Any], path: Path) -> None:
    fig, (left, right) = subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    for engine, drops in record["drops"].items():
        left.plot(drops["flat_A"]["time"], 1e3 * np.asarray(drops["flat_A"]["lowest"]), label=engine)
        right.plot(drops["tilted_A"]["time"], 1e3 * np.asarray(drops["tilted_A"]["centre_z"]), label=engine)
    left.axhline(1e3 * reference["flat"]["apex_lowest_point_A"], color="k", ls="--", lw=0.8, label="study's code: apex")
    apex, at = reference["tilted"]["A_centre_apex"]
    right.plot([at], [1e3 * apex], "kx", ms=9, label="study's code: apex")
    right.axvline(reference["tilted"]["A_second_landing"], color="k", ls=":", lw=0.8, label="study's code: 2nd landing")
    right.set_xlim(0.12, 0.30)
    right.set_ylim(0.0, 40.0)
    left.set_title("Flat drop A: lowest point of the brick")
    right.set_title("Tilted drop A: centre of the brick")
    for ax, label in ((left, "lowest point above the plate (mm)"), (right, "centre above the plate (mm)")):
        ax.set_xlabel("t (s)")
        ax.set_ylabel(label)
        ax.legend(fontsize=8)
    fig.savefig(path, dpi=110)


def _plot_demo(record: dict[str, Any], reference: dict[str, Any], engines: list[str], path: Path) -> None:
    fig, axes = subplots(1, len(DEMO_METRICS), figsize=(12, 3.2), constrained_layout=True, sharey=True)
    rows = ["study's code", *engines]
    for ax, (key, label) in zip(axes, DEMO_METRICS):
        low, high = reference[key]
        mid = 0.5 * (low + high)
        ax.plot([low / mid, high / mid], [0, 0], color="k", lw=6, alpha=0.3)
        for row, engine in enumerate(engines, start=1):
            values = np.array([run["deposit"][key] for run in record["demo"][engine]]) / mid
            ax.plot(values, np.full(len(values), row), "o", ms=4, color=f"C{row}")
            ax.plot([values.min(), values.max()], [row, row], lw=1.5, color=f"C{row}")
        ax.axvspan(low / mid, high / mid, color="0.9", zorder=0)
        ax.set_title(label, fontsize=9)
        ax.set_yticks(range(len(rows)), rows)
        ax.set_ylim(-0.5, len(rows) - 0.5)
    fig.savefig(path, dpi=110)
