"""Dump ingestion: engine output → body states, against a line-by-line Python parser.

Run: .venv/bin/python benchmarks/dump_ingestion.py  → docs/benchmarks/dump_ingestion.json and a
markdown table. BENCH_MB (default 1000) sets the size of the text dump set.

The data: full-scale avalanche frames, 6300 bricks of 8 spheres (50 400 atoms, rigid bricks at
random positions and orientations), in the columns the LIGGGHTS deck dumps. The same frames are
written three ways: the text `dump custom` that runs made before the binary dump (%.16g, ~1 GB in
all), the binary dump LIGGGHTS writes now (frames.bin), and YADE's frame stream (frames.npy, one
row per body). Measured, in MB/s of the file read and atom-frames/s:

- baseline: a line-by-line parser in plain Python, as LPP / pizza.py read dumps (text);
- `read_dump`: the project's text reader (kept for old runs);
- `read_binary_dump`: the binary reader (what a LIGGGHTS run now goes through);
- binary → states: the binary reader plus `clump_states` (centres, velocities, spins and
  orientations of every brick by a batched Kabsch fit), i.e. everything up to results.h5;
- YADE `read_frames` on its frame stream.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from scipy.spatial.transform import Rotation

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.case import parse_case  # noqa: E402
from orchestrator.engines.liggghts.deck import CLUMP_COLUMNS  # noqa: E402
from orchestrator.engines.liggghts.dump import clump_states, read_binary_dump, read_dump  # noqa: E402
from orchestrator.engines.common import read_frames  # noqa: E402
from orchestrator.physics import clump_shapes  # noqa: E402

BRICKS = 6300
LAYOUT = (4, 2, 1)


def synthetic_case(positions: np.ndarray, orientations: np.ndarray):  # type: ignore[no-untyped-def]
    return parse_case(
        {
            "name": "bench",
            "time": {"duration": 1.0, "output_interval": 0.01},
            "materials": [{"name": "brick", "density": 1700.0}],
            "contacts": [{"materials": ["brick", "brick"], "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}],
            "shapes": [{"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008, "layout": list(LAYOUT)}],
            "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": p.tolist(), "orientation": q.tolist()} for p, q in zip(positions, orientations)]},
        }
    )


def synthetic_frame(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(atoms × columns) rows of rigid bricks, and the bricks' positions and (w, x, y, z) orientations."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform([-0.6, -0.5, 0.0], [1.5, 0.5, 0.3], size=(BRICKS, 3))
    rotations = Rotation.random(BRICKS, random_state=seed)
    x, y, z, w = rotations.as_quat().T
    orientations = np.stack([w, x, y, z], axis=1)
    case = synthetic_case(positions[:2], orientations[:2])
    template = case.shape("brick").clump(1700.0)
    n = template.n_spheres
    centres = positions[:, None, :] + np.einsum("bij,nj->bni", rotations.as_matrix(), template.centres)
    rows = np.zeros((BRICKS * n, len(CLUMP_COLUMNS)))
    col = {name: i for i, name in enumerate(CLUMP_COLUMNS)}
    rows[:, col["id"]] = np.arange(1, BRICKS * n + 1)
    rows[:, col["id_multisphere"]] = np.repeat(np.arange(1, BRICKS + 1), n)
    rows[:, col["type"]] = 1
    rows[:, col["mass"]] = template.mass / n
    rows[:, col["radius"]] = template.radius
    rows[:, col["x"] : col["z"] + 1] = centres.reshape(-1, 3)
    rows[:, col["vx"] : col["vz"] + 1] = np.repeat(rng.normal(size=(BRICKS, 3)), n, axis=0)
    rows[:, col["omegax"] : col["omegaz"] + 1] = np.repeat(rng.normal(size=(BRICKS, 3)), n, axis=0)
    return rows, positions, orientations


def text_frame(step: int, rows: np.ndarray, body: str) -> str:
    header = (
        f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{len(rows)}\nITEM: BOX BOUNDS ff ff ff\n"
        "-1 2\n-1 1\n-1 1\nITEM: ATOMS " + " ".join(CLUMP_COLUMNS) + "\n"
    )
    return header + body


def binary_frame(step: int, rows: np.ndarray) -> bytes:
    """One frame in LIGGGHTS 3.8's binary dump layout (see read_binary_dump)."""
    header = np.array([step, len(rows)], np.int64).tobytes() + np.zeros(7, np.int32).tobytes()
    header += np.array([-1, 2, -1, 1, -1, 1], np.float64).tobytes()
    header += np.array([rows.shape[1], 1, rows.size], np.int32).tobytes()
    return header + rows.astype(np.float64).tobytes()


def baseline_parse(path: Path) -> int:
    """Line by line, the way LPP / pizza.py read a dump: returns the atom-frames read."""
    atom_frames = 0
    with open(path) as stream:
        while True:
            line = stream.readline()
            if not line:
                return atom_frames
            if line.startswith("ITEM: TIMESTEP"):
                int(stream.readline())
                stream.readline()
                count = int(stream.readline())
                for _ in range(4):
                    stream.readline()
                stream.readline()  # ITEM: ATOMS ...
                frame = [[float(value) for value in stream.readline().split()] for _ in range(count)]
                atom_frames += len(frame)


def timed(function, *args):  # type: ignore[no-untyped-def]
    started = time.perf_counter()
    result = function(*args)
    return time.perf_counter() - started, result


def main() -> None:
    target_mb = float(os.environ.get("BENCH_MB", 1000))
    scratch = Path(tempfile.mkdtemp(prefix="demorch-ingest-"))
    try:
        rows, positions, orientations = synthetic_frame()
        body = "\n".join(
            "%d %d %d %.16g %.16g %.16g %.16g %.16g %.16g %.16g %.16g %.16g %.16g %.16g" % tuple(r) for r in rows
        ) + "\n"
        frame_mb = len(text_frame(0, rows, body)) / 1e6
        frames = max(1, round(target_mb / frame_mb))
        text_path, binary_path, yade_path = scratch / "frames.dump", scratch / "frames.bin", scratch / "frames.npy"
        with open(text_path, "w") as text, open(binary_path, "wb") as binary, open(yade_path, "wb") as yade:
            per_body = np.zeros((BRICKS, 16))
            per_body[:, 3:6] = positions
            per_body[:, 12:16] = orientations
            for f in range(frames):
                text.write(text_frame(1000 * f, rows, body))
                binary.write(binary_frame(1000 * f, rows))
                np.save(yade, np.array([0.01 * f]))
                np.save(yade, per_body)
        sizes = {name: path.stat().st_size / 1e6 for name, path in (("text", text_path), ("binary", binary_path), ("yade", yade_path))}
        atom_frames = len(rows) * frames
        case = synthetic_case(positions, orientations)
        column = {name: i for i, name in enumerate(CLUMP_COLUMNS)}

        def binary_to_states() -> None:
            _, parsed = read_binary_dump(binary_path, len(CLUMP_COLUMNS))
            states = clump_states(SimpleNamespace(case=case, shapes=clump_shapes(case)), column, parsed)  # the two fields it reads of a plan
            assert np.allclose(states[0][0], positions)

        results = {}
        seconds, counted = timed(baseline_parse, text_path)
        assert counted == atom_frames
        results["baseline line-by-line (text)"] = (seconds, sizes["text"])
        seconds, _ = timed(read_dump, text_path)
        results["read_dump (text)"] = (seconds, sizes["text"])
        seconds, _ = timed(read_binary_dump, binary_path, len(CLUMP_COLUMNS))
        results["read_binary_dump (binary)"] = (seconds, sizes["binary"])
        seconds, _ = timed(binary_to_states)
        results["binary → brick states (read + Kabsch)"] = (seconds, sizes["binary"])
        seconds, _ = timed(read_frames, yade_path)
        results["YADE read_frames (per body)"] = (seconds, sizes["yade"])
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    baseline_rate = atom_frames / results["baseline line-by-line (text)"][0]
    table = {
        name: {
            "seconds": seconds,
            "file_mb": megabytes,
            "mb_per_s": megabytes / seconds,
            "atom_frames_per_s": atom_frames / seconds,
            "speedup_vs_baseline": atom_frames / seconds / baseline_rate,
        }
        for name, (seconds, megabytes) in results.items()
    }
    out = REPO / "docs" / "benchmarks"
    out.mkdir(parents=True, exist_ok=True)
    summary = {"machine": f"{platform.machine()} {os.cpu_count()} CPUs, {platform.platform()}", "frames": frames, "atoms_per_frame": len(rows), "results": table}
    (out / "dump_ingestion.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"{frames} frames of {len(rows)} atoms ({BRICKS} bricks); text {sizes['text']:.0f} MB, binary {sizes['binary']:.0f} MB\n")
    print("| reader | file | MB/s | atom-frames/s | × baseline |\n|---|---|---|---|---|")
    for name, row in table.items():
        print(f"| {name} | {row['file_mb']:.0f} MB | {row['mb_per_s']:.0f} | {row['atom_frames_per_s']:.3g} | {row['speedup_vs_baseline']:.1f} |")


if __name__ == "__main__":
    main()
