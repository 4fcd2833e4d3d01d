"""Checkpoints and segments of a run directory, the same rules for every engine.

A run writes its whole state every few output intervals as `checkpoint.<step>.<ext>` (LIGGGHTS
restart files with contact history and clumps, YADE's saved scene, cocd's arrays). A run that is
killed continues from its newest usable checkpoint in a new *segment*: segment 0 is the first
attempt, segment k the k-th continuation. Each segment writes its own outputs (frames, contacts,
engine log) under names carrying its number (`segment_name`), so nothing an earlier segment wrote
is overwritten; readers merge them, a later segment's frames replacing an earlier one's from its
first frame on (`merge`).

A checkpoint is sealed once it is complete: its sha256 is written beside it
(`checkpoint.<step>.<ext>.sha256`) by the engine's runner after the file took its name (YADE, cocd)
or by the orchestrator once the engine reports a later step (LIGGGHTS writes a checkpoint between two
sub-runs, after the thermo line that ends the first: a checkpoint is complete only once a thermo line
of a later step is out). A run continues only from a sealed checkpoint whose content still
matches its seal, the newest such; one that does not match (truncated, zeroed, edited) is set aside
as `checkpoint.<step>.<ext>.damaged` (kept, never deleted) and the next older one is tried; one cut
short while being written has no seal and is never used. The two newest sealed checkpoints are
kept, older ones are deleted (`prune`).
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path
from typing import Sequence, TypeVar

from orchestrator.plan import Resume  # noqa: F401  (where a continued run starts; re-exported)

KEEP = 2
_CHECKPOINT = re.compile(r"^checkpoint\.(\d+)\.(.+)$")
Frame = TypeVar("Frame")


def segment_name(name: str, segment: int) -> str:
    """The file of `name` written by `segment`: frames.bin → frames.bin (0), frames.1.bin (1), …"""
    if segment == 0:
        return name
    stem, dot, suffix = name.partition(".")
    return f"{stem}.{segment}{dot}{suffix}"


def _numbered(rundir: Path, name: str) -> list[tuple[int, Path]]:
    """(segment, path) of the existing files of `name`, in segment order."""
    stem, dot, suffix = name.partition(".")
    pattern = re.compile(rf"^{re.escape(stem)}(?:\.(\d+))?{re.escape(dot + suffix)}$")
    found = []
    for path in rundir.iterdir() if rundir.exists() else []:
        match = pattern.match(path.name)
        if match:
            found.append((int(match.group(1) or 0), path))
    return sorted(found)


def segment_files(rundir: Path, name: str) -> list[Path]:
    """The existing files of `name` in segment order (a segment that wrote none is skipped)."""
    return [path for _, path in _numbered(rundir, name)]


def next_segment(rundir: Path, log_name: str) -> int:
    """The number of the next segment: one past the newest that started (each writes its engine log
    first)."""
    numbered = _numbered(rundir, log_name)
    return numbered[-1][0] + 1 if numbered else 0


def merge(pieces: Sequence[tuple[Sequence[int], Sequence[Frame]]]) -> tuple[list[int], list[Frame]]:
    """One frame sequence from the segments' (steps, frames), in segment order: a later segment's
    frames replace every earlier frame from its first step on."""
    steps: list[int] = []
    frames: list[Frame] = []
    for piece_steps, piece_frames in pieces:
        if len(piece_steps):
            keep = sum(1 for s in steps if s < piece_steps[0])
            steps, frames = steps[:keep], frames[:keep]
        steps += list(piece_steps)
        frames += list(piece_frames)
    return steps, frames


def checkpoints(rundir: Path, ext: str) -> list[tuple[int, Path]]:
    """(step, path) of the checkpoint files with this extension, oldest first."""
    found = []
    for path in rundir.iterdir() if rundir.exists() else []:
        match = _CHECKPOINT.match(path.name)
        if match and match.group(2) == ext:
            found.append((int(match.group(1)), path))
    return sorted(found)


SEAL = ".sha256"
DAMAGED = ".damaged"


def seal_path(path: Path) -> Path:
    return path.with_name(path.name + SEAL)


def digest(path: Path) -> str:
    """sha256 of a file's content, read in blocks."""
    value = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            value.update(block)
    return value.hexdigest()


def seal(rundir: Path, ext: str, up_to_step: int | None = None) -> None:
    """Write the seal of every complete, unsealed checkpoint (those at or before up_to_step; None: all)."""
    for step, path in checkpoints(rundir, ext):
        target = seal_path(path)
        if (up_to_step is None or step <= up_to_step) and not target.exists():
            temporary = target.with_name(target.name + ".tmp")
            try:
                temporary.write_text(digest(path) + "\n")
                os.replace(temporary, target)
            except FileNotFoundError:
                continue  # pruned meanwhile by the engine itself


def usable(rundir: Path, ext: str) -> list[tuple[int, Path]]:
    """The checkpoints written completely (sealed), oldest first; their content is not read."""
    return [(step, path) for step, path in checkpoints(rundir, ext) if seal_path(path).exists()]


def verified(path: Path) -> bool:
    """The checkpoint's content still matches its seal."""
    try:
        return seal_path(path).read_text().strip() == digest(path)
    except OSError:
        return False


def set_aside(path: Path) -> Path:
    """Rename a damaged checkpoint (and its seal) out of the way: checkpoint.<step>.<ext>.damaged."""
    target = path.with_name(path.name + DAMAGED)
    os.replace(path, target)
    if seal_path(path).exists():
        os.replace(seal_path(path), target.with_name(target.name + SEAL))
    return target


def clear(rundir: Path, ext: str) -> None:
    """Delete every checkpoint with this extension and every seal of one, orphaned or half-written
    seals included (a kill between a checkpoint's deletion and its seal's leaves a seal alone): a
    completed run keeps none. Damaged checkpoints set aside stay."""
    for path in list(rundir.iterdir()) if rundir.exists() else []:
        match = _CHECKPOINT.match(path.name)
        if match and match.group(2) in (ext, ext + SEAL, ext + SEAL + ".tmp"):
            path.unlink(missing_ok=True)


def prune(rundir: Path, ext: str, keep: int = KEEP) -> None:
    """Delete the checkpoints (and seals) older than the `keep` newest sealed ones; a newer one being
    written, and the damaged ones set aside, stay."""
    kept = usable(rundir, ext)[-keep:]
    if not kept:
        return
    for step, path in checkpoints(rundir, ext):
        if step < kept[0][0]:
            path.unlink(missing_ok=True)
            seal_path(path).unlink(missing_ok=True)
