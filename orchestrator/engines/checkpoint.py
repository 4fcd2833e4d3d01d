"""Checkpoints and segments of a run directory, the same rules for every engine.

A run writes its whole state every few output intervals as `checkpoint.<step>.<ext>` (LIGGGHTS
restart files with contact history and clumps, YADE's saved scene, cocd's arrays). A run that is
killed continues from its newest usable checkpoint in a new *segment*: segment 0 is the first
attempt, segment k the k-th continuation. Each segment writes its own outputs (frames, contacts,
engine log) under names carrying its number (`segment_name`), so nothing an earlier segment wrote
is overwritten; readers merge them, a later segment's frames replacing an earlier one's from its
first frame on (`merge`).

A checkpoint is usable once a frame after its step was written: one cut short while being written
(the engine killed in the middle) is never used. The two newest usable checkpoints are kept, older
ones are deleted (`prune`).
"""

from __future__ import annotations

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


def usable(rundir: Path, ext: str, last_frame_step: int | None) -> list[tuple[int, Path]]:
    """The checkpoints written completely: those before the last frame written, oldest first."""
    if last_frame_step is None:
        return []
    return [(step, path) for step, path in checkpoints(rundir, ext) if step < last_frame_step]


def prune(rundir: Path, ext: str, last_frame_step: int | None, keep: int = KEEP) -> None:
    """Delete the checkpoints older than the `keep` newest usable ones (a newer one being written
    stays). last_frame_step None: every checkpoint counts as complete (an engine that writes them
    through a temporary name)."""
    found = checkpoints(rundir, ext)
    kept = (found if last_frame_step is None else usable(rundir, ext, last_frame_step))[-keep:]
    if not kept:
        return
    for step, path in found:
        if step < kept[0][0]:
            path.unlink(missing_ok=True)
