"""The engine-neutral result store: one HDF5 file per run with per-body time series.

Layout (identical for every engine):
    /time                     (frames,)            s
    /bodies/id                (bodies,)            engine body id
    /bodies/material          (bodies,)            material name
    /bodies/mass              (bodies,)            kg
    /bodies/radius            (bodies,)            m (bounding radius for non-spheres)
    /bodies/inertia           (bodies, 3)          kg m², principal moments about the body axes
    /frames/position          (frames, bodies, 3)  m
    /frames/velocity          (frames, bodies, 3)  m/s
    /frames/angular_velocity  (frames, bodies, 3)  rad/s
    /frames/orientation       (frames, bodies, 4)  unit quaternion (w, x, y, z); NaN where the
                                                   engine does not track it (LIGGGHTS spheres)
Root attributes (ATTRIBUTES): format_version, engine, engine_version, case_name,
orientation_tracked (False where orientations are NaN); stopped_at_rest (s) and rest_speed (m/s)
when the run ended at rest. A body missing from a frame (lost by the engine) has NaN state there.
LAYOUT below is this table as data; a test reads a produced file against it.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

FORMAT_VERSION = 1
# What a run directory holds besides this file (rundir.py writes and checks them).
RESULTS = "results.h5"
RUN_RECORD = "run.json"  # the record: run_id, build, status, timings, metrics
CASE_COPY = "case.json"  # the validated inputs, canonical JSON


def read_json(path: Path) -> dict | None:
    """The JSON object in `path` (run.json, case.json, …), or None when it is missing, unreadable or
    not an object."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None

# dataset → (dtype kind, rank): f float, i integer, S bytes
LAYOUT: dict[str, tuple[str, int]] = {
    "time": ("f", 1),
    "bodies/id": ("i", 1),
    "bodies/material": ("S", 1),
    "bodies/mass": ("f", 1),
    "bodies/radius": ("f", 1),
    "bodies/inertia": ("f", 2),
    "frames/position": ("f", 3),
    "frames/velocity": ("f", 3),
    "frames/angular_velocity": ("f", 3),
    "frames/orientation": ("f", 3),
}
ATTRIBUTES = ("format_version", "engine", "engine_version", "case_name", "orientation_tracked")  # always written
REST_ATTRIBUTES = ("stopped_at_rest", "rest_speed")  # written when the run ended at rest


@dataclass
class Trajectory:
    """All frames of one run, arrays shaped as in the module docstring."""

    time: np.ndarray
    ids: np.ndarray
    material: np.ndarray
    mass: np.ndarray
    radius: np.ndarray
    inertia: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    orientation: np.ndarray
    attrs: dict[str, object] = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return int(self.time.shape[0])

    @property
    def n_bodies(self) -> int:
        return int(self.ids.shape[0])

    def validate(self) -> None:
        frames, bodies = self.n_frames, self.n_bodies
        expected = {
            "position": (frames, bodies, 3),
            "velocity": (frames, bodies, 3),
            "angular_velocity": (frames, bodies, 3),
            "orientation": (frames, bodies, 4),
        }
        for name, shape in expected.items():
            actual = getattr(self, name).shape
            if actual != shape:
                raise ValueError(f"trajectory {name} has shape {actual}, expected {shape}")
        for name in ("material", "mass", "radius"):
            if getattr(self, name).shape != (bodies,):
                raise ValueError(f"trajectory {name} must have one entry per body")
        if self.inertia.shape != (bodies, 3):
            raise ValueError("trajectory inertia must have three principal moments per body")


def write_results(path: Path, trajectory: Trajectory) -> None:
    """Write atomically (temp file + rename) so a crash never leaves a half-written results.h5."""
    trajectory.validate()
    temporary = path.with_name(path.name + ".tmp")
    with h5py.File(temporary, "w") as store:
        store.attrs["format_version"] = FORMAT_VERSION
        for key, value in trajectory.attrs.items():
            store.attrs[key] = value
        store.create_dataset("time", data=trajectory.time)
        bodies = store.create_group("bodies")
        bodies.create_dataset("id", data=trajectory.ids)
        bodies.create_dataset("material", data=trajectory.material.astype("S"))
        bodies.create_dataset("mass", data=trajectory.mass)
        bodies.create_dataset("radius", data=trajectory.radius)
        bodies.create_dataset("inertia", data=trajectory.inertia)
        frames = store.create_group("frames")
        chunk = lambda width: (1, trajectory.n_bodies, width)  # noqa: E731 - one frame per chunk
        for name, width in (("position", 3), ("velocity", 3), ("angular_velocity", 3), ("orientation", 4)):
            frames.create_dataset(name, data=getattr(trajectory, name), chunks=chunk(width) if trajectory.n_frames else None)
    os.replace(temporary, path)


def read_results(path: Path) -> Trajectory:
    with h5py.File(path, "r") as store:
        return Trajectory(
            time=store["time"][()],
            ids=store["bodies/id"][()],
            material=store["bodies/material"][()].astype(str),
            mass=store["bodies/mass"][()],
            radius=store["bodies/radius"][()],
            inertia=store["bodies/inertia"][()],
            position=store["frames/position"][()],
            velocity=store["frames/velocity"][()],
            angular_velocity=store["frames/angular_velocity"][()],
            orientation=store["frames/orientation"][()],
            attrs={key: _plain(value) for key, value in store.attrs.items()},
        )


def _plain(value: object) -> object:
    return value.item() if hasattr(value, "item") else value


def layout(path: Path) -> dict[str, tuple[str, int]]:
    """Dataset name → (dtype kind, rank): what 'same layout' means when comparing two runs."""
    found: dict[str, tuple[str, int]] = {}

    def visit(name: str, node: object) -> None:
        if isinstance(node, h5py.Dataset):
            found[name] = (node.dtype.kind, node.ndim)

    with h5py.File(path, "r") as store:
        store.visititems(visit)
    return found
