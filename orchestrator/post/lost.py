"""Bodies lost from a run: one rule for every engine, counted from the Trajectory alone.

A body is lost from the first frame where its state is not finite (LIGGGHTS drops a sphere that
leaves its box: NaN from then on) or its centre is outside the simulation domain (YADE and cocd
carry such a body on). Each lost body is reported with the time of that frame, its time of leaving
to within one output interval.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from orchestrator.results import Trajectory

SHOWN = 5  # bodies named in a message; the rest are counted


@dataclass(frozen=True)
class Lost:
    """The lost bodies (indices into the Trajectory, in the order they left), when each left (s) and
    the index of that first frame."""

    bodies: np.ndarray
    times: np.ndarray
    frames: np.ndarray

    def __len__(self) -> int:
        return len(self.bodies)

    def message(self, advice: str = "enlarge `domain:` in the case") -> str:
        """One line: how many bodies left the domain, which and when, then `advice`; empty when none did."""
        count = len(self)
        if not count:
            return ""
        which = ", ".join(f"{int(b)} at t = {t:.4g} s" for b, t in zip(self.bodies[:SHOWN], self.times[:SHOWN]))
        more = f" and {count - SHOWN} more" if count > SHOWN else ""
        return (f"{count} {plural(count, 'body', 'bodies')} left the simulation domain "
                f"({plural(count, 'body', 'bodies')} {which}{more}); {advice}")

    def as_records(self) -> list[dict[str, float]]:
        """[{"body": index, "time_s": when it left}] in the order they left, for a run record."""
        return [{"body": int(b), "time_s": float(t)} for b, t in zip(self.bodies, self.times)]


def plural(count: int, one: str, many: str) -> str:
    return one if count == 1 else many


def lost_bodies(trajectory: Trajectory, lower: tuple[float, ...] | None = None, upper: tuple[float, ...] | None = None) -> Lost:
    """The bodies of `trajectory` whose state stops being finite or, with a domain (lower, upper),
    whose centre leaves it, each with the time of the first such frame."""
    position = trajectory.position
    gone = ~np.isfinite(position).all(axis=2)
    if lower is not None and upper is not None:
        with np.errstate(invalid="ignore"):
            gone |= ((position < np.asarray(lower)) | (position > np.asarray(upper))).any(axis=2)
    bodies = np.flatnonzero(gone.any(axis=0))
    first = gone[:, bodies].argmax(axis=0)
    order = np.argsort(first, kind="stable")
    return Lost(bodies=bodies[order], times=np.asarray(trajectory.time)[first[order]], frames=first[order])


def drop_lost(trajectory: Trajectory, lost: Lost) -> None:
    """Make each lost body's state NaN from the first frame it is lost, in place (YADE and cocd carry
    a body on outside the domain; LIGGGHTS already dropped it), so every engine's result reads alike."""
    for body, first in zip(lost.bodies, lost.frames):
        for states in (trajectory.position, trajectory.velocity, trajectory.angular_velocity, trajectory.orientation):
            states[first:, body] = np.nan


class NoBodyLeft(ValueError):
    """Every body of a result was lost by its last frame: there is nothing to measure."""


def require_bodies(final: np.ndarray, what: str) -> None:
    """NoBodyLeft naming `what` when none of the final body centres (B, 3) is a number."""
    if not np.isfinite(final).all(axis=1).any():
        raise NoBodyLeft(f"{what}: all {len(final)} {plural(len(final), 'body was', 'bodies were')} lost by the last frame "
                         "(they left the simulation domain or their state is not a number); no metric can be measured")
