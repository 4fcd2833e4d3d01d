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
With contacts recorded (the case's `record_contacts`), also (CONTACT_LAYOUT):
    /contacts/offset          (frames + 1,)        rows of frame f are offset[f]:offset[f+1]
    /contacts/body            (rows, 2)            the two bodies' indices in /bodies (0-based);
                                                   the second is -1 for a wall
    /contacts/wall            (rows,)              the wall's index in the case's `walls`, -1 for a
                                                   body–body contact
    /contacts/point           (rows, 3)            m, contact point
    /contacts/normal_force    (rows, 3)            N, normal force on the first body
    /contacts/tangential_force (rows, 3)           N, tangential (friction) force on the first body
    /contacts/branch          (rows, 3)            m, first body's centre to the second's (to the
                                                   contact point for a wall)
    /contacts/coordination    (frames,)            coordination number 2 N_c / N_b: N_c touching
                                                   body pairs, N_b bodies present (walls left out)
    /frames/contact_count     (frames, bodies)     contacts of each body (walls included; a clump
                                                   touching at several spheres counts each)
    /frames/normal_force_sum  (frames, bodies)     N, Σ |normal force| over each body's contacts
One row is one sphere–sphere or sphere–wall contact: a clump touching another at three spheres has
three rows. Forces are those the engine computed at the frame's step (YADE: at the step before).
Root attributes (ATTRIBUTES): format_version, engine, engine_version, case_name,
orientation_tracked (False where orientations are NaN); stopped_at_rest (s) and rest_speed (m/s)
when the run ended at rest. A body missing from a frame (lost by the engine) has NaN state there.
LAYOUT below is this table as data; a test reads a produced file against it.
"""

from __future__ import annotations

import json
import os
import stat
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

FORMAT_VERSION = 1
# What a run directory holds besides this file (rundir.py writes and checks them).
# The run directory's layout, one home for each name (orchestrator.rundir owns what is in them).
RESULTS = "results.h5"
RUN_RECORD = "run.json"  # the record: run_id, build, status, timings, metrics
CAMPAIGN_RECORD = "campaign.json"  # a campaign directory (or a study over seeds): which campaign it holds (campaign.store)
STUDY_RECORD = "study.json"  # a study's directory: the study's id and kind, written before its release starts (studies.base)
CASE_COPY = "case.json"  # the validated inputs, canonical JSON
REPORT = "report.json"  # a study's report, beside its release
RELEASE_DIR = "run"  # a study's (or a micro-case's) run, inside its directory


def read_json(path: Path) -> dict | None:
    """The JSON object in `path` (run.json, case.json, …), or None when it is missing, unreadable or
    not an object."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def safe_output_path(directory: Path, name: str) -> Path:
    """`directory / name`, made safe to write through: a writer opens it by name and would follow a
    symbolic link there (out of `directory`, overwriting its target) or write into a file hard-linked
    elsewhere (or block on a FIFO), so such an entry is removed first and the writer makes a new file
    (or directory) in its place. A regular file or a directory of its own stays. ValueError for a name that is not one entry
    of `directory` (a path, `..`)."""
    if not name or name in (".", "..") or Path(name).name != name:
        raise ValueError(f"{name!r} is not a file name")
    path = directory / name
    try:
        status = os.lstat(path)
    except FileNotFoundError:
        return path
    single_file = stat.S_ISREG(status.st_mode) and status.st_nlink == 1
    if not (single_file or stat.S_ISDIR(status.st_mode)):  # a link of either kind, a FIFO, a socket, a device
        path.unlink()
    return path


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
CONTACT_LAYOUT: dict[str, tuple[str, int]] = {
    "contacts/offset": ("i", 1),
    "contacts/body": ("i", 2),
    "contacts/wall": ("i", 1),
    "contacts/point": ("f", 2),
    "contacts/normal_force": ("f", 2),
    "contacts/tangential_force": ("f", 2),
    "contacts/branch": ("f", 2),
    "contacts/coordination": ("f", 1),
    "frames/contact_count": ("i", 2),
    "frames/normal_force_sum": ("f", 2),
}
ATTRIBUTES = ("format_version", "engine", "engine_version", "case_name", "orientation_tracked")  # always written
REST_ATTRIBUTES = ("stopped_at_rest", "rest_speed")  # written when the run ended at rest


@dataclass
class Contacts:
    """Every contact of every frame, frames stacked (arrays as /contacts/* in the module docstring)."""

    offset: np.ndarray  # (frames + 1,) int
    body: np.ndarray  # (rows, 2) int, second -1 for a wall
    wall: np.ndarray  # (rows,) int, -1 for a body pair
    point: np.ndarray  # (rows, 3) m
    normal_force: np.ndarray  # (rows, 3) N, on the first body
    tangential_force: np.ndarray  # (rows, 3) N, on the first body

    RAW = ("offset", "body", "wall", "point", "normal_force", "tangential_force")

    @property
    def n_frames(self) -> int:
        return int(self.offset.shape[0]) - 1

    def frame(self, f: int) -> slice:
        """The rows of frame f."""
        return slice(int(self.offset[f]), int(self.offset[f + 1]))

    @classmethod
    def from_frames(cls, frames: list[np.ndarray]) -> "Contacts":
        """From per-frame (rows, 12) arrays: body 1, body 2, wall, point (3), normal force (3), tangential force (3)."""
        rows = np.concatenate(frames) if frames else np.empty((0, 12))
        offset = np.concatenate([[0], np.cumsum([len(f) for f in frames])]).astype(np.int64)
        return cls(offset, rows[:, 0:2].astype(np.int64), rows[:, 2].astype(np.int64), rows[:, 3:6], rows[:, 6:9], rows[:, 9:12])

    def frame_index(self) -> np.ndarray:
        """(rows,) the frame of each row."""
        return np.repeat(np.arange(self.n_frames), np.diff(self.offset))

    def per_body(self, bodies: int) -> tuple[np.ndarray, np.ndarray]:
        """(frames, bodies) int contact counts and (frames, bodies) N sums of |normal force|.

        Both bodies of a pair count the contact (a wall counts for its body only); a clump touching
        at several spheres counts each. Enough to find contact episodes and rebounds without
        reading rows.
        """
        frames = self.frame_index()
        magnitude = np.linalg.norm(self.normal_force, axis=1)
        count = np.zeros((self.n_frames, bodies), dtype=np.int64)
        force = np.zeros((self.n_frames, bodies))
        for side in (0, 1):
            body = self.body[:, side]
            real = body >= 0
            np.add.at(count, (frames[real], body[real]), 1)
            np.add.at(force, (frames[real], body[real]), magnitude[real])
        return count, force

    def branch(self, position: np.ndarray) -> np.ndarray:
        """(rows, 3) m: from the first body's centre to the second's, or to the contact point for a
        wall. position: the trajectory's (frames, bodies, 3)."""
        frames = self.frame_index()
        first = position[frames, self.body[:, 0]]
        wall = self.body[:, 1] < 0
        second = np.where(wall[:, None], self.point, position[frames, np.maximum(self.body[:, 1], 0)])
        return second - first

    def touching_pairs(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        """Body pairs touching in one frame: (pairs, 2) body indices (lower first, each pair once)
        and (pairs,) N their summed |normal force| (several sphere contacts of two clumps add up)."""
        rows = self.frame(frame % self.n_frames)
        body = self.body[rows]
        pairs = body[:, 1] >= 0
        if not pairs.any():
            return np.empty((0, 2), dtype=np.int64), np.empty(0)
        keys, inverse = np.unique(np.sort(body[pairs], axis=1), axis=0, return_inverse=True)
        force = np.bincount(inverse.ravel(), weights=np.linalg.norm(self.normal_force[rows][pairs], axis=1), minlength=len(keys))
        return keys, force

    def coordination(self, position: np.ndarray) -> np.ndarray:
        """(frames,) coordination number Z = 2 N_c / N_b: N_c touching body pairs (walls left out),
        N_b bodies present in the frame (finite position)."""
        present = np.isfinite(position[..., 0]).sum(axis=1)
        touching = np.array([len(self.touching_pairs(f)[0]) for f in range(self.n_frames)])
        return np.where(present > 0, 2.0 * touching / np.maximum(present, 1), 0.0)

    def validate(self, frames: int, bodies: int) -> None:
        rows = int(self.offset[-1]) if len(self.offset) else 0
        if self.n_frames != frames or self.offset[0] != 0 or np.any(np.diff(self.offset) < 0):
            raise ValueError(f"contacts offset must rise from 0 over {frames} frames")
        for name, width in (("body", 2), ("point", 3), ("normal_force", 3), ("tangential_force", 3)):
            if getattr(self, name).shape != (rows, width):
                raise ValueError(f"contacts {name} has shape {getattr(self, name).shape}, expected {(rows, width)}")
        if self.wall.shape != (rows,):
            raise ValueError("contacts wall must have one entry per row")
        if rows and (self.body[:, 0].min() < 0 or self.body.max() >= bodies):
            raise ValueError("contacts name a body that is not in the trajectory")


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
    contacts: Contacts | None = None  # recorded when the case asks (record_contacts)

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
        if self.contacts is not None:
            self.contacts.validate(frames, bodies)


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
        if trajectory.contacts is not None:
            _write_contacts(store, trajectory)
    os.replace(temporary, path)


def _write_contacts(store: h5py.File, trajectory: Trajectory) -> None:
    recorded = trajectory.contacts
    assert recorded is not None
    group = store.create_group("contacts")
    for name in Contacts.RAW:
        group.create_dataset(name, data=getattr(recorded, name))
    group.create_dataset("branch", data=recorded.branch(trajectory.position))
    group.create_dataset("coordination", data=recorded.coordination(trajectory.position))
    count, force = recorded.per_body(trajectory.n_bodies)
    store["frames"].create_dataset("contact_count", data=count)
    store["frames"].create_dataset("normal_force_sum", data=force)


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
            contacts=Contacts(*(store[f"contacts/{name}"][()] for name in Contacts.RAW)) if "contacts" in store else None,
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
