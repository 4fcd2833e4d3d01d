"""The engines this package can drive, each with what it can do: one dict, one error listing them.

Everything outside `engines/` asks this table for a capability (`capabilities(name).clumps`) and
never compares engine names, so adding an engine is one folder under `engines/` and one entry here.
It is a leaf: it imports nothing from the package (an adapter is named as "module:Class" and
imported on first use, by `engines.adapter_class`), so the case model can read its engine choices
from it without loading any engine code.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Any


@dataclass(frozen=True)
class Capabilities:
    """What an engine can run; the case validation, the studies and the CLI read these.

    clumps: rigid clumps of spheres (multisphere bodies).
    mixed_bodies: spheres and clumps in one case.
    meshes: STL walls (rectangles are always supported).
    mpi: one run split over MPI processes (`demorch --mpi N`).
    restart: writes its whole state (`save_state`) and starts a case from it (`initial_state`),
        contact history included.
    compiled_law: the bilinear law of Richefeu et al. (2012) runs as compiled code; without it the
        engine emulates the law with a spring-dashpot of the same loading stiffness and restitution.
    implicit: contact dynamics without stiffness (e_n², k_n and k_t unused); its step is
        `default_step`, not a fraction of a contact duration.
    state_file: the file `save_state` writes in the run directory (None: no restart file).
    contact_output: records every contact at each frame (`record_contacts`: results.h5 /contacts),
        except between bodies of the `unrecorded_kinds`.
    bilinear_only_kinds: kinds whose bodies it makes touch by the bilinear law only.
    one_rounding_kinds: kinds whose bodies must all share one `rounding` in a case.
    shape_kinds: the kinds of body shape it takes (orchestrator/shapes: clump, superquadric, rounded_box).
    mixed_kinds: bodies of several of those kinds in one case (a clump beside a superquadric).
    glued_kinds: the kinds of body it can glue in place (`bodies.clumps[i].fixed`).
    preferred_brick: the kind of brick the avalanche studies use on it unless told (chosen by
        measurement: docs/bricks.md).
    brick_fallbacks: the kinds, in order, a study gets where its settings refuse the preferred one
        (a linear law or recorded contacts for a kind in bilinear_only_kinds or unrecorded_kinds);
        a clump after them, and for a bevelled brick.
    """

    clumps: bool
    mixed_bodies: bool
    meshes: bool
    mpi: bool
    restart: bool
    compiled_law: bool
    implicit: bool
    default_step: float | None = None
    state_file: str | None = None
    contact_output: bool = False
    unrecorded_kinds: tuple[str, ...] = ()
    bilinear_only_kinds: tuple[str, ...] = ()
    one_rounding_kinds: tuple[str, ...] = ()
    shape_kinds: tuple[str, ...] = ("clump",)
    mixed_kinds: bool = False
    glued_kinds: tuple[str, ...] = ()
    preferred_brick: str = "clump"
    brick_fallbacks: tuple[str, ...] = ()


@dataclass(frozen=True)
class EngineEntry:
    name: str
    adapter: str  # "module:Class", imported on first use
    capabilities: Capabilities
    summary: str
    # Micro-cases of the parity matrix (orchestrator.parity) this engine is known to miss: why, and
    # the value measured (dated in the docs' parity table).
    parity_gaps: tuple[tuple[str, str], ...] = ()
    # The same for its fallback bricks (capabilities.brick_fallbacks), which the matrix does not run:
    # kind → (brick-on-brick case, what was measured).
    fallback_gaps: tuple[tuple[str, tuple[tuple[str, str], ...]], ...] = ()


ENGINES: dict[str, EngineEntry] = {
    entry.name: entry
    for entry in (
        EngineEntry(
            "liggghts",
            "orchestrator.engines.liggghts.adapter:LiggghtsAdapter",
            Capabilities(clumps=True, mixed_bodies=False, meshes=True, mpi=True, restart=True, compiled_law=True,
                         implicit=False, state_file="state.restart", contact_output=True,
                         unrecorded_kinds=("rounded_box",), bilinear_only_kinds=("rounded_box",),
                         one_rounding_kinds=("rounded_box",), shape_kinds=("clump", "superquadric", "rounded_box"), glued_kinds=("clump", "superquadric", "rounded_box"),
                         preferred_brick="rounded_box", brick_fallbacks=("superquadric",)),
            "LIGGGHTS 3.8 (Debian), the bilinear law as a compiled plugin",
            fallback_gaps=(("superquadric", (
                ("brick on brick, aligned_y, 40.2°", "slides 0.234 m: one superquadric contact under a face tilts to carry the "
                 "friction's moment, and across the 15 mm width that tilt lowers the friction angle (2026-12-02)"),
                ("brick on brick, offset_x_3.9mm, 40.2°", "slides 0.023 m: as across the width (2026-12-02)"))),),
        ),
        EngineEntry(
            "yade",
            "orchestrator.engines.yade.adapter:YadeAdapter",
            Capabilities(clumps=True, mixed_bodies=True, meshes=True, mpi=False, restart=False, compiled_law=False,
                         implicit=False, contact_output=True, glued_kinds=("clump",)),
            "YADE 2023.02a (Debian), the bilinear law emulated by a dashpot",
            (("sphere on a mesh, shared edge", "e² 0.414: a sphere is met once per facet it touches (two here)"),
             ("sphere on a mesh, shared vertex", "e² 0.299: a sphere is met once per facet it touches (four here)"),
             *((f"brick on brick, {placement}, 40.2°", f"slides {slide} m: the clump's faces are rows of spheres that "
                "interlock or roll over each other (2026-12-02)")
               for placement, slide in (("aligned", "0.0050"), ("aligned_y", "0.35"), ("offset_x_3.9mm", "0.0015"),
                                        ("yaw_90deg", "0.26"), ("yaw_30deg", "0.0043"))),
             ("brick on brick, aligned, 47°", "a = 2.98 × Coulomb's: the upper clump tips off the lower one's edge "
              "while sliding (2026-12-02)")),
        ),
        EngineEntry(
            "cocd",
            "orchestrator.engines.cocd.adapter:CocdAdapter",
            # The erodible-bed study's 2D step (no stiffness, so no contact duration to scale from).
            Capabilities(clumps=False, mixed_bodies=False, meshes=False, mpi=False, restart=False, compiled_law=False,
                         implicit=True, default_step=1e-3),
            "convex contact dynamics of this package (spheres, implicit)",
        ),
    )
}

ENGINE_NAMES: tuple[str, ...] = tuple(ENGINES)
DEFAULT_ENGINE = ENGINE_NAMES[0]

# The case model's `engine` field: one member per registered engine.
Engine = Enum("Engine", {name: name for name in ENGINE_NAMES}, type=str)  # type: ignore[misc]
Engine.__doc__ = "An engine of the table (orchestrator.capabilities.ENGINES)."
Engine.__str__ = lambda self: self.value  # type: ignore[method-assign]


class UnknownEngine(ValueError):
    """A name that is not in the registry; the message lists the engines that exist."""


def entry(name: str | Enum) -> EngineEntry:
    key = name.value if isinstance(name, Enum) else name
    try:
        return ENGINES[key]
    except KeyError:
        raise UnknownEngine(f"unknown engine {key!r}; allowed: {', '.join(ENGINE_NAMES)}") from None


def capabilities(name: str | Enum) -> Capabilities:
    return entry(name).capabilities


def refused_kinds(name: str | Enum, law: str, record_contacts: bool) -> dict[str, str]:
    """Shape kind → the setting that refuses it on this engine: `record_contacts` (a kind in
    unrecorded_kinds, while contacts are recorded) or `contacts.law` (a kind in bilinear_only_kinds,
    under another law than the bilinear one)."""
    can = capabilities(name)
    refused = {kind: "contacts.law" for kind in can.bilinear_only_kinds if law != "bilinear"}
    refused.update({kind: "record_contacts" for kind in can.unrecorded_kinds if record_contacts})
    return refused


def brick_gaps(name: str | Enum, kind: str | None = None) -> tuple[str, ...]:
    """The brick-on-brick micro-cases the engine's brick of `kind` misses (default: its preferred
    brick, whose gaps are its parity gaps; a fallback's are its `fallback_gaps`), each as "case:
    what was measured": one brick on another's face should hold below atan μ and slide above it at
    Coulomb's acceleration (docs/bricks.md, "Brick on brick")."""
    found = entry(name)
    if kind is None or kind == found.capabilities.preferred_brick:
        gaps = found.parity_gaps
    else:
        gaps = dict(found.fallback_gaps).get(kind, ())
    return tuple(f"{case}: {why}" for case, why in gaps if case.startswith("brick on brick"))


def engines_with(**wanted: Any) -> tuple[str, ...]:
    """Names of the engines whose capabilities match every keyword, e.g. engines_with(clumps=True)."""
    return tuple(n for n, e in ENGINES.items() if all(getattr(e.capabilities, k) == v for k, v in wanted.items()))

