"""Figures of column collapses: one run (front, velocity, profiles) and a slope × bed campaign (the
study's Figs 9 and 11: r_f(t)/R0 per slope with one curve per bed thickness, and front velocity)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize

from orchestrator.figures import subplots
import numpy as np
from scipy.ndimage import uniform_filter1d

from orchestrator.post.collapse import FRONT_WINDOW


def _mark_phases(axis: Any, front: dict[str, Any], key: str) -> None:
    """Vertical lines at the phase switches: end of acceleration, start of the slow phase, rest."""
    for name, label, style in (("t_max", "v max", "--"), ("t_slow", "slow phase", ":"), ("t_stop", "rest", "-.")):
        value = front.get(name)
        if name == "t_stop" and not front.get("at_rest"):
            continue  # still moving at the end: no rest to mark
        if value is not None and np.isfinite(value):
            axis.axvline(value, color="grey", linestyle=style, linewidth=1, label=label if key == "legend" else None)


def plot_run(report: dict[str, Any], arrays: dict[str, np.ndarray], path: Path) -> Path:
    """Front position and velocity against time, and the profile h(x) at a few instants."""
    study, front = report["study"], report["front"]
    r0 = study["column"]["length"]
    time = np.asarray(front["time"])
    figure, (top, middle, bottom) = subplots(3, 1, figsize=(7, 9), constrained_layout=True)
    top.plot(time, np.asarray(front["position"]) / r0, color="C0")
    top.set_ylabel("front r_f / R0")
    _mark_phases(top, front, "legend")
    top.legend(loc="lower right", fontsize=8)
    middle.plot(time, front["velocity"], color="C1")
    middle.set_ylabel("front velocity (m/s)")
    _mark_phases(middle, front, "")
    middle.set_xlabel("time since release (s)")
    edges, thickness = arrays["edges"], arrays["thickness"]
    centres = 0.5 * (edges[1:] + edges[:-1])
    for k in np.unique(np.linspace(0, len(thickness) - 1, 5).round().astype(int)):
        smooth = uniform_filter1d(thickness[k], size=FRONT_WINDOW, mode="nearest")  # the front's 3 d window
        bottom.plot(centres / r0, smooth * 1000, label=f"t = {arrays['time'][k]:.2f} s")
    bottom.axvline(0.0, color="grey", linewidth=1)
    bottom.set_xlabel("x / R0 (from the gate; the column starts at -1)")
    bottom.set_ylabel("thickness h (mm)")
    bottom.legend(fontsize=8)
    title = f"{study['name']}: α = {study['channel']['slope_deg']:g}°, h_i = {1000 * study['bed']['erodible_thickness']:g} mm, runout {report['runout_over_R0']:.2f} R0"
    figure.suptitle(title, fontsize=10)
    figure.savefig(path, dpi=120)
    return path


def plot_slope_bed(reports: list[dict[str, Any]], directory: Path) -> list[Path]:
    """r_f(t)/R0 and front velocity per slope (one panel each), one curve per bed thickness."""
    by_slope: dict[float, list[dict[str, Any]]] = {}
    for report in reports:
        by_slope.setdefault(float(report["study"]["channel"]["slope_deg"]), []).append(report)
    slopes = sorted(by_slope)
    written = []
    for quantity, label, name in (("position", "r_f / R0", "front_position.png"), ("velocity", "front velocity (m/s)", "front_velocity.png")):
        figure, axes = subplots(1, len(slopes), figsize=(4 * len(slopes), 3.6), sharey=True, squeeze=False, constrained_layout=True)
        for axis, slope in zip(axes[0], slopes):
            for report in sorted(by_slope[slope], key=lambda r: r["study"]["bed"]["erodible_thickness"]):
                front, study = report["front"], report["study"]
                values = np.asarray(front[quantity]) / (study["column"]["length"] if quantity == "position" else 1.0)
                axis.plot(front["time"], values, label=f"h_i = {1000 * study['bed']['erodible_thickness']:g} mm")
            axis.set_title(f"α = {slope:g}°")
            axis.set_xlabel("time (s)")
            axis.legend(fontsize=8)
        axes[0][0].set_ylabel(label)
        path = directory / name
        figure.savefig(path, dpi=120)
        written.append(path)
    return written


def plot_profiles(report: dict[str, Any], arrays: dict[str, np.ndarray], path: Path, curves: int = 12) -> Path | None:
    """u_x(z) (top row) and Φ(z) (bottom row) at each station, one curve per instant coloured by time
    (as the study draws them), the initial bed level dashed; at most `curves` instants per panel,
    those when the station had grains. None when there is no station."""
    fields, time = report["fields"], np.asarray(arrays["time"])
    z, ux, phi, stations = arrays["profile_z"] * 1000, arrays["profile_ux"], arrays["profile_phi"], arrays["stations"]
    r0 = report["study"]["column"]["length"]
    if len(stations) == 0:
        return None  # no station in the channel
    figure, axes = subplots(2, len(stations), figsize=(3.6 * len(stations), 7), sharey=True, squeeze=False, constrained_layout=True)
    colours = colormaps["viridis"]
    for s, station in enumerate(stations):
        filled = np.flatnonzero(np.nansum(phi[s], axis=1) > 0)
        for f in filled[np.unique(np.linspace(0, len(filled) - 1, min(curves, len(filled))).round().astype(int))] if filled.size else []:
            colour = colours(time[f] / max(time[-1], 1e-12))
            axes[0][s].plot(ux[s, f], z, color=colour, linewidth=1)
            axes[1][s].plot(phi[s, f], z, color=colour, linewidth=1)
        for row in (0, 1):
            axes[row][s].axhline(fields["initial_bed_level"] * 1000, color="grey", linestyle="--", linewidth=1)
        axes[0][s].set_title(f"x = {station * 100:.1f} cm ({station / r0:.2f} R0)", fontsize=9)
        axes[0][s].set_xlabel("u_x (m/s)")
        axes[1][s].set_xlabel("solid fraction Φ")
    axes[0][0].set_ylabel("z (mm)")
    axes[1][0].set_ylabel("z (mm)")
    mappable = ScalarMappable(norm=Normalize(0.0, float(time[-1])), cmap=colours)
    figure.colorbar(mappable, ax=axes[:, -1].tolist(), label="time (s)")
    figure.savefig(path, dpi=120)
    return path


def plot_waves(report: dict[str, Any], arrays: dict[str, np.ndarray], path: Path) -> Path | None:
    """The static/flowing interface near the front at the frame of the largest waves, over the grains
    (erodible-bed grains dark, the column's light) and the bed grains' velocity vectors (u_x, u_z):
    1 cm of arrow is 0.2 m/s."""
    waves = report["fields"]["waves"]
    if waves.get("frame") is None or "wave_grains" not in arrays:
        return None
    f = waves["frame"]
    grains, bed = arrays["wave_grains"], arrays["wave_bed"].astype(bool)
    x, interface = arrays["interface_x"], arrays["interface"][f]
    figure, axis = subplots(1, 1, figsize=(11, 3.6), constrained_layout=True)
    for mask, colour in ((~bed, "#cfcfcf"), (bed, "#7a7a7a")):
        axis.scatter(grains[mask, 0] * 100, grains[mask, 1] * 100, s=4, color=colour, linewidths=0)
    axis.quiver(grains[bed, 0] * 100, grains[bed, 1] * 100, grains[bed, 2], grains[bed, 3], color="C0", width=0.0015,
                angles="xy", scale_units="xy", scale=0.2)  # 1 cm of arrow: 0.2 m/s
    axis.plot(x * 100, interface * 100, color="C3", linewidth=1.5, label="static/flowing interface (u_x = 1 cm/s)")
    kh = waves.get("kelvin_helmholtz", {})
    axis.set_title(f"t = {arrays['time'][f]:.2f} s: λ = {100 * waves['wavelength_at_frame']:.1f} cm, A = {1000 * waves['amplitude_at_frame']:.1f} mm; "
                   f"u1 − u2 = {_cm(kh.get('shear'))} against √(gλ/2π (Φ2/Φ1 − Φ1/Φ2)) = {_cm(kh.get('threshold'))}", fontsize=9)
    axis.set_xlabel("x (cm from the gate)")
    axis.set_ylabel("z (cm)")
    axis.set_aspect("equal")
    axis.legend(fontsize=8, loc="upper left")
    figure.savefig(path, dpi=130)
    return path


def _cm(value: float | None) -> str:
    return "—" if value is None else f"{100 * value:.1f} cm/s"
