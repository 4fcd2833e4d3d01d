"""ParaView export (`demorch paraview`, orchestrator.post.paraview): write time and size per frame.

Run: .venv/bin/python benchmarks/paraview_export.py [BRICKS]  → docs/benchmarks/paraview_export.json
and a markdown table. BRICKS (default 6400, the full-scale pour) bricks at random positions and
orientations in a 1 m box, two frames, written as the study's brick (a clump of 4 × 2 × 1 spheres
and 8 corner spheres, rounding 1 mm) at the default surface resolution (post/paraview.py
RESOLUTION) and at 4 latitudes (`--resolution 4`), and as a superquadric brick. What is measured is the writer alone: the
frames need no engine, and the contacts (a few lines a body) are left out.
"""

from __future__ import annotations

import datetime as dt
import json
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import meshio
import numpy as np
from scipy.spatial.transform import Rotation

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.case import parse_case  # noqa: E402
from orchestrator.post.paraview import KINDS, write_series  # noqa: E402
from orchestrator.results import Trajectory  # noqa: E402

FRAMES = 2
CLUMP = {"kind": "clump", "layout": [4, 2, 1], "rounding": 0.001}
SUPERQUADRIC = {"kind": "superquadric", "rounding": 0.001}
# (what is written, the brick's shape, the latitudes of its meshes: None for the defaults)
SHAPES = (("clump (study's brick, 16 spheres)", CLUMP, None), ("clump, --resolution 4", CLUMP, 4), ("superquadric", SUPERQUADRIC, None))


def synthetic(bricks: int, shape: dict, seed: int = 0):  # type: ignore[no-untyped-def]
    """A case of `bricks` bricks of `shape` and a trajectory of FRAMES frames of them, randomly placed."""
    rng = np.random.default_rng(seed)
    case = parse_case({
        "name": "bench", "engine": "liggghts",
        "time": {"duration": 1.0, "output_interval": 0.01},
        "materials": [{"name": "brick", "density": 1700.0}],
        "contacts": [{"materials": ["brick", "brick"], "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}],
        "shapes": [{"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008, **shape}],
        "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": [0.0, 0.0, 0.01 * (i + 1)]} for i in range(bricks)]},
    })
    position = rng.uniform(0.0, 1.0, (FRAMES, bricks, 3))
    orientation = np.roll(Rotation.random(FRAMES * bricks, random_state=seed).as_quat(), 1, axis=1).reshape(FRAMES, bricks, 4)
    trajectory = Trajectory(time=np.arange(FRAMES) * 0.02, ids=np.arange(bricks), material=np.array(["brick"] * bricks),
                            mass=np.full(bricks, 6.2e-3), radius=np.full(bricks, 0.018), inertia=np.full((bricks, 3), 1e-7),
                            position=position, velocity=rng.normal(0.0, 1.0, (FRAMES, bricks, 3)),
                            angular_velocity=np.zeros((FRAMES, bricks, 3)), orientation=orientation)
    return case, trajectory


def measure(bricks: int) -> list[dict]:
    rows = []
    for name, shape, latitudes in SHAPES:
        case, trajectory = synthetic(bricks, shape)
        with tempfile.TemporaryDirectory(prefix="demorch-paraview-") as scratch:
            started = time.perf_counter()
            write_series(case, trajectory, Path(scratch), resolution=None if latitudes is None else dict.fromkeys(KINDS, latitudes))
            seconds = (time.perf_counter() - started) / FRAMES
            size = sum(p.stat().st_size for p in Path(scratch).glob("bodies_*.vtu")) / FRAMES
            mesh = meshio.read(next(Path(scratch).glob("bodies_*_00000.vtu")))  # the bricks: one kind, one file a frame
        rows.append({"shape": name, "bricks": bricks, "vertices_per_brick": len(mesh.points) // bricks,
                     "triangles_per_brick": sum(len(b.data) for b in mesh.cells) // bricks,
                     "seconds_per_frame": round(seconds, 2), "mb_per_frame": round(size / 1e6, 1),
                     "kb_per_brick": round(size / bricks / 1e3, 1)})
    return rows


def main() -> None:
    bricks = int(sys.argv[1]) if len(sys.argv) > 1 else 6400
    rows = measure(bricks)
    record = {"date": dt.date.today().isoformat(), "machine": f"{platform.machine()}, {platform.system()} {platform.release()}",
              "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3), "rows": rows}
    out = REPO / "docs" / "benchmarks" / "paraview_export.json"
    out.write_text(json.dumps(record, indent=2) + "\n")
    print("| shape | bricks | vertices / triangles a brick | s per frame | MB per frame | kB a brick |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['shape']} | {r['bricks']} | {r['vertices_per_brick']} / {r['triangles_per_brick']} | {r['seconds_per_frame']} "
              f"| {r['mb_per_frame']} | {r['kb_per_brick']} |")
    print(f"peak memory {record['peak_rss_mb']} MB; written {out}")


if __name__ == "__main__":
    main()
