"""What a run will write to disk and hold in memory, estimated before it starts.

A run writes results.h5 (every body at every frame, and with `record_contacts` every contact), the
engine's raw output that results.h5 is read from (kept beside it), and checkpoints; reading the raw
output back into results.h5 holds both in memory at once. The sizes per frame are the formats' own
(results.py, the engines' dumps); the number of contacts is a dense pile's, an upper estimate for a
flow. Measured 2026-12-01 on LIGGGHTS, 200 touching spheres, a frame every step for 0.02 s (10 001
frames), contacts recorded: results.h5 277 MB, frames.bin 209 MB, contact dumps 64 MB, peak memory
0.99 GB (1.8 × results and raw output).
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from orchestrator import physics
from orchestrator.capabilities import capabilities
from orchestrator.case import Case, CaseError

BODY_FRAME_BYTES = 13 * 8  # results.h5: position, velocity, spin (3 doubles each), orientation (4)
CONTACT_ROW_BYTES = 112  # results.h5 /contacts: two bodies and a wall (int64), point, normal and tangential force (3 doubles each)
CONTACT_BODY_BYTES = 16  # results.h5: per body and frame, a contact count and a force sum
RAW_SPHERE_FRAME_BYTES = 14 * 8  # the engine's frame dump: a sphere's (LIGGGHTS, per clump sphere) or a body's row of doubles
RAW_CONTACT_ROW_BYTES = 110  # LIGGGHTS `dump local` text (YADE's binary rows are 96 B): measured 107 B per row
# Contacts per sphere in a dense pile at rest: a coordination number of about 4 (each contact shared
# by two spheres), and walls. A flow has fewer.
CONTACTS_PER_SPHERE = 2.0
CHECKPOINT_SPHERE_BYTES = 500  # a LIGGGHTS restart file: 465 B per clump sphere measured on the demo packing
CHECKPOINTS_ON_DISK = 3  # the two newest kept and one being written
MEMORY_FACTOR = 2.0  # peak memory over (results + raw output) while results.h5 is written (measured 1.8)
BASE_MEMORY = 300 * 2**20  # the orchestrator itself, with numpy, h5py and pandas loaded
WARN_FRACTION = 0.25  # of the free disk or the machine's memory: say so before running


@dataclass(frozen=True)
class OutputEstimate:
    """Bytes a run is expected to write (results, raw engine output, checkpoints) and to hold in memory."""

    frames: int
    results: int
    raw: int
    checkpoints: int
    memory: int

    @property
    def disk(self) -> int:
        return self.results + self.raw + self.checkpoints

    def describe(self) -> str:
        return (f"{self.frames} frames: about {_gb(self.results)} of results, {_gb(self.raw)} of raw engine output, "
                f"{_gb(self.checkpoints)} of checkpoints ({_gb(self.disk)} on disk) and {_gb(self.memory)} of memory")


def _gb(size: float) -> str:
    return f"{size / 1e9:.3g} GB"


def sphere_count(case: Case) -> int:
    """Particles the engine moves: free spheres, every sphere of every clump, one per superquadric."""
    per_kind = {(c.shape, c.material): case.shape(c.shape).body(case.material(c.material).density).particles
                for c in case.bodies.clumps}
    return len(case.bodies.spheres) + sum(per_kind[(c.shape, c.material)] for c in case.bodies.clumps)


def estimate(case: Case, schedule: physics.Schedule, table: Sequence[physics.BodyInfo]) -> OutputEstimate:
    frames, bodies, spheres = schedule.frames + 1, len(table), sphere_count(case)
    results = frames * bodies * BODY_FRAME_BYTES
    raw = frames * spheres * RAW_SPHERE_FRAME_BYTES
    if case.record_contacts:
        rows = frames * CONTACTS_PER_SPHERE * spheres
        results += int(rows * CONTACT_ROW_BYTES) + frames * bodies * CONTACT_BODY_BYTES
        raw += int(rows * RAW_CONTACT_ROW_BYTES)
    checkpoints = CHECKPOINTS_ON_DISK * spheres * CHECKPOINT_SPHERE_BYTES if capabilities(case.engine).restart else 0
    return OutputEstimate(frames, results, raw, checkpoints, int(MEMORY_FACTOR * (results + raw)) + BASE_MEMORY)


def machine_memory() -> int:
    """Bytes of physical memory of this machine."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def check_machine(output: OutputEstimate, directory: Path) -> str | None:
    """Raise CaseError when the run would not fit this machine's free disk (where `directory` is) or
    memory, with the numbers; return a warning when it would take more than WARN_FRACTION of either."""
    existing = next((p for p in (directory, *directory.parents) if p.exists()), Path("."))
    free, memory = shutil.disk_usage(existing).free, machine_memory()
    if output.disk > free or output.memory > memory:
        raise CaseError(f"time.output_interval: the run would write {output.describe()}; this machine has {_gb(free)} free "
                        f"at {existing} and {_gb(memory)} of memory: record fewer frames (a longer output_interval) "
                        "or no contacts")
    if output.disk > WARN_FRACTION * free or output.memory > WARN_FRACTION * memory:
        return f"a large run: {output.describe()} ({_gb(free)} free on disk, {_gb(memory)} of memory)"
    return None
