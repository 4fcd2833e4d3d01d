"""Pictures and pages of an avalanche run: what a person looks at before reading numbers.

All figures are matplotlib PNGs (orchestrator.figures: no pyplot, no display needed); `index.html` shows them with the
metrics table; `bodies_NNNN.vtu` (meshio) opens in ParaView.
"""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from orchestrator.shapes import BodyShape
from orchestrator.shapes.clump import quaternion_matrices
from orchestrator.figures import subplots
from orchestrator.post import deposit
from orchestrator.post.contacts import force_chains
from orchestrator.post.front import flat_phases
from orchestrator.results import Trajectory
from orchestrator.studies.avalanche.geometry import AvalancheGeometry

# The 2012 study's front phases on the flat (reference.toml, random_pour_findings), for the plot.
FLAT_PHASES = ((0.0, 0.2, "strong deceleration at impact"), (0.2, 0.6, "slow decrease"), (0.6, 0.8, "strong deceleration to stop"))


def phases_of(report: dict[str, Any]) -> dict[str, Any] | None:
    """The front's phases on the flat: stored in the report, or fitted now (reports written before they were)."""
    front = report["front"]
    if "flat_phases" in front:
        return front["flat_phases"]
    return flat_phases(np.asarray(front["position"], dtype=float), np.asarray(front["velocity"], dtype=float))


# Fig. 9 of the 2012 study, read off the figure (science brief): the experiment's mass at the opening,
# a slab of 40 l on the base of the 0.6 × 0.4 × 0.2 m box, for the full-scale set-up only.
FIG9_CENTRE = (-1.15, 1.27)  # m, (x, z) of the initial centre of mass
FIG9_REAR = (-1.41, 1.41)  # m, (x, z) of the upper end of the box's base, where φ_app starts


def _span(ranges: dict[str, Any], key: str) -> str:
    low, high = ranges[key]
    return f"{low:.3g}–{high:.3g} (study's code, {ranges.get('runs', '')} runs from the demo's earlier heap packing)"


def initial_rows(report: dict[str, Any], full_scale: bool) -> list[tuple[str, float, str, str]]:
    """The mass at the opening (report["initial"]) beside a slab filling the box's base and, at full
    scale, Fig. 9's reading; empty for reports written before it was measured."""
    initial = report.get("initial")
    if not initial:
        return []

    def beside(slab: float, fig9: float) -> str:
        return f"slab: {slab:.3f}" + (f"; Fig. 9: ≈ {fig9:g}" if full_scale else "")

    outside = initial["bodies_outside_box"]
    return [
        ("opening: centre of mass x (m)", initial["x_cm"], beside(initial["slab_x_cm"], FIG9_CENTRE[0]), ""),
        ("opening: centre of mass z (m)", initial["z_cm"], beside(initial["slab_z_cm"], FIG9_CENTRE[1]), ""),
        ("opening: rear of the base x (m)", initial["rear_x"], beside(initial["slab_rear_x"], FIG9_REAR[0]), ""),
        ("opening: rear of the base z (m)", initial["rear_z"], beside(initial["slab_rear_z"], FIG9_REAR[1]), ""),
        ("opening: bulk volume (l)", 1e3 * initial["bulk_volume"], "", ""),
        ("opening: bricks outside the box", outside, "0", "pass" if outside == 0 else "bricks stand above or outside the box"),
    ]


def comparison_rows(report: dict[str, Any], reference: dict[str, Any], demo: dict[str, Any] | None = None) -> list[tuple[str, float, str, str]]:
    """(metric, value, reference, verdict) rows. `demo`: the study's code's ranges for the demo
    ([low, high] per deposit metric), shown when the report is the demo's (same geometry and
    volume); Fig. 9's initial state when the geometry is the experiment's."""
    deposit = report["deposit"]
    findings = reference.get("avalanche", {}).get("manzella2009", {}).get("random_pour_findings", {})
    span = (lambda key: _span(demo, key)) if demo else (lambda key: "")
    height_note = f"DEM ≈ {1 + findings.get('height_overestimate_by_dem', 0.6):.1f} × experiment"
    rows = [
        ("L (m)", deposit["length"], span("length"), ""),
        ("R (m)", deposit["runout"], span("runout"), ""),
        ("W (m)", deposit["width"], span("width"), ""),
        ("H (m)", deposit["height"], span("height") or height_note, ""),
        ("X_CM (m)", deposit["x_cm"], span("x_cm"), ""),
        ("φ_CM (°)", deposit["travel_angle_cm_deg"], span("travel_angle_cm_deg"), ""),
        ("φ_app (°)", deposit["fahrboschung_deg"], span("fahrboschung_deg"), ""),
        ("outlier bricks", deposit["outliers"], "", ""),
        ("bricks left on the slope", deposit.get("bodies_on_slope", float("nan")), "", ""),
        ("bricks off the boards (lost)", deposit.get("bodies_lost", float("nan")), "", ""),
        ("front max speed (m/s)", report["front"]["max_velocity"], "", ""),
        ("front final position (m)", report["front"]["final_position"], "", ""),
    ]
    phases = phases_of(report)
    if phases is not None:
        bands = findings.get("front_phases_on_flat_m", [[0.0, 0.2], [0.2, 0.6], [0.6, 0.8]])
        rows += [
            ("front on flat: 1st switch x_1 (m)", phases["x_1"], f"≈ {bands[0][1]:g} (experiment, full scale)", ""),
            ("front on flat: 2nd switch x_2 (m)", phases["x_2"], f"≈ {bands[1][1]:g} (experiment, full scale)", ""),
            ("front on flat: stop (m)", phases["x_stop"], f"≈ {bands[2][1]:g} (experiment, full scale)", ""),
            ("front on flat: middle/first deceleration", phases["slope_2"] / phases["slope_1"] if phases["slope_1"] else float("nan"),
             "strong / slow / strong", "pass" if phases["strong_slow_strong"] else "not strong / slow / strong"),
        ]
    geometry = report.get("study", {}).get("geometry", {})
    full_scale = bool(geometry) and all(geometry.get(key) == getattr(AvalancheGeometry, key) for key in
                                        ("slope_deg", "launch_height", "box_depth", "box_width", "box_height"))
    rows += initial_rows(report, full_scale)
    packing = report.get("packing")
    if packing:
        target, value = packing["target_apparent_density"], packing["apparent_density"]
        floor = geometry.get("box_depth", EXPERIMENT_BOX[0]) * geometry.get("box_width", EXPERIMENT_BOX[1])
        tolerance = report.get("study", {}).get("packing", {}).get("density_search", {}).get("tolerance", DENSITY_TOLERANCE)
        rows.append(("apparent density (kg/m³)", value, f"{target:g} ± {tolerance:.0%} (the experiment's)",
                     packing_verdict(value, target, floor, tolerance)))
        if packing.get("trials"):
            rows.append(("μ brick/brick while packing", packing["brick_brick_mu"],
                         f"{len(packing['trials'])} trial(s): " + ", ".join(f"{t['mu']:.3g} → {t['apparent_density']:.0f}" for t in packing["trials"]), ""))
    return rows


# The experiment's release box floor (m; Manzella & Labiouse 2009, the set-up's defaults): the
# densities of its packings (1000 kg/m³ poured, 1600 piled) were reached in it.
EXPERIMENT_BOX = (AvalancheGeometry.box_depth, AvalancheGeometry.box_width)
DENSITY_TOLERANCE = 0.02  # relative: the density search's default (study.DensitySearchSpec)


def packing_verdict(value: float, target: float, floor: float, tolerance: float = DENSITY_TOLERANCE) -> str:
    """The check of a packing's apparent density (kg/m³) against its target, for a box floor of
    `floor` m². A box with a fraction of the experiment's floor packs looser than the experiment's
    (measured 2026-11-30 with Table 1 throughout: 933–958 kg/m³ in a quarter or an eighth of its floor,
    710–819 in the demo's sixteenth; docs/studies/avalanche.md), so a miss in a box of less than half the
    experiment's floor is said to be the box's."""
    off = value / target - 1.0
    if abs(off) <= tolerance:
        return "pass"
    share = EXPERIMENT_BOX[0] * EXPERIMENT_BOX[1] / floor
    if share >= 2.0:
        return f"off by {off:+.0%}: expected, a box 1/{share:.0f} of the experiment's floor packs looser (walls)"
    return f"off by {off:+.0%}"


FRAME = "x from the slope toe along the flow, y across it, z up from the board (m)"


def plot_deposit(trajectory: Trajectory, brick: BodyShape, path: Path, slope_deg: float = 45.0) -> None:
    """Thickness map of the deposit (gridded at half a brick width, contours every 5 mm) with its
    length L, runout R, width W and centre of mass marked, bodies outside it as crosses; below it,
    the longitudinal section. One frame for every position: FRAME."""
    final = trajectory.position[-1]
    members = deposit.deposit_members(final, trajectory.radius)
    metrics = deposit.deposit_metrics(trajectory.position[0], final, trajectory.mass, trajectory.radius, slope_deg=slope_deg)
    rotations = quaternion_matrices(np.nan_to_num(trajectory.orientation[-1, members], nan=1.0))
    vertices, _ = brick.surface_mesh(6)  # the bodies' surfaces, whatever their kind
    surface = final[members][:, None, :] + np.einsum("bij,vj->bvi", rotations, vertices)
    x_edges, y_edges, thickness = deposit.thickness_map(surface.reshape(-1, 3), np.zeros(surface.shape[0] * surface.shape[1]),
                                                        slope_deg, brick.extent[1] / 2)
    fig, (plan, section) = subplots(2, 1, figsize=(8, 9), constrained_layout=True, gridspec_kw={"height_ratios": [2, 1]})
    mesh = plan.pcolormesh(x_edges, y_edges, thickness.T * 1e3, cmap="YlOrBr", shading="flat")
    centres_x, centres_y = (x_edges[:-1] + x_edges[1:]) / 2, (y_edges[:-1] + y_edges[1:]) / 2
    levels = np.arange(5.0, max(10.0, np.nanmax(thickness) * 1e3), 5.0)
    plan.contour(centres_x, centres_y, np.nan_to_num(thickness.T * 1e3), levels=levels, colors="k", linewidths=0.5)
    fig.colorbar(mesh, ax=plan, label="thickness (mm)")
    proximal = metrics.runout - metrics.length
    plan.axvline(0.0, color="k", lw=0.8, ls="--", label="slope toe")
    plan.axvline(metrics.runout, color="tab:red", lw=1, label=f"R = {metrics.runout:.3f} m")
    plan.axvspan(proximal, metrics.runout, ymin=0, ymax=0.03, color="tab:blue", label=f"L = {metrics.length:.3f} m")
    ys = final[members, 1]
    plan.axhline(ys.min() - brick.bounding_radius, color="tab:green", lw=0.8)
    plan.axhline(ys.max() + brick.bounding_radius, color="tab:green", lw=0.8, label=f"W = {metrics.width:.3f} m")
    plan.plot([metrics.x_cm], [float(np.average(ys, weights=trajectory.mass[members]))], "k*", ms=10, label=f"centre of mass, x = {metrics.x_cm:.3f} m")
    strays = ~members & np.isfinite(final).all(axis=1)
    if strays.any():
        plan.plot(final[strays, 0], final[strays, 1], "x", color="grey", label=f"outside the deposit ({int(strays.sum())})")
    plan.set_aspect("equal", adjustable="datalim")
    plan.set_ylabel("y (m)")
    plan.legend(loc="upper left", fontsize=7)
    plan.set_title(f"Deposit thickness; frame: {FRAME}", fontsize=9)
    ok = np.isfinite(final).all(axis=1)
    section.scatter(final[ok, 0], final[ok, 2], s=4, color="tab:brown")
    left, right = min(final[ok, 0].min(), 0.0) - 0.05, final[ok, 0].max() + 0.05
    section.plot([left, 0.0, right], [-left * math.tan(math.radians(slope_deg)), 0.0, 0.0], color="k", lw=0.8)
    section.set_xlabel("x (m)")
    section.set_ylabel("z (m)")
    section.set_title("Longitudinal section (body centres)")
    fig.savefig(path, dpi=120)


def plot_front(report: dict[str, Any], path: Path) -> None:
    """Front position versus time, and front velocity versus front position on the flat board."""
    front = report["front"]
    time, position, velocity = (np.asarray(front[k], dtype=float) for k in ("time", "position", "velocity"))
    fig, (left, right) = subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    left.plot(time, position, color="tab:blue")
    left.axhline(0.0, color="k", lw=0.8, ls="--")
    left.set_xlabel("t (s)")
    left.set_ylabel("front x (m)")
    left.set_title("Mass front position")
    flat = position >= 0.0
    right.plot(position[flat], velocity[flat], color="tab:red", marker=".", label="simulated front")
    for start, end, label in FLAT_PHASES:
        right.axvspan(start, end, alpha=0.08, color="grey")
        right.text((start + end) / 2, 0.02, label, ha="center", va="bottom", fontsize=7, rotation=90, transform=right.get_xaxis_transform())
    phases = phases_of(report)
    if phases is not None:
        for key in ("x_1", "x_2"):
            right.axvline(phases[key], color="tab:red", lw=1, ls=":")
        right.plot([], [], color="tab:red", lw=1, ls=":", label=f"fitted switches: {phases['x_1']:.2f}, {phases['x_2']:.2f} m")
        right.legend(loc="upper right", fontsize=8)
    right.set_xlabel("front position on the flat board (m)")
    right.set_ylabel("front velocity (m/s)")
    right.set_title("Front velocity on the flat (cf. the 2012 study, Figs 12c/14c)")
    fig.savefig(path, dpi=120)


def plot_force_chains(trajectory: Trajectory, path: Path, frame: int = -1) -> None:
    """Force chains of one frame (default: the deposit), side (x, z) and plan (x, y) views: a segment
    joins the centres of two touching bricks, its width and colour the normal force between them
    (N, their sphere contacts summed). Same frame as the deposit picture: x from the slope toe,
    z above the board."""
    from matplotlib.collections import LineCollection

    assert trajectory.contacts is not None
    segments, force = force_chains(trajectory.contacts, trajectory.position, frame)
    z = trajectory.contacts.coordination(trajectory.position)[frame]
    fig, axes = subplots(2, 1, figsize=(10, 8), constrained_layout=True, gridspec_kw={"height_ratios": [1, 2]})
    centres = trajectory.position[frame]
    scale = float(force.max()) if len(force) else 1.0
    # Framed on the bricks that touch (5 cm around them); bricks elsewhere are left out of the frame.
    margin = 0.05
    low = segments.reshape(-1, 3).min(axis=0) - margin if len(force) else np.nanmin(centres, axis=0)
    high = segments.reshape(-1, 3).max(axis=0) + margin if len(force) else np.nanmax(centres, axis=0)
    views = (((0, 2), "z above the board (m), stretched", "auto"), ((0, 1), "y across the flow (m)", "equal"))
    framed = np.all((centres >= low) & (centres <= high), axis=1)
    for ax, ((a, b), label, aspect) in zip(axes, views):
        ax.scatter(centres[framed, a], centres[framed, b], s=3, color="0.75", zorder=1)
        if len(force):
            lines = LineCollection(segments[:, :, [a, b]], array=force, cmap="inferno_r", linewidths=0.5 + 3.0 * force / scale, zorder=2)
            ax.add_collection(lines)
        ax.autoscale_view()
        ax.set_aspect(aspect, adjustable="datalim")
        ax.set_xlabel("x from the slope toe (m)")
        ax.set_ylabel(label)
    if len(force):
        fig.colorbar(lines, ax=axes, label="normal force between two bricks (N)")
    axes[0].set_title(f"Force chains at t = {trajectory.time[frame]:.2f} s: {len(force)} touching pairs, coordination number {z:.2f}")
    fig.savefig(path, dpi=120)


def plot_snapshots(trajectory: Trajectory, outdir: Path, count: int = 6, slope_deg: float = 45.0) -> list[Path]:
    """Side views (x, z) at evenly spaced times, one PNG each, on common axes."""
    frames = np.unique(np.linspace(0, trajectory.n_frames - 1, count).round().astype(int))
    positions = trajectory.position
    ok = np.isfinite(positions[..., 0])
    xlim = (np.nanmin(positions[..., 0]) - 0.05, np.nanmax(positions[..., 0]) + 0.05)
    zlim = (-0.02, np.nanmax(positions[..., 2]) + 0.05)
    paths = []
    for frame in frames:
        fig, ax = subplots(figsize=(8, 3.2), constrained_layout=True)
        ax.plot([xlim[0], 0.0, xlim[1]], [max(-xlim[0], 0.0) * math.tan(math.radians(slope_deg)), 0.0, 0.0], color="k", lw=1)
        ax.scatter(positions[frame, ok[frame], 0], positions[frame, ok[frame], 2], s=4, color="tab:brown")
        ax.set_xlim(*xlim)
        ax.set_ylim(*zlim)
        ax.set_aspect("equal")
        ax.set_title(f"t = {trajectory.time[frame]:.2f} s")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("z (m)")
        path = outdir / f"snapshot_{frame:04d}.png"
        fig.savefig(path, dpi=100)
        paths.append(path)
    return paths


def export_vtk(trajectory: Trajectory, outdir: Path, every: int = 1) -> list[Path]:
    """One .vtu point cloud per frame (velocity, radius, mass as point data) for ParaView."""
    paths = []
    for frame in range(0, trajectory.n_frames, every):
        ok = np.isfinite(trajectory.position[frame, :, 0])
        points = trajectory.position[frame, ok]
        mesh = meshio.Mesh(
            points,
            [("vertex", np.arange(len(points)).reshape(-1, 1))],
            point_data={"velocity": trajectory.velocity[frame, ok], "radius": trajectory.radius[ok], "mass": trajectory.mass[ok]},
        )
        path = outdir / f"bodies_{frame:04d}.vtu"
        meshio.write(path, mesh)
        paths.append(path)
    return paths


def write_html(outdir: Path, title: str, rows: list[tuple[str, float, str, str]], images: list[Path]) -> Path:
    table = "\n".join(
        f"<tr><td>{html.escape(name)}</td><td>{value:.4g}</td><td>{html.escape(ref)}</td><td>{html.escape(verdict)}</td></tr>"
        for name, value, ref, verdict in rows
    )
    figures = "\n".join(f'<figure><img src="{html.escape(p.name)}" alt="{html.escape(p.stem)}"></figure>' for p in images)
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;margin:2em;max-width:1100px}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:4px 10px}}img{{max-width:100%}}figure{{margin:1em 0}}</style></head>
<body><h1>{html.escape(title)}</h1><p>Positions: {html.escape(FRAME)}.</p><table><tr><th>metric</th><th>value</th><th>reference</th><th>check</th></tr>
{table}</table>{figures}</body></html>"""
    path = outdir / "index.html"
    path.write_text(page)
    return path
