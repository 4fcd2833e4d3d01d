"""Erosion waves: the interface between flowing and static grains near the front, its wavelength and
amplitude, and the Kelvin–Helmholtz criterion (Martin et al. 2022, section 5).

Interface. h_sf(x) is the static/flowing interface of `post.collapse.static_flowing_interface` (the
top of the part where u_x < 1 cm/s, in layers of one d) read every `spacing` along x, here over a
window behind the front. Wavelength and amplitude. The trace is detrended (a straight line removed:
the deposit's slope), its periodogram (scipy.signal.periodogram, Hann window) gives the dominant
wavenumber, and a sine plus a line fitted from there (scipy.optimize.curve_fit) gives the wavelength
λ (m) and the amplitude A (m, half the crest-to-trough height).

Kelvin–Helmholtz. Two superposed layers, the upper (flowing) of solid fraction Φ1 moving at u1 over
the lower (static bed) of Φ2 at u2, are unstable at wavelength λ when (the study's eq. for its
erosion waves, the classical two-fluid result with densities in the ratio Φ2/Φ1)

    u1 − u2 ≥ √( g λ / (2π) · (Φ2/Φ1 − Φ1/Φ2) ).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import curve_fit
from scipy.signal import periodogram

from orchestrator.post.collapse import grain_measure, static_flowing_interface

MIN_WAVES = 1.5  # a wavelength counts only if the window holds at least this many


def interface_trace(x: np.ndarray, z: np.ndarray, ux: np.ndarray, radii: np.ndarray, stations: np.ndarray, diameter: float,
                    threshold: float = 0.01) -> np.ndarray:
    """(len(stations),) h_sf (m) at each x of `stations` (m), one instant; x, z, ux, radii: (grains,)
    of the grains that can flow (the glued bed left out). NaN where no grain is."""
    return np.array([static_flowing_interface(z, ux, x, radii, at, diameter, threshold) for at in stations])


def dominant_wave(stations: np.ndarray, height: np.ndarray) -> tuple[float, float]:
    """(λ in m, A in m) of the strongest undulation of `height` (m) sampled at evenly spaced
    `stations` (m): periodogram peak, then a sine + line least-squares fit (module docstring).
    NaN, NaN when fewer than 8 finite samples, a flat trace, or a peak longer than the window / 1.5."""
    ok = np.isfinite(height)
    if ok.sum() < 8:
        return math.nan, math.nan
    x, h = stations[ok], height[ok]
    spacing = float(np.median(np.diff(stations)))
    detrended = h - np.polyval(np.polyfit(x, h, 1), x)
    if np.ptp(detrended) == 0.0:
        return math.nan, math.nan
    grid = np.arange(x[0], x[-1] + spacing / 2, spacing)
    frequency, power = periodogram(np.interp(grid, x, detrended), fs=1.0 / spacing, window="hann", detrend=False)
    peak = 1 + int(np.argmax(power[1:]))
    guess = 1.0 / frequency[peak]
    if guess > (x[-1] - x[0]) / MIN_WAVES:
        return math.nan, math.nan

    def wave(s: np.ndarray, amplitude: float, wavelength: float, phase: float, level: float, slope: float) -> np.ndarray:
        return amplitude * np.sin(2 * math.pi * s / wavelength + phase) + level + slope * s

    start = (math.sqrt(2.0) * float(np.std(detrended)), guess, 0.0, float(np.mean(h)), 0.0)
    best = None
    for phase in np.linspace(0.0, 2 * math.pi, 4, endpoint=False):  # the phase's start: the fit is not convex in it
        try:
            params, _ = curve_fit(wave, x, h, p0=(*start[:2], phase, *start[3:]), maxfev=4000)
        except RuntimeError:
            continue
        error = float(np.sum((wave(x, *params) - h) ** 2))
        if best is None or error < best[0]:
            best = (error, params)
    if best is None or not 0.5 * guess < abs(best[1][1]) < 2.0 * guess:
        return guess, math.sqrt(2.0) * float(np.std(detrended))  # the periodogram's figures
    return float(abs(best[1][1])), float(abs(best[1][0]))


def kelvin_helmholtz_threshold(wavelength: float, phi_flowing: float, phi_static: float, g: float = 9.81) -> float:
    """The velocity difference (m/s) above which the interface is unstable at `wavelength` (m):
    √(g λ/(2π) (Φ2/Φ1 − Φ1/Φ2)), Φ1 the flowing layer's solid fraction, Φ2 the static bed's, g in
    m/s² (module docstring). 0 when Φ1 ≥ Φ2 (a denser layer on top is unstable at any shear);
    NaN when an input is NaN or a fraction is not positive."""
    if not all(math.isfinite(v) for v in (wavelength, phi_flowing, phi_static)) or min(phi_flowing, phi_static) <= 0:
        return math.nan
    contrast = phi_static / phi_flowing - phi_flowing / phi_static
    return math.sqrt(g * wavelength / (2 * math.pi) * contrast) if contrast > 0 else 0.0


def layer_speeds_and_fractions(x: np.ndarray, z: np.ndarray, ux: np.ndarray, radii: np.ndarray, stations: np.ndarray,
                               interface: np.ndarray, base: float, planar: bool, depth: float = 1.0) -> dict[str, float]:
    """u1, u2 (m/s) and Φ1, Φ2 (1) over a window: grains whose centre lies above the interface of
    their column (the x of `stations`, evenly spaced, ± half the spacing) are the flowing layer,
    those below it and above `base` (the top of the glued layer, m) the static bed. x, z, ux, radii:
    (grains,); interface: (len(stations),) h_sf (m). u: measure-weighted mean u_x. Φ: the layer's
    grain measure (disc areas in 2D; sphere volumes over the channel width `depth` in 3D) over its
    extent, Σ (free surface − h_sf) · spacing for the flowing layer and Σ (h_sf − base) · spacing for
    the static one; the free surface is the top of the column's highest grain."""
    spacing = float(stations[1] - stations[0])
    measure = grain_measure(radii, planar) / depth
    column = np.floor((x - stations[0]) / spacing + 0.5).astype(int)
    inside = (column >= 0) & (column < len(stations))
    column = np.where(inside, column, 0)
    level = np.where(inside, interface[column], np.nan)
    flowing, static = inside & (z >= level), inside & (z < level) & (z >= base)
    tops = np.full(len(stations), np.nan)
    np.fmax.at(tops, column[inside], z[inside] + radii[inside])
    ok = np.isfinite(interface) & np.isfinite(tops)
    flowing_area = float(np.sum(np.clip(tops[ok] - interface[ok], 0, None))) * spacing
    static_area = float(np.sum(np.clip(interface[ok] - base, 0, None))) * spacing

    def mean(mask: np.ndarray) -> float:
        return float(np.average(ux[mask], weights=measure[mask])) if mask.any() else math.nan

    return {"u1": mean(flowing), "u2": mean(static),
            "phi1": float(measure[flowing].sum() / flowing_area) if flowing_area > 0 else math.nan,
            "phi2": float(measure[static].sum() / static_area) if static_area > 0 else math.nan}
