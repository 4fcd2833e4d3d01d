"""A record of a row of collapses (one slope, several bed thicknesses) against the erodible-bed study's
section 5 numbers (Martin et al. 2022, 2D simulations), and its section of the validation page.

`row_record` reads finished collapse studies (their report.json and the runs' run.json) into a
JSON-ready record: the set-up (N, d, R0, H0), the cost per run, the runout over R0 at the study's
times, the front phases, the waves and the Kelvin–Helmholtz numbers. Times and speeds scale with
the column: a collapse of height H0 runs on the time scale √(H0/g), so the study's instant t is
t √(R0 / R0_study) here (same a = H0/R0) and its speeds scale by the same factor.
`render_section` turns a record into Markdown lines, every number read from it.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

STUDY_R0 = 0.20  # m: the study's column length (H0 = 14 cm)
STUDY_TIMES = (0.5, 1.0, 1.5, 2.0)  # s: instants at which the row's runouts are compared (the study's clock)
STUDY_GAP_3_5 = {16.0: 0.10, 19.0: 0.30, 22.0: 1.10}  # (r_f(5 mm) − r_f(3 mm)) / R0, 2D
STUDY_SLOW_SPEED = 0.20  # m/s: slow-phase front speed at α = 22°, h_i = 10 mm
STUDY_WAVELENGTH = (0.07, 0.08)  # m: erosion waves in the experiments, in the simulations
STUDY_KH = (0.40, 0.24)  # m/s: the criterion's threshold, experiments and simulations
END_SPAN = 0.3  # s: the last part of a record over which the front's mean speed says whether it still moves
MOVING = 0.02  # m/s: a front faster than this at the end of the record still moves (post.collapse.REST_SPEED)


def _wall(directory: Path) -> float:
    """Engine wall time (s) of the run in `directory` (its run.json), NaN when unknown."""
    try:
        return float(json.loads((directory / "run.json").read_text())["engine_wall_time_s"])
    except (OSError, KeyError, ValueError):
        return math.nan


def run_entry(report: dict[str, Any], study_dir: Path) -> dict[str, Any]:
    """One collapse's line of the record (see the module docstring)."""
    study, front = report["study"], report["front"]
    r0 = study["column"]["length"]
    scale = math.sqrt(r0 / STUDY_R0)
    time, position = np.asarray(front["time"]), np.asarray(front["position"])
    at = {f"{t:g}": float(np.interp(t * scale, time, position) / r0) if t * scale <= time[-1] else None for t in STUDY_TIMES}
    waves = report.get("fields", {}).get("waves", {})
    preparation = Path(report.get("preparation", {}).get("directory", ""))
    return {
        "erodible_thickness": study["bed"]["erodible_thickness"],
        "grains": report["grains"],
        "cost_s": {"release": _wall(study_dir / "run"), "preparation": _wall(preparation) if preparation.name else math.nan,
                   "simulated_s": float(time[-1])},
        "runout_over_R0": report["runout_over_R0"], "runout_at_study_times": at, "reached_end": front["reached_end"],
        "end_speed": end_speed(time, position),
        "front": {k: front[k] for k in ("v_max", "t_max", "x_max", "slow_phase", "t_slow", "x_slow", "v_slow", "at_rest", "t_stop")},
        "waves": {k: waves.get(k) for k in ("wavelength_at_frame", "amplitude_at_frame", "median_wavelength",
                                              "median_wavelength_half_window", "wavelength_resolved")}
                 | {"time": float(time[waves["frame"]]) if waves.get("frame") is not None else None,
                    "kelvin_helmholtz": waves.get("kelvin_helmholtz")},
    }


def end_speed(time: np.ndarray, position: np.ndarray, span: float = END_SPAN) -> float:
    """Mean front speed (m/s) over the last `span` seconds of the record: whether the runout is final."""
    start = max(float(time[0]), float(time[-1]) - span)
    return float((position[-1] - np.interp(start, time, position)) / (time[-1] - start)) if time[-1] > start else 0.0


def row_record(study_dirs: list[Path]) -> dict[str, Any]:
    """The record of the collapses in `study_dirs` (each with a report.json), sorted by h_i; they
    must share the slope and the column."""
    reports = [(json.loads((d / "report.json").read_text()), d) for d in study_dirs]
    reports.sort(key=lambda item: item[0]["study"]["bed"]["erodible_thickness"])
    study = reports[0][0]["study"]
    slopes = {r["study"]["channel"]["slope_deg"] for r, _ in reports}
    if len(slopes) != 1:
        raise ValueError(f"study directories: one slope per row, got {sorted(slopes)}")
    return plain({
        "recorded": dt.date.today().isoformat(),
        "engine": study["engine"], "dimension": study["dimension"], "slope_deg": study["channel"]["slope_deg"],
        "column": study["column"], "grains": study["grains"], "channel_length": study["channel"]["length"],
        "contacts": study["contacts"], "step": study.get("cocd_step"), "time_scale": math.sqrt(study["column"]["length"] / STUDY_R0),
        "runs": [run_entry(report, directory) for report, directory in reports],
    })


def plain(value: Any) -> Any:
    """JSON-ready: NaN and infinities → None, numpy scalars → floats, recursively."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def _num(value: Any, scale: float = 1.0, digits: int = 2) -> str:
    return "—" if value is None else f"{value * scale:.{digits}f}"


def runout_order(record: dict[str, Any]) -> str:
    """The bed thicknesses from the shortest final runout to the longest, e.g. '5 < 3 < 0 mm'."""
    runs = sorted(record["runs"], key=lambda run: run["runout_over_R0"])
    return " < ".join(f"{1000 * run['erodible_thickness']:g}" for run in runs) + " mm"


def render_section(record: dict[str, Any]) -> list[str]:
    """The validation page's section of a row record: set-up and cost, then the row against the study."""
    r0, h0, d = record["column"]["length"], record["column"]["height"], record["grains"]["diameter"]
    scale = record["time_scale"]
    runs = record["runs"]
    lines = [f"## Column collapse on an erodible bed ({record['dimension']}D, α = {record['slope_deg']:g}°)", "",
             f"Recorded {record['recorded']} (`docs/collapse/disc2d22.json`, `demorch collapse record`): the erodible-bed study's "
             f"2D collapse on {record['engine']} (discs, inelastic contacts, μ = {record['contacts']['mu']:g}, Δt = {record['step']:g} s) "
             f"scaled to R0 × H0 = {100 * r0:g} × {100 * h0:g} cm with d = {1000 * d:g} mm (the study: 20 × 14 cm, d ≈ 1 mm). "
             f"Times and speeds scale by √(R0/20 cm) = {scale:.3f}: the study's t = 1 s is {scale:.3f} s here.", "",
             "| h_i (mm) | grains (column + bed) | cost (min: rain + release) | r_f/R0 at the study's " + ", ".join(f"{t:g}" for t in STUDY_TIMES)
             + " s | r_f/R0 at the end | v_max (m/s) | slow phase (m/s) | λ (cm): window / half | A (mm) | u1 − u2 (m/s) | KH threshold (m/s) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for run in runs:
        grains, cost, front, waves = run["grains"], run["cost_s"], run["front"], run["waves"]
        kh = waves.get("kelvin_helmholtz") or {}
        minutes = (cost["preparation"] or 0.0) / 60 + (cost["release"] or 0.0) / 60
        at = " / ".join(_num(v) for v in run["runout_at_study_times"].values())
        slow = _num(front["v_slow"], digits=3) if front["slow_phase"] else "none"
        lines.append(f"| {1000 * run['erodible_thickness']:g} | {grains['column']} + {grains['bed']} | {minutes:.1f} | {at} | "
                     f"{run['runout_over_R0']:.2f}{' (end wall)' if run['reached_end'] else ''}{_moving(run)} | {front['v_max']:.2f} | {slow} | "
                     f"{_num(waves['median_wavelength'], 100, 1)} / {_num(waves['median_wavelength_half_window'], 100, 1)}"
                     f"{'' if waves['wavelength_resolved'] else ' (follows the window)'} | {_num(waves['amplitude_at_frame'], 1000, 1)} | "
                     f"{_num(kh.get('shear'), digits=3)} | {_num(kh.get('threshold'), digits=3)} |")
    lines += [""] + _comparisons(record) + [""]
    return lines


def _moving(run: dict[str, Any]) -> str:
    speed = run.get("end_speed")
    return f" (moving, {speed:.2f} m/s)" if speed is not None and speed > MOVING else ""


def _comparisons(record: dict[str, Any]) -> list[str]:
    """Sentences setting the row against the study's numbers."""
    by_bed = {round(1000 * run["erodible_thickness"]): run for run in record["runs"]}
    scale = record["time_scale"]
    moving = [f"{1000 * run['erodible_thickness']:g}" for run in record["runs"] if _moving(run)]
    lines = [f"Runouts at the end of the record, shortest to longest: h_i = {runout_order(record)} (the study: the runout grows "
             f"with h_i)" + (f"; still moving at the end: h_i = {', '.join(moving)} mm, so those runouts are lower bounds." if moving else ".")]
    if 3 in by_bed and 5 in by_bed:
        gap = by_bed[5]["runout_over_R0"] - by_bed[3]["runout_over_R0"]
        lines.append(f"Gap r_f(5 mm) − r_f(3 mm): {gap:+.2f} R0 (the study at {record['slope_deg']:g}°: "
                     f"{STUDY_GAP_3_5.get(record['slope_deg'], math.nan):+.2f} R0).")
    slow = by_bed.get(10)
    if slow is not None:
        lines.append(f"Slow phase at h_i = 10 mm: {_num(slow['front']['v_slow'], digits=3)} m/s against the study's "
                     f"{STUDY_SLOW_SPEED:g} m/s × {scale:.3f} = {STUDY_SLOW_SPEED * scale:.3f} m/s at this scale.")
    lines.append(f"Erosion waves: the study's λ ≈ {100 * STUDY_WAVELENGTH[0]:g} cm (experiments) and {100 * STUDY_WAVELENGTH[1]:g} cm "
                 f"(simulations), KH threshold ≈ {STUDY_KH[0]:g} and {STUDY_KH[1]:g} m/s. λ here is the median over the frames "
                 "of the interface's dominant wavelength in the window behind the front, and again in the half of the window next "
                 "to the front: when the two differ by more than a quarter, λ follows the window (the trace has no length of its "
                 "own) and is not a wave's. A: the amplitude and KH: the criterion at the frame of the largest amplitude.")
    return lines
