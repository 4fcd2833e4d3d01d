"""Depth profiles of a granular flow at fixed stations: velocity u_x(z) and solid fraction Φ(z).

Martin et al. 2022, section 5 (the erodible-bed collapses): velocity profiles u_x(z) at three
stations along the channel over time, and the solid fraction of the flowing layer.

Coarse graining. A station is the window |x − x_s| ≤ w/2 of the channel; its grains are those whose
centre lies in the window. The height is cut into layers [z_k, z_k + Δz). Each grain contributes to
a layer the part of its measure lying in it: a disc of radius r centred at z_c (2D) covers the area
∫ 2 √(r² − (z − z_c)²) dz of the layer, a sphere (3D) the volume ∫ π (r² − (z − z_c)²) dz. Then

    Φ_k = Σ_i a_ik / (w Δz)        (2D: areas; 3D: volumes over w Δz W)
    u_k = Σ_i a_ik u_x,i / Σ_i a_ik   (measure-weighted mean velocity; NaN in an empty layer)

So a grain straddling two layers counts in both, and a layered packing gives a smooth Φ(z). Frame as
in `post.collapse`: x down the channel, z normal to the bed, lengths in m, velocities in m/s.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import curve_fit


def layer_measure(centre_z: np.ndarray, radii: np.ndarray, edges: np.ndarray, planar: bool) -> np.ndarray:
    """(grains, layers) area (2D, m²) or volume (3D, m³) of each grain between consecutive `edges` (m)."""
    t = np.clip(edges[None, :] - centre_z[:, None], -radii[:, None], radii[:, None]) / radii[:, None]
    r = radii[:, None]
    if planar:  # ∫_{-r}^{t r} 2 √(r² − s²) ds
        below = r**2 * (np.arcsin(t) + math.pi / 2 + t * np.sqrt(1.0 - t**2))
    else:  # ∫_{-r}^{t r} π (r² − s²) ds
        below = math.pi * r**3 * (t - t**3 / 3.0 + 2.0 / 3.0)
    return np.diff(below, axis=1)


def station_profile(x: np.ndarray, z: np.ndarray, ux: np.ndarray, radii: np.ndarray, station: float, width: float,
                    edges: np.ndarray, planar: bool, depth: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(u_x, Φ) per layer at one station, one instant (module docstring).

    x, z, ux, radii: (grains,) centres (m), velocities (m/s), radii (m); station, width: the window's
    centre and full width (m); edges: (layers + 1,) layer edges (m); depth: the channel width W (3D;
    1 in 2D). Returns two (layers,) arrays: u_x (m/s, NaN where the layer is empty) and Φ (1).
    """
    near = np.abs(x - station) <= width / 2
    measure = layer_measure(z[near], radii[near], edges, planar)
    total = measure.sum(axis=0)
    fraction = total / (width * np.diff(edges) * depth)
    with np.errstate(invalid="ignore", divide="ignore"):
        velocity = np.where(total > 0, (measure * ux[near, None]).sum(axis=0) / total, np.nan)
    return velocity, fraction


def station_profiles(positions: np.ndarray, velocities: np.ndarray, radii: np.ndarray, include: np.ndarray, stations: np.ndarray,
                     width: float, edges: np.ndarray, planar: bool, depth: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """u_x(z, t) and Φ(z, t) at every station: two (stations, frames, layers) arrays.

    positions, velocities: (frames, grains, 3); include: (grains,) the grains counted (e.g. the mobile
    ones: a glued bed is not part of the flow); stations: (S,) x of each station (m).
    """
    shape = (len(stations), len(positions), len(edges) - 1)
    velocity, fraction = np.full(shape, np.nan), np.zeros(shape)
    for f, (frame, speed) in enumerate(zip(positions, velocities)):
        keep = include & np.isfinite(frame).all(axis=1)
        for s, station in enumerate(stations):
            velocity[s, f], fraction[s, f] = station_profile(frame[keep, 0], frame[keep, 2], speed[keep, 0], radii[keep], station,
                                                             width, edges, planar, depth)
    return velocity, fraction


def flowing_layer_fraction(velocity: np.ndarray, fraction: np.ndarray, threshold: float = 0.01, filled: float = 0.1) -> tuple[float, float]:
    """(Φ of the flowing layer, Φ of the static layer) of one profile: the mean Φ over the layers
    whose u_x is at least `threshold` (1 cm/s, the rule of h_sf) and over those below it, counting
    only layers at least `filled` full (the free surface's sparse top layers are left out). NaN when
    a part is missing."""
    valid = np.isfinite(velocity) & (fraction >= filled)
    flowing, static = valid & (velocity >= threshold), valid & (velocity < threshold)
    return (float(fraction[flowing].mean()) if flowing.any() else math.nan,
            float(fraction[static].mean()) if static.any() else math.nan)


def fit_linear_shear(z: np.ndarray, ux: np.ndarray) -> tuple[float, float]:
    """Least-squares u_x = γ̇ (z − z_0): returns (γ̇ in 1/s, z_0 in m), the shear rate of a linear
    profile and the height where it extrapolates to rest (scipy.optimize.curve_fit)."""
    ok = np.isfinite(ux)
    slope, intercept = np.polyfit(z[ok], ux[ok], 1)
    (rate, base), _ = curve_fit(lambda h, g, h0: g * (h - h0), z[ok], ux[ok], p0=(slope, -intercept / slope if slope else 0.0))
    return float(rate), float(base)


def fit_exponential(z: np.ndarray, ux: np.ndarray, top: float) -> tuple[float, float]:
    """Least-squares u_x = u_s exp((z − top) / ℓ), the exponential tail of a surface flow over a
    static bed (GDR MiDi 2004; the creeping part of the study's profiles): returns (u_s in m/s, the
    decay length ℓ in m). `top`: the reference height (m), e.g. the free surface. The residuals are
    relative (u_x spans decades): the fast top layers do not outweigh the tail."""
    ok = np.isfinite(ux) & (ux > 0)
    slope, intercept = np.polyfit(z[ok] - top, np.log(ux[ok]), 1)  # the log-linear start
    (surface, length), _ = curve_fit(lambda h, u, ell: u * np.exp((h - top) / ell), z[ok], ux[ok], p0=(math.exp(intercept), 1.0 / slope),
                                      sigma=ux[ok])  # relative residuals: every decade of the tail counts
    return float(surface), float(length)
