"""LIGGGHTS dumps → body states: the binary and text `dump custom` readers, and the clump
reconstruction (centre, orientation by Kabsch, velocity, spin) from the per-sphere rows."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from orchestrator.shapes.rigid import quaternion_matrices
from orchestrator.plan import RunPlan


def atom_columns(ids: np.ndarray, frames: list[np.ndarray], first: list[int], widths: list[int]) -> list[np.ndarray]:
    """Per-atom columns by atom id: one (F, B, width) array per (first column, width); a lost atom
    is NaN from then on."""
    arrays = [np.full((len(frames), len(ids), width), np.nan) for width in widths]
    index_of = {int(i): k for k, i in enumerate(ids)}
    for f, rows in enumerate(frames):
        slots = np.array([index_of[int(i)] for i in rows[:, 0]], dtype=np.int64)
        for array, start, width in zip(arrays, first, widths):
            array[f, slots] = rows[:, start : start + width]
    return arrays


def sphere_states(ids: np.ndarray, column: dict[str, int], frames: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F, B, 3) position, velocity, spin of spheres by atom id; a lost atom is NaN from then on."""
    position, velocity, spin = atom_columns(ids, frames, [column["x"], column["vx"], column["omegax"]], [3, 3, 3])
    return position, velocity, spin


def superquadric_states(ids: np.ndarray, column: dict[str, int], frames: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(F, B, 3) position, velocity, spin and (F, B, 4) orientation (w, x, y, z) of superquadric
    bodies (one atom each, columns quat1..quat4); a lost body is NaN from then on."""
    position, velocity, spin, orientation = atom_columns(ids, frames, [column["x"], column["vx"], column["omegax"], column["quat1"]], [3, 3, 3, 4])
    return position, velocity, spin, orientation


def clump_states(plan: RunPlan, column: dict[str, int], frames: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Body states from the per-sphere dump of multisphere clumps, all bodies of a frame at once:
    position, velocity, spin, orientation, and atom id → body index (the clump's place in the case).

    Orientation: the rotation R that best maps the template's sphere centres onto the dumped ones
    (Kabsch, by a batched SVD), as a (w, x, y, z) quaternion of the brick frame. Centre: the brick's
    centre of mass, mean of the sphere centres − R × the template's mean (zero on a box; not on a
    bevelled brick). A clump that lost a sphere (dropped from the box) is NaN from then on. Velocity: mean sphere velocity. Spin: the spheres carry their body's. Bodies are matched to the case's clumps by their
    nearest requested position in the first frame (insertion places them within 1 mm).
    """
    from scipy.spatial import cKDTree

    clumps = plan.case.bodies.clumps
    templates = [body.centres for body in plan.shapes]  # type: ignore[attr-defined]
    template_means, sizes = np.array([t.mean(axis=0) for t in templates]), np.array([len(t) for t in templates])
    shape = (len(frames), len(clumps))
    position, velocity, spin = (np.full(shape + (3,), np.nan) for _ in range(3))
    orientation = np.full(shape + (4,), np.nan)
    requested = np.array([c.position for c in clumps])
    xyz, vxyz, wxyz = (slice(column[a], column[a] + 3) for a in ("x", "vx", "omegax"))
    body_column, id_column = column["id_multisphere"], column["id"]
    slot_of = np.full(1, -1, dtype=np.int64)  # body id → clump slot (-1: not seen yet)
    stacked: dict[int, np.ndarray] = {}  # sphere count → (clumps, spheres, 3) templates, by slot
    for f, rows in ((f, rows) for f, rows in enumerate(frames) if len(rows)):  # a frame of no sphere: every clump lost (NaN)
        # `dump_modify sort id` and clumps inserted one at a time: usually sorted by body already.
        keys = rows[:, body_column]
        if not (np.all(np.diff(keys) >= 0) and np.all(np.diff(rows[:, id_column]) > 0)):
            rows = rows[np.lexsort((rows[:, id_column], keys))]  # by body, then atom id = template order
            keys = rows[:, body_column]
        bodies_all = keys.astype(np.int64)
        starts = np.flatnonzero(np.r_[True, np.diff(bodies_all) != 0])
        counts = np.diff(np.r_[starts, len(rows)])
        bodies = bodies_all[starts]
        if bodies.max() >= len(slot_of):
            slot_of = np.concatenate([slot_of, np.full(bodies.max() + 1 - len(slot_of), -1, dtype=np.int64)])
        for size in np.unique(counts):  # bodies of one sphere count form one batch
            chosen = counts == size
            index = starts[chosen][:, None] + np.arange(size)[None, :]
            group = rows[index]  # (bodies, spheres, columns)
            centre = group[:, :, xyz].mean(axis=1)
            ids = bodies[chosen]
            new = slot_of[ids] < 0
            if new.any():
                _, nearest = cKDTree(requested).query(centre[new])
                slot_of[ids[new]] = np.atleast_1d(nearest)
            whole = sizes[slot_of[ids]] == size  # a clump missing a sphere (dropped from the box) is lost: NaN
            slots, centre, group = slot_of[ids][whole], centre[whole], group[whole]
            position[f, slots] = centre
            velocity[f, slots] = group[:, :, vxyz].mean(axis=1)
            spin[f, slots] = group[:, 0, wxyz]
            if int(size) not in stacked:
                stacked[int(size)] = np.stack([c - c.mean(axis=0) if len(c) == size else np.full((size, 3), np.nan) for c in templates])
            quaternions = kabsch_quaternions(group[:, :, xyz] - centre[:, None, :], stacked[int(size)][slots])
            orientation[f, slots] = quaternions
            if np.any(template_means[slots]):
                position[f, slots] = centre - np.einsum("bij,bj->bi", quaternion_matrices(quaternions), template_means[slots])
    atoms = frames[0][:, id_column].astype(np.int64)
    atom_slot = np.full(int(atoms.max()) + 1, -1, dtype=np.int64)
    atom_slot[atoms] = slot_of[frames[0][:, body_column].astype(np.int64)]
    return position, velocity, spin, orientation, atom_slot


def kabsch_quaternions(world: np.ndarray, template: np.ndarray) -> np.ndarray:
    """(B, 4) quaternions (w, x, y, z; w ≥ 0) of the rotations R minimising Σ |world_i − R template_i|.

    world, template: (B, n, 3), both centred. Kabsch: H = Σ template_i world_iᵀ = U S Vᵀ, then
    R = V diag(1, 1, det(V Uᵀ)) Uᵀ (no reflection).
    """
    from scipy.spatial.transform import Rotation

    h = np.einsum("bni,bnj->bij", template, world)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.einsum("bji,bkj->bik", vt, u)))
    correction = np.ones((len(h), 3))
    correction[:, 2] = d
    rotation = np.einsum("bji,bj,bkj->bik", vt, correction, u)
    x, y, z, w = Rotation.from_matrix(rotation).as_quat().T
    quaternion = np.stack([w, x, y, z], axis=1)
    return np.where(quaternion[:, :1] < 0, -quaternion, quaternion)


def read_dump(path: Path) -> tuple[list[int], list[str], list[np.ndarray]]:
    """Parse a `dump custom` text file into (steps, column names, per-frame arrays); a cut-off last frame is dropped."""
    if not path.exists():
        return [], [], []
    steps: list[int] = []
    frames: list[np.ndarray] = []
    columns: list[str] = []
    for block in path.read_text().split("ITEM: TIMESTEP\n")[1:]:
        parts = block.split("\n", 8)  # 8 header lines, then the rows
        if len(parts) < 9:
            break  # a frame cut short by a crash
        step, count, names = int(parts[0]), int(parts[2]), parts[7].split()[2:]
        if columns and names != columns:
            raise ValueError(f"{path}: dump columns change between frames")
        columns = names
        data = np.fromstring(parts[8], sep=" ")  # C parsing of the whole block, 1.5 × str.split
        if data.size != count * len(columns):
            break  # incomplete last frame
        steps.append(step)
        frames.append(data.reshape(count, len(columns)))
    return steps, columns, frames


def binary_dump_steps(path: Path, n_columns: int) -> list[int]:
    """The steps of the complete frames of a binary `dump custom` file, reading only their headers
    (layout: read_binary_dump)."""
    steps: list[int] = []
    if not path.exists():
        return steps
    end = path.stat().st_size
    with open(path, "rb") as stream:
        offset = 0
        while offset + 60 <= end:
            stream.seek(offset)
            head = stream.read(20)
            step, atoms = (int(v) for v in np.frombuffer(head, np.int64, 2))
            triclinic = int(np.frombuffer(head, np.int32, 1, 16)[0])
            offset += 16 + 4 + 24 + 48 + (24 if triclinic else 0)
            stream.seek(offset)
            size_one, chunks = (int(v) for v in np.frombuffer(stream.read(8), np.int32, 2))
            offset += 8
            if size_one != n_columns:
                raise ValueError(f"{path}: {size_one} values per atom, expected {n_columns}")
            values = 0
            for _ in range(chunks):
                stream.seek(offset)
                raw = stream.read(4)
                if len(raw) < 4:
                    return steps
                count = int(np.frombuffer(raw, np.int32, 1)[0])
                offset += 4 + 8 * count
                values += count
            if offset > end or values != atoms * size_one:
                return steps  # a frame cut short by a crash
            steps.append(step)
    return steps


def read_binary_dump(path: Path, n_columns: int) -> tuple[list[int], list[np.ndarray]]:
    """Parse a binary `dump custom` file into (steps, per-frame (atoms, columns) arrays).

    Layout of each frame (LIGGGHTS 3.8, LAMMPS of its time): timestep and atom count (int64), the
    triclinic flag and 6 boundary flags (int32), 6 box bounds (+3 tilts if triclinic; float64), the
    values per atom and the number of chunks (int32), then per chunk its value count (int32) and
    its values (float64). A frame cut short by a crash is dropped.
    """
    if not path.exists():
        return [], []
    raw = path.read_bytes()
    steps: list[int] = []
    frames: list[np.ndarray] = []
    offset, end = 0, len(raw)
    while offset + 60 <= end:
        step, atoms = (int(v) for v in np.frombuffer(raw, np.int64, 2, offset))
        triclinic = int(np.frombuffer(raw, np.int32, 1, offset + 16)[0])
        offset += 16 + 4 + 24 + 48 + (24 if triclinic else 0)
        if offset + 8 > end:
            break
        size_one, chunks = (int(v) for v in np.frombuffer(raw, np.int32, 2, offset))
        offset += 8
        if size_one != n_columns:
            raise ValueError(f"{path}: {size_one} values per atom, expected {n_columns}")
        parts = []
        for _ in range(chunks):
            if offset + 4 > end:
                return steps, frames
            count = int(np.frombuffer(raw, np.int32, 1, offset)[0])
            offset += 4
            if offset + 8 * count > end:
                return steps, frames  # a frame cut short by a crash
            parts.append(np.frombuffer(raw, np.float64, count, offset))
            offset += 8 * count
        data = np.concatenate(parts) if parts else np.empty(0)
        if data.size != atoms * size_one:
            break
        steps.append(step)
        frames.append(data.reshape(atoms, size_one))
    return steps, frames


def read_local_dump(path: Path) -> dict[int, np.ndarray]:
    """A text `dump local` file as step → (entries, columns) array; a frame cut short by a crash is
    dropped, frames with no entries are kept (empty)."""
    found: dict[int, np.ndarray] = {}
    if not path.exists():
        return found
    for block in path.read_text().split("ITEM: TIMESTEP\n")[1:]:
        lines = block.split("\n", 8)
        if len(lines) < 8:
            break
        step, count, columns = int(lines[0]), int(lines[2]), len(lines[7].split()) - 2
        data = np.fromstring(lines[8], sep=" ") if len(lines) > 8 else np.empty(0)
        if data.size != count * columns:
            break
        # A dump made again after a wall removal repeats the step it is made at: the first copy goes
        # with the frame dumped at that step.
        found.setdefault(step, data.reshape(count, columns))
    return found


def contact_rows(pairs: np.ndarray | None, walls: np.ndarray | None, atom_slot: np.ndarray, wall_index: list[int]) -> np.ndarray:
    """(rows, 12) contacts of one frame as results.Contacts.from_frames takes them, from the rows of
    the deck's pair/gran/local dump (id1 id2 periodic, force, normal force, contact point: force on
    atom 1) and wall/gran/local dump (point on the wall, atom centre, mesh triangle atom, force,
    normal force: force on the atom). atom_slot: atom id → body index; wall_index: mesh → case wall.
    A pair counted by two MPI processes is kept once; a clump's own spheres never pair. Rows without
    any force are left out: LIGGGHTS also lists pairs and walls within its contact distance (the
    deck's contact_distance_factor) that do not touch."""
    if pairs is not None and len(pairs):
        pairs = pairs[np.any(pairs[:, 3:6] != 0.0, axis=1)]
    if walls is not None and len(walls):
        walls = walls[np.any(walls[:, 9:12] != 0.0, axis=1)]
    out = []
    if pairs is not None and len(pairs):
        ids = pairs[:, 0:2].astype(np.int64)
        _, first = np.unique(np.sort(ids, axis=1), axis=0, return_index=True)
        pairs, ids = pairs[np.sort(first)], ids[np.sort(first)]
        body = atom_slot[ids]
        keep = body[:, 0] != body[:, 1]
        normal = pairs[keep, 6:9]
        out.append(np.column_stack([body[keep], np.full(keep.sum(), -1), pairs[keep, 9:12], normal, pairs[keep, 3:6] - normal]))
    if walls is not None and len(walls):
        keys = walls[:, 6:9].astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        walls, keys = walls[np.sort(first)], keys[np.sort(first)]
        normal = walls[:, 12:15]
        mesh = np.asarray(wall_index, dtype=np.int64)[keys[:, 0]]
        out.append(np.column_stack([atom_slot[keys[:, 2]], np.full(len(walls), -1), mesh, walls[:, 0:3], normal, walls[:, 9:12] - normal]))
    return np.concatenate(out).astype(float) if out else np.empty((0, 12))
