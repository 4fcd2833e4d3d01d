"""Pictures and pages of an avalanche run: what a person looks at before reading numbers.

`write_report` makes a study directory's report/ (figures, snapshots, VTK, index.html with the table
of studies.avalanche.table) from its release's results and its report.json.

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
from orchestrator.shapes.rigid import quaternion_matrices
from orchestrator.figures import subplots
from orchestrator.post import deposit
from orchestrator.post.contacts import force_chains
from orchestrator.results import RELEASE_DIR, RESULTS, Trajectory, read_results, safe_output_path
from orchestrator.studies.avalanche.study import KIND
from orchestrator.studies.avalanche.table import FLAT_PHASES, Row, phases_of, report_experiment, study_rows

def write_report(outdir: Path, report: dict[str, Any]) -> Path:
    """Plots, snapshots, VTK and index.html for the study directory `outdir` (its report.json as
    `report`), drawn with the brick kind the run used; returns the page. CaseError when a link would
    take a figure out of the directory or the reference numbers cannot be read."""
    trajectory = read_results(outdir / RELEASE_DIR / RESULTS)
    figures = safe_output_path(outdir, "report")  # a link named report would take the figures out of the study directory
    figures.mkdir(exist_ok=True)
    for entry in list(figures.iterdir()):  # the writers below open their files by name: no link there may lead them out
        safe_output_path(figures, entry.name)
    study = KIND.parse(report["study"], str(outdir / "report.json"))
    slope_deg = study.geometry.slope_deg
    experiment = report_experiment(report)
    plot_deposit(trajectory, study.brick_spec.build(), figures / "deposit.png", slope_deg, experiment=experiment["experiment"] if experiment else None)
    plot_front(report, figures / "front.png")
    snapshots = plot_snapshots(trajectory, figures, slope_deg=slope_deg)
    export_vtk(trajectory, figures, every=max(1, trajectory.n_frames // 20))
    chains = [figures / "force_chains.png"] if trajectory.contacts is not None else []
    if chains:
        plot_force_chains(trajectory, chains[0])
    return write_html(figures, outdir.name, study_rows(report), [figures / "deposit.png", *chains, figures / "front.png", *snapshots],
                      [f"This engine's {study.brick_spec.kind} brick misses the study's brick on brick: {gap}" for gap in report.get("brick_gaps", [])])


FRAME = "x from the slope toe along the flow, y across it, z up from the board (m)"


def plot_deposit(trajectory: Trajectory, brick: BodyShape, path: Path, slope_deg: float = 45.0,
                 experiment: dict[str, float] | None = None) -> None:
    """Thickness map of the deposit (gridded at half a brick width, contours every 5 mm) with its
    length L, runout R, width W and centre of mass marked, bodies outside it as crosses; below it,
    the longitudinal section. One frame for every position: FRAME. experiment: the experiment's
    deposit (reference.toml [avalanche.manzella2009.deposit]: L, R, W, X_CM in m), drawn as the
    rectangle its L, R and W span about the axis, with its centre of mass."""
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
    if experiment is not None:
        from matplotlib.patches import Rectangle

        plan.add_patch(Rectangle((experiment["R"] - experiment["L"], -experiment["W"] / 2), experiment["L"], experiment["W"], fill=False,
                                 ls="--", lw=1.2, ec="k", label=f"experiment: L {experiment['L']:g}, R {experiment['R']:g}, W {experiment['W']:g} m"))
        plan.plot([experiment["X_CM"]], [0.0], "k+", ms=12, mew=1.5, label=f"experiment's centre of mass, x = {experiment['X_CM']:g} m")
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


def write_html(outdir: Path, title: str, rows: list[Row], images: list[Path], warnings: list[str] | None = None) -> Path:
    """index.html: the title, the warnings (one paragraph each), the metrics table, the figures."""
    notes = "".join(f'<p class="warning">{html.escape(text)}</p>' for text in warnings or [])
    table = "\n".join(
        f"<tr><td>{html.escape(name)}</td><td>{value:.4g}</td><td>{html.escape(ref)}</td><td>{html.escape(verdict)}</td></tr>"
        for name, value, ref, verdict in rows
    )
    figures = "\n".join(f'<figure><img src="{html.escape(p.name)}" alt="{html.escape(p.stem)}"></figure>' for p in images)
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;margin:2em;max-width:1100px}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:4px 10px}}img{{max-width:100%}}figure{{margin:1em 0}}.warning{{color:#8a5a00}}</style></head>
<body><h1>{html.escape(title)}</h1>{notes}<p>Positions: {html.escape(FRAME)}.</p><table><tr><th>metric</th><th>value</th><th>reference</th><th>check</th></tr>
{table}</table>{figures}</body></html>"""
    path = outdir / "index.html"
    path.write_text(page)
    return path
