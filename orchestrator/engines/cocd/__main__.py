"""Run a COCD deck: `python -m orchestrator.engines.cocd deck.json` in the run directory.

Writes the deck's frame stream (frames.npy, the YADE adapter's format: time, then an (N, 16) array
per frame), cocd_stats.json (per step: contacts, solver iterations and seconds, and in 2D the
answer's relative primal and dual residuals and duality gap; the smallest gap seen), and prints
`DEMORCH_T <time>` lines for progress and `DEMORCH_DONE` at the end. With the deck's
`checkpoint_every`, the scene's arrays (and, in 2D, the last step's impulses by contact, the warm start)
are saved every so many steps as checkpoint.<step>.npz (the two newest kept); with `resume`, the
run continues from such a file.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from orchestrator.engines import checkpoint
from orchestrator.engines.cocd.solver import Scene, Walls, disc_mass, smallest_gap, step

STATS_NAME = "cocd_stats.json"


def load_scene(deck: dict) -> Scene:
    """The deck's scene; in 2D (planar) each grain becomes the disc of its radius (solver.disc_mass:
    the deck carries sphere masses), so the frames record kg per metre of thickness."""
    bodies = np.asarray(deck["bodies"], dtype=float)
    walls = deck["walls"]
    planar = bool(deck["planar"])
    return Scene(
        position=bodies[:, 2:5].copy(),
        velocity=bodies[:, 5:8].copy(),
        spin=bodies[:, 8:11].copy(),
        radius=bodies[:, 1].copy(),
        mass=disc_mass(bodies[:, 0], bodies[:, 1]) if planar else bodies[:, 0].copy(),
        material=bodies[:, 11].astype(int),
        fixed=bodies[:, 12].astype(bool),
        mu=np.asarray(deck["mu"], dtype=float),
        walls=Walls(
            origin=np.asarray([w["origin"] for w in walls], dtype=float).reshape(-1, 3),
            edge1=np.asarray([w["edge1"] for w in walls], dtype=float).reshape(-1, 3),
            edge2=np.asarray([w["edge2"] for w in walls], dtype=float).reshape(-1, 3),
            mu=np.asarray([w["mu"] for w in walls], dtype=float).reshape(len(walls), len(deck["mu"])),
            names=[w["name"] for w in walls],
            active=np.ones(len(walls), bool),
        ),
        gravity=np.asarray(deck["gravity"], dtype=float),
        planar=planar,
    )


def rest_of_discs(rest: dict | None, scene: Scene, deck: dict) -> dict | None:
    """The deck's rest settings with the moving mass M of the scene's grains: the deck gives the
    spheres' (the orchestrator's masses), a 2D scene weighs discs (load_scene)."""
    if not rest or not scene.planar:
        return rest
    moving = ~scene.fixed
    spheres = float(np.asarray(deck["bodies"], dtype=float)[moving, 0].sum())
    return {**rest, "mass": rest["mass"] * float(scene.mass[moving].sum()) / spheres}


def write_frame(stream, scene: Scene, now: float) -> None:
    rows = np.full((len(scene.mass), 16), np.nan)
    rows[:, 0] = np.arange(1, len(scene.mass) + 1)
    rows[:, 1], rows[:, 2] = scene.mass, scene.radius
    rows[:, 3:6], rows[:, 6:9], rows[:, 9:12] = scene.position, scene.velocity, scene.spin
    np.save(stream, np.array([now]))
    np.save(stream, rows)
    stream.flush()


def at_rest(scene: Scene, rest: dict | None, n: int) -> bool:
    """The case's time.stop_at_rest at the steps the orchestrator chose (first check, period)."""
    if not rest or n < rest["first"] or (n - rest["first"]) % rest["every"]:
        return False
    moving = ~scene.fixed
    squared = np.sum(scene.velocity[moving] ** 2, axis=1)
    speed = float(np.sqrt(np.sum(scene.mass[moving] * squared) / rest["mass"]))
    if rest["stray_fraction"] is None:
        resting = speed < rest["speed"]
    else:  # the bodies faster than "speed" weigh at most this fraction of M
        resting = np.sum(scene.mass[moving][squared > rest["speed"] ** 2]) <= rest["stray_fraction"] * rest["mass"]
    if not resting:
        return False
    print(f"DEMORCH_AT_REST step {n} speed {speed!r}", flush=True)
    return True


def save_checkpoint(scene: Scene, n: int, stats: dict) -> None:
    """The arrays that change, through a temporary file (a cut-off save never takes the name)."""
    with open("checkpoint.saving.npz", "wb") as handle:
        keys, impulses = scene.impulses if scene.impulses is not None else (np.zeros(0, np.int64), np.zeros((0, 2)))
        np.savez(handle, step=n, position=scene.position, velocity=scene.velocity, spin=scene.spin, active=scene.walls.active,
                 stats=json.dumps(stats), impulse_keys=keys, impulses=impulses)
    os.replace("checkpoint.saving.npz", f"checkpoint.{n}.npz")
    checkpoint.seal(Path("."), "npz", n)
    checkpoint.prune(Path("."), "npz")
    print(f"DEMORCH_CHECKPOINT step {n}", flush=True)


def load_checkpoint(scene: Scene, path: str) -> tuple[int, dict]:
    saved = np.load(path, allow_pickle=False)
    scene.position, scene.velocity, scene.spin = saved["position"].copy(), saved["velocity"].copy(), saved["spin"].copy()
    scene.walls.active = saved["active"].copy()
    if "impulse_keys" in saved.files and len(saved["impulse_keys"]):  # the warm start of the next step
        scene.impulses = (saved["impulse_keys"].copy(), saved["impulses"].copy())
    print(f"DEMORCH_RESUMED step {int(saved['step'])}", flush=True)
    return int(saved["step"]), json.loads(str(saved["stats"]))


def main(deck_path: str) -> None:
    deck = json.loads(Path(deck_path).read_text())
    scene = load_scene(deck)
    deck["rest"] = rest_of_discs(deck.get("rest"), scene, deck)
    checkpoint_every = deck.get("checkpoint_every")
    dt, total, every = deck["dt"], deck["total_steps"], deck["output_every"]
    removals: dict[int, list[int]] = {}
    for k, wall in enumerate(deck["walls"]):
        if wall["remove_step"] is not None:
            removals.setdefault(int(wall["remove_step"]), []).append(k)
    stats = {"contacts": [], "iterations": [], "solve_s": [], "primal": [], "dual": [], "gap": [], "missed": 0, "unresolved": 0, "smallest_gap": smallest_gap(scene), "wall_s": 0.0}
    first = 1
    if deck.get("resume"):
        done, stats = load_checkpoint(scene, deck["resume"])
        first = done + 1
    started = time.perf_counter()
    with open(deck["frames"], "wb") as frames:
        if first == 1:
            write_frame(frames, scene, 0.0)
        for n in range(first, total + 1):
            for k in removals.get(n - 1, []):
                scene.walls.active[k] = False
            try:
                result = step(scene, dt, deck["solver"], deck["tolerance"])
            except (RuntimeError, ArithmeticError) as error:  # a solver that stops short of the tolerance (mehrotra's NotConverged, Clarabel's status)
                print(f"ERROR: step {n}: the solver stopped short of cocd.tolerance {deck['tolerance']:g} ({str(error)[:200]}); "
                      "loosen cocd.tolerance (default 1e-8) or give another cocd.solver", flush=True)
                sys.exit(1)
            stats["contacts"].append(result.contacts)
            stats["iterations"].append(result.iterations)
            stats["solve_s"].append(result.solve_s)
            for measure in ("primal", "dual", "gap"):
                value = getattr(result, measure)  # NaN (3D, or no contacts) is written as null
                stats[measure].append(None if value != value else value)
            stats["missed"] += result.missed
            stats["unresolved"] += result.unresolved
            if result.unresolved:
                print(f"WARNING: step {n}: {result.unresolved} overlapping pairs were not candidates even after widening the search", flush=True)
            if not np.isfinite(scene.position).all():
                print("ERROR: non-finite positions: the solver diverged", flush=True)
                sys.exit(1)
            stats["smallest_gap"] = min(stats["smallest_gap"], result.smallest_gap)
            if n % every == 0:
                write_frame(frames, scene, n * dt)
                print(f"DEMORCH_T {n * dt!r}", flush=True)
                if at_rest(scene, deck.get("rest"), n):
                    total = n
                    break
            if checkpoint_every and n % checkpoint_every == 0 and n < total:
                save_checkpoint(scene, n, stats)
    stats["wall_s"] = time.perf_counter() - started
    Path(STATS_NAME).write_text(json.dumps(stats) + "\n")
    print(f"DEMORCH_STATS steps {total} wall {stats['wall_s']:.2f} s smallest gap {stats['smallest_gap']:.3e} m missed-and-redone {stats['missed']} unresolved {stats['unresolved']}")
    print("DEMORCH_DONE", flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
