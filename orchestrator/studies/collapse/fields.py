"""The flow's inner fields in a collapse (Martin et al. 2022, section 5): depth profiles u_x(z, t) and
Φ(z, t) at stations along the channel, and the erosion waves of the static/flowing interface near
the front with their Kelvin–Helmholtz criterion.

The study's stations are x = 29.5, 69.5 and 119.5 cm with its column over x = 0–20 cm (R0 = 20 cm),
i.e. 0.475, 2.475 and 4.975 R0 past the gate: the defaults, in units of R0, so they scale with the
column. The functions are those of `post.profiles` and `post.waves`; this module picks the grains,
the frames and the windows.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

import numpy as np
from pydantic import Field

from orchestrator.case import Real, Strict
from orchestrator.post import profiles as pf
from orchestrator.post import waves as wv

G = 9.81  # m/s²: the g of the study's Kelvin–Helmholtz criterion
STUDY_STATIONS = (0.475, 2.475, 4.975)  # × R0 past the gate (module docstring)
WINDOW_AGREEMENT = 0.25  # relative: λ over the whole window and over its half next to the front (window_check)


class FieldsSpec(Strict):
    """Where the depth profiles and the erosion waves are measured."""

    # x / R0 past the gate; None: the study's three scaled to the column (STUDY_STATIONS), those
    # that lie in the channel
    stations: Annotated[list[Real(unit="1", ge=-1.0, le=1000.0)], Field(min_length=1, max_length=20)] | None = None
    # × d: full width of a station's window. Grains count by their centre, so a window of n grains
    # wide holds its measure to about ±1/n per layer: 10 d keeps Φ(z) within ≈ 10 %.
    station_width: Real(unit="1", gt=0.0, le=100.0) = 10.0
    layer: Real(unit="1", ge=0.1, le=10.0) = 0.5  # × d: height of a profile's layers
    wave_window: Real(unit="1", gt=0.0, le=100.0) = 2.0  # × R0 behind the front: where the interface is traced


def station_positions(study: Any) -> np.ndarray:
    """x (m, from the gate) of the profile stations: `fields.stations` × R0, or the study's three
    (STUDY_STATIONS × R0) that lie in the channel."""
    r0 = study.column.length
    if study.fields.stations is not None:
        return np.asarray(study.fields.stations) * r0
    return np.array([x * r0 for x in STUDY_STATIONS if x * r0 <= study.channel.length])


def measure_fields(study: Any, position: np.ndarray, velocity: np.ndarray, radii: np.ndarray, mobile: np.ndarray, bed: np.ndarray,
                   times: np.ndarray, front: np.ndarray) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(report part, arrays) of the profiles and waves of one release; `study` a CollapseStudy,
    report: the stations, u_x(z, t) as `ux` and Φ(z, t) as `phi` ((stations, frames, layers) lists,
    m/s and 1, up to the highest layer reached; heights `z` in m), flowing/static Φ, the waves;
    position/velocity (frames, grains, 3), mobile (grains,) the grains that can flow, bed (grains,)
    the erodible layer's, front (frames,). Arrays: profile_z (layers,), profile_ux and profile_phi
    (stations, frames, layers), stations (S,), interface_x (slices,), interface (frames, slices),
    and at the wave frame the grains of the window: wave_grains (n, 5) x, z, u_x, u_z, r and
    wave_bed (n,) whether each began in the erodible layer."""
    d, r0, planar = study.grains.diameter, study.column.length, study.dimension == 2
    depth = 1.0 if planar else study.column.width
    spec = study.fields
    stations = station_positions(study)
    top = float(np.nanmax(position[0, mobile, 2] + radii[mobile]))
    edges = np.arange(0.0, top + spec.layer * d, spec.layer * d)
    ux, phi = pf.station_profiles(position, velocity, radii, mobile, stations, spec.station_width * d, edges, planar, depth)
    centres = 0.5 * (edges[1:] + edges[:-1])
    filled = np.flatnonzero(phi.max(axis=(0, 1)) > 0) if phi.size else np.zeros(0, int)  # layers some grain ever reached
    shown = slice(0, int(filled[-1]) + 1 if filled.size else 0)
    report: dict[str, Any] = {"stations": stations.tolist(), "station_width": spec.station_width * d, "layer_height": spec.layer * d,
                              "initial_bed_level": study.bed_top + study.bed.erodible_thickness,
                              "z": centres[shown].round(6).tolist(), "ux": _rounded(ux[:, :, shown], 5), "phi": _rounded(phi[:, :, shown], 4),
                              "flowing_fraction": [], "static_fraction": []}
    for s in range(len(stations)):
        pairs = [pf.flowing_layer_fraction(ux[s, f], phi[s, f]) for f in range(len(times))]
        report["flowing_fraction"].append([_plain(a) for a, _ in pairs])
        report["static_fraction"].append([_plain(b) for _, b in pairs])
    waves, interface, grid = measure_waves(study, position, velocity, radii, mobile, front)
    report["waves"] = waves
    arrays = {"profile_z": centres, "profile_ux": ux, "profile_phi": phi, "stations": stations,
              "interface_x": grid, "interface": interface}
    if waves["frame"] is not None:
        f = waves["frame"]
        x = position[f, :, 0]
        near = mobile & (x >= np.nanmin(grid[np.isfinite(interface[f])]) - d) & (x <= front[f] + d)
        arrays["wave_grains"] = np.column_stack([position[f, near][:, [0, 2]], velocity[f, near][:, [0, 2]], radii[near]])
        arrays["wave_bed"] = bed[near]
    return report, arrays


def measure_waves(study: Any, position: np.ndarray, velocity: np.ndarray, radii: np.ndarray, mobile: np.ndarray,
                  front: np.ndarray) -> tuple[dict[str, Any], np.ndarray, np.ndarray]:
    """The interface h_sf(x, t) on slices of one d over the channel, traced in the window behind the
    front; per frame its dominant wavelength and amplitude; the Kelvin–Helmholtz numbers at the frame
    of the largest amplitude. Returns (report, interface (frames, slices) with NaN outside the
    window, the slices' x)."""
    d, r0, planar = study.grains.diameter, study.column.length, study.dimension == 2
    grid = np.arange(0.5 * d, study.channel.length, d)
    window = study.fields.wave_window * r0
    interface = np.full((len(position), len(grid)), np.nan)
    wavelength, amplitude = np.full(len(position), np.nan), np.full(len(position), np.nan)
    for f, (frame, speed) in enumerate(zip(position, velocity)):
        inside = (grid >= front[f] - window) & (grid <= front[f]) & (grid >= 0.0)
        if inside.sum() < 8:
            continue
        keep = mobile & np.isfinite(frame).all(axis=1)
        interface[f, inside] = wv.interface_trace(frame[keep, 0], frame[keep, 2], speed[keep, 0], radii[keep], grid[inside], d)
        wavelength[f], amplitude[f] = wv.dominant_wave(grid[inside], interface[f, inside])
    report: dict[str, Any] = {"window": window, "wavelength": [_plain(v) for v in wavelength], "amplitude": [_plain(v) for v in amplitude],
                              "frame": None, **window_check(grid, interface, front, window, wavelength)}
    if np.isfinite(amplitude).any():
        f = int(np.nanargmax(amplitude))
        keep = mobile & np.isfinite(position[f]).all(axis=1)
        inside = np.isfinite(interface[f])
        layers = wv.layer_speeds_and_fractions(position[f, keep, 0], position[f, keep, 2], velocity[f, keep, 0], radii[keep],
                                               grid[inside], interface[f, inside], study.bed_top, planar,
                                               1.0 if planar else study.column.width)
        threshold = wv.kelvin_helmholtz_threshold(wavelength[f], layers["phi1"], layers["phi2"], G)
        shear = layers["u1"] - layers["u2"]
        report.update(frame=f, wavelength_at_frame=float(wavelength[f]), amplitude_at_frame=float(amplitude[f]),
                      kelvin_helmholtz={**{k: _plain(v) for k, v in layers.items()}, "g": G, "wavelength": float(wavelength[f]),
                                        "shear": _plain(shear), "threshold": _plain(threshold),
                                        "unstable": bool(math.isfinite(shear) and math.isfinite(threshold) and shear >= threshold)})
    return report, interface, grid


def window_check(grid: np.ndarray, interface: np.ndarray, front: np.ndarray, window: float, wavelength: np.ndarray) -> dict[str, Any]:
    """Whether the waves have a wavelength of their own: the median λ over the frames, measured again
    on the half of the window next to the front, must agree within WINDOW_AGREEMENT. A trace without
    a characteristic length (noise, whose spectrum rises towards long waves) gives a λ that follows
    the window instead."""
    half = np.full(len(interface), np.nan)
    for f, row in enumerate(interface):
        near = np.isfinite(row) & (grid >= front[f] - window / 2)
        if near.sum() >= 8:
            half[f] = wv.dominant_wave(grid[near], row[near])[0]
    full, short = (float(np.nanmedian(v)) if np.isfinite(v).any() else math.nan for v in (wavelength, half))
    agree = math.isfinite(full) and math.isfinite(short) and abs(full - short) <= WINDOW_AGREEMENT * full
    return {"median_wavelength": _plain(full), "median_wavelength_half_window": _plain(short), "wavelength_resolved": bool(agree)}


def _rounded(values: np.ndarray, digits: int) -> list:
    """Nested lists of `values` rounded to `digits` decimals, NaN → None (JSON)."""
    return np.where(np.isfinite(values), values.round(digits), None).tolist()


def _plain(value: float) -> float | None:
    """JSON-able: NaN → None."""
    return None if value is None or not math.isfinite(value) else float(value)


def field_metrics(report: dict[str, Any]) -> dict[str, float]:
    """The scalar numbers of the waves, flat, for campaign tables."""
    waves = report.get("fields", {}).get("waves", {})
    kh = waves.get("kelvin_helmholtz", {})
    values = {"waves.wavelength": waves.get("wavelength_at_frame"), "waves.median_wavelength": waves.get("median_wavelength"),
              "waves.amplitude": waves.get("amplitude_at_frame"), "waves.kh_shear": kh.get("shear"), "waves.kh_threshold": kh.get("threshold"),
              "waves.phi1": kh.get("phi1"), "waves.phi2": kh.get("phi2")}
    return {k: math.nan if v is None else float(v) for k, v in values.items()}
