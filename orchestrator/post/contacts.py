"""Force chains: what recorded contacts (results.Contacts) draw. Counts, force sums, branch vectors and
coordination numbers are methods of Contacts (stored in results.h5 with them)."""

from __future__ import annotations

import numpy as np

from orchestrator.results import Contacts


def force_chains(contacts: Contacts, position: np.ndarray, frame: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Body–body force chains of one frame: (pairs, 2, 3) m segments between the centres of touching
    bodies, and (pairs,) N the summed |normal force| between them. position: (frames, bodies, 3)."""
    keys, force = contacts.touching_pairs(frame)
    frame = frame % contacts.n_frames
    return np.stack([position[frame, keys[:, 0]], position[frame, keys[:, 1]]], axis=1), force
