"""Convex Optimization Contact Dynamics (Martin et al. 2022): one convex program per time step.

Unknowns: the velocities of the mobile spheres after the step, u = (v, w) per body with w = r ω
(the rotation in m/s, so every unknown has the same scale). With U = uᵏ + Δt M⁻¹ f_ext (the free
flight), the step solves

    minimise ½ uᵀ M u − uᵀ M U   subject to, per contact a,   ‖μ_a P_a A_a u‖ ≤ D_a / Δt + ∇D_a · u

A_a u is the relative velocity at the contact point, P_a its projection on the tangent plane, D_a
the gap and ∇D_a · u = u_n its rate: a second-order cone per contact (in 2D, where the tangent is a
line, two linear rows). Then cᵏ⁺¹ = cᵏ + Δt vᵏ⁺¹. The cone keeps the linearised gap D + Δt u_n ≥ 0,
and for spheres the true gap after the step is never below the linearised one (distance is convex),
so grains do not interpenetrate beyond the solver's tolerance. Contacts are perfectly inelastic; a
sliding contact dilates by μ |u_t| Δt (the convexification's known artefact). There is no rolling
resistance: rolling grains do not stop by themselves.

In 2D (`planar`) the grains are discs, as in the study's 2D simulations: mass ρ π r² per metre of
thickness (`disc_mass`, applied when a deck is loaded) and inertia ½ m r²; a sphere kept in a plane
would roll with ⅖ m r² and weigh ∝ r³.

Masses are divided by their mean and the cone by Δt is already in velocity units, so the program is
well scaled whatever the grain size. Solvers (called directly with scipy.sparse matrices): Clarabel
(interior point, the reference), SCS (first order, for large 3D problems), PIQP (2D only: a QP) and
mehrotra (2D only: this package's interior point on the normal equations with CHOLMOD, warm-started
from the previous step's impulses carried by contact identity; mehrotra.py), the 2D default
(engine_sections.CocdSettings.resolved).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from orchestrator.engine_sections import COCD_PLANAR_ONLY as PLANAR_ONLY
from orchestrator.engine_sections import COCD_SOLVERS as SOLVERS
from orchestrator.engines.cocd import mehrotra


@dataclass
class Walls:
    """Rectangles with orthogonal edges: origin (W, 3), edges (W, 3) each, names; `active` per wall."""

    origin: np.ndarray
    edge1: np.ndarray
    edge2: np.ndarray
    mu: np.ndarray  # (W, n_materials): friction of each wall with each body material
    names: list[str]
    active: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))

    def closest(self, k: int, centres: np.ndarray) -> np.ndarray:
        """Closest points of wall k to each centre (N, 3)."""
        relative = centres - self.origin[k]
        s = np.clip(relative @ self.edge1[k] / (self.edge1[k] @ self.edge1[k]), 0.0, 1.0)
        t = np.clip(relative @ self.edge2[k] / (self.edge2[k] @ self.edge2[k]), 0.0, 1.0)
        return self.origin[k] + s[:, None] * self.edge1[k] + t[:, None] * self.edge2[k]


@dataclass
class Scene:
    """Everything the stepper needs; arrays over all bodies (fixed ones included), in case order."""

    position: np.ndarray  # (N, 3)
    velocity: np.ndarray  # (N, 3)
    spin: np.ndarray  # (N, 3) angular velocity
    radius: np.ndarray  # (N,)
    mass: np.ndarray  # (N,)
    material: np.ndarray  # (N,) material index
    fixed: np.ndarray  # (N,) glued bodies never move
    mu: np.ndarray  # (n_materials, n_materials)
    walls: Walls
    gravity: np.ndarray  # (3,)
    planar: bool  # 2D: motion in the x-z plane (unknowns vx, vz, r ω_y)
    # the last step's contact keys (C,) and impulses (C, 2) in the solver's units, for a warm start (2D)
    impulses: tuple[np.ndarray, np.ndarray] | None = None

    def contact_keys(self, contacts: "Contacts") -> np.ndarray:
        """One integer per contact naming its pair: body i against body j, or against wall k (j = -1 - k)."""
        bodies = len(self.radius)
        other = np.where(contacts.j >= 0, contacts.j, bodies - 1 - contacts.j)
        return contacts.i.astype(np.int64) * (bodies + len(self.walls.names)) + other


@dataclass
class Contacts:
    """Candidate contacts of one step: body i against body j (j = -1 - k for wall k)."""

    i: np.ndarray
    j: np.ndarray
    normal: np.ndarray  # (C, 3) unit, from i towards the other
    gap: np.ndarray  # (C,)
    mu: np.ndarray  # (C,)


@dataclass
class StepStats:
    contacts: int
    iterations: int
    solve_s: float
    missed: int  # contacts found penetrating after the step that were not candidates (the step was redone)
    unresolved: int  # such contacts left after the last retry (the step went on with them)
    smallest_gap: float  # the smallest sphere/sphere gap after the step (negative: overlap)
    # the answer's optimality measures (mehrotra.measures; 2D only, NaN in 3D or without contacts)
    primal: float = math.nan
    dual: float = math.nan
    gap: float = math.nan


def find_contacts(scene: Scene, dt: float, scale: float = 1.0) -> Contacts:
    """Pairs (one mobile at least) and sphere/wall pairs that may touch within this step.

    A pair is a candidate when its gap is below `scale` × (the distance the two can close in one
    step, Δt (|v_i| + |v_j| + 2 g Δt), plus 5 % of the mean radius): per pair, so that the fast
    grains of a flow do not make every slow pair of the deposit a candidate.
    """
    mobile = ~scene.fixed
    reach = dt * (np.linalg.norm(scene.velocity, axis=1) + float(np.linalg.norm(scene.gravity)) * dt)
    reach[scene.fixed] = 0.0
    slack = 0.05 * float(scene.radius.mean())
    margin = scale * (2.0 * float(reach.max()) + slack)
    tree = cKDTree(scene.position)
    pairs = tree.query_pairs(2.0 * float(scene.radius.max()) + margin, output_type="ndarray")
    if len(pairs):
        pairs = pairs[mobile[pairs[:, 0]] | mobile[pairs[:, 1]]]
        # a mobile body first, so that `i` always has unknowns
        swap = ~mobile[pairs[:, 0]]
        pairs[swap] = pairs[swap][:, ::-1]
        d = scene.position[pairs[:, 1]] - scene.position[pairs[:, 0]]
        distance = np.linalg.norm(d, axis=1)
        gap = distance - scene.radius[pairs[:, 0]] - scene.radius[pairs[:, 1]]
        keep = gap < scale * (reach[pairs[:, 0]] + reach[pairs[:, 1]] + slack)
        pairs, d, distance, gap = pairs[keep], d[keep], distance[keep], gap[keep]
        i, j, normal = pairs[:, 0], pairs[:, 1], d / distance[:, None]
        mu = scene.mu[scene.material[i], scene.material[j]]
    else:
        i = j = np.zeros(0, int)
        normal, gap, mu = np.zeros((0, 3)), np.zeros(0), np.zeros(0)
    parts = [(i, j, normal, gap, mu)]
    index = np.flatnonzero(mobile)
    for k in np.flatnonzero(scene.walls.active):
        centres = scene.position[index]
        towards = scene.walls.closest(k, centres) - centres
        distance = np.linalg.norm(towards, axis=1)
        wall_gap = distance - scene.radius[index]
        near = (wall_gap < scale * (reach[index] + slack)) & (distance > 0)
        bodies = index[near]
        parts.append((bodies, np.full(len(bodies), -1 - k), towards[near] / distance[near, None], wall_gap[near],
                      scene.walls.mu[k, scene.material[bodies]]))
    return Contacts(*(np.concatenate([p[n] for p in parts]) for n in range(5)))


def tangents(normal: np.ndarray, planar: bool) -> list[np.ndarray]:
    """Unit tangent directions per contact: one in the x-z plane (2D), two (3D)."""
    if planar:
        return [np.stack([normal[:, 2], np.zeros(len(normal)), -normal[:, 0]], axis=1)]
    helper = np.where(np.abs(normal[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    first = np.cross(normal, helper)
    first /= np.linalg.norm(first, axis=1)[:, None]
    return [first, np.cross(normal, first)]


class Layout:
    """Where each mobile body's unknowns sit in u: 6 per body in 3D (v, w), 3 in 2D (vx, vz, w_y)."""

    def __init__(self, scene: Scene):
        self.mobile = np.flatnonzero(~scene.fixed)
        self.slot = np.full(len(scene.fixed), -1)
        self.slot[self.mobile] = np.arange(len(self.mobile))
        self.planar = scene.planar
        self.width = 3 if scene.planar else 6
        self.size = self.width * len(self.mobile)

    def columns(self, bodies: np.ndarray, vector: np.ndarray, rotation: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(valid rows, columns, values) of the linear form vector · (v or w) of `bodies`; walls (negative
        ids) and glued bodies have no unknowns and give no entries."""
        slot = np.where(bodies >= 0, self.slot[np.maximum(bodies, 0)], -1) if len(bodies) else np.zeros(0, int)
        valid = np.flatnonzero(slot >= 0)
        base = slot[valid] * self.width
        if self.planar:
            if rotation:
                return valid, base + 2, vector[valid, 1]
            rows = np.concatenate([valid, valid])
            return rows, np.concatenate([base, base + 1]), np.concatenate([vector[valid, 0], vector[valid, 2]])
        offset = 3 if rotation else 0
        rows = np.repeat(valid, 3)
        cols = (base[:, None] + offset + np.arange(3)).ravel()
        return rows, cols, vector[valid].ravel()

    def pack(self, velocity: np.ndarray, w: np.ndarray) -> np.ndarray:
        v, w = velocity[self.mobile], w[self.mobile]
        return np.stack([v[:, 0], v[:, 2], w[:, 1]], axis=1).ravel() if self.planar else np.hstack([v, w]).ravel()

    def unpack(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(v, w) of the mobile bodies, (n, 3) each."""
        block = u.reshape(len(self.mobile), self.width)
        if self.planar:
            zero = np.zeros(len(self.mobile))
            return np.stack([block[:, 0], zero, block[:, 1]], axis=1), np.stack([zero, block[:, 2], zero], axis=1)
        return block[:, :3], block[:, 3:]


def _linear_rows(layout: Layout, contacts: Contacts, direction: np.ndarray, with_rotation: bool) -> sp.csr_matrix:
    """One row per contact: the relative velocity of the other body w.r.t. body i along `direction`.

    u_rel = v_j - w_j × n - v_i - w_i × n (w = r ω); d · (w × n) = w · (n × d).
    """
    count = len(contacts.i)
    blocks = [layout.columns(contacts.i, -direction, False), layout.columns(contacts.j, direction, False)]
    if with_rotation:
        arm = np.cross(contacts.normal, direction)
        blocks += [layout.columns(contacts.i, -arm, True), layout.columns(contacts.j, -arm, True)]
    rows = np.concatenate([b[0] for b in blocks])
    cols = np.concatenate([b[1] for b in blocks])
    values = np.concatenate([b[2] for b in blocks])
    return sp.csr_matrix((values, (rows, cols)), shape=(count, layout.size))


SPHERE_INERTIA = 0.4  # I / (m r²) of a solid sphere
DISC_INERTIA = 0.5  # I / (m r²) of a solid disc (a cylinder about its axis)
UNIT_THICKNESS = 1.0  # m: a 2D grain is a disc of this thickness (masses in kg per metre of thickness)


def disc_mass(sphere_mass: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Mass (kg per metre of thickness, UNIT_THICKNESS) of the disc of each sphere's radius and density:
    ρ π r² · 1 m = m_sphere · 3 / (4 r). Shapes (N,); the 2D grain of the study's simulations."""
    return sphere_mass * 3.0 / (4.0 * radius) * UNIT_THICKNESS


def mass_diagonal(scene: Scene, layout: Layout) -> np.ndarray:
    """Diagonal of M over the unknowns, divided by the mean mass: m for v, I/r² for w, with
    I/r² = 0.5 m for a 2D grain (a disc) and 0.4 m in 3D (a sphere)."""
    m = scene.mass[layout.mobile] / scene.mass[layout.mobile].mean()
    if layout.planar:
        return np.stack([m, m, DISC_INERTIA * m], axis=1).ravel()
    return np.stack([m, m, m, *([SPHERE_INERTIA * m] * 3)], axis=1).ravel()


def solve(P: sp.csc_matrix, q: np.ndarray, A: sp.csc_matrix, b: np.ndarray, cones: list[int], linear: int, solver: str,
          tolerance: float, warm: tuple[np.ndarray, np.ndarray] | None = None) -> mehrotra.Solution:
    """min ½ xᵀPx + qᵀx  s.t.  A x + s = b, s in (`linear` nonnegative rows, then SOCs of the sizes in `cones`).

    `warm` (x0, z0) is used by mehrotra only. The answer's measures are NaN where there are cones."""
    if solver in PLANAR_ONLY and cones:
        raise ValueError(f"{solver} solves 2D (planar) cases only: 3D cones are not linear")
    if solver == "mehrotra":
        return mehrotra.solve(P.diagonal(), q, A, b, tolerance, warm)
    if solver == "clarabel":
        import clarabel

        settings = clarabel.DefaultSettings()
        settings.verbose = False
        settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = tolerance
        cone_list = ([clarabel.NonnegativeConeT(linear)] if linear else []) + [clarabel.SecondOrderConeT(n) for n in cones]
        result = clarabel.DefaultSolver(sp.triu(P).tocsc(), q, A, b, cone_list, settings).solve()
        if str(result.status) not in ("Solved", "AlmostSolved"):
            raise RuntimeError(f"Clarabel: {result.status}")
        x, z, iterations = np.asarray(result.x), np.asarray(result.z), int(result.iterations)
    elif solver == "scs":
        import scs

        data = {"P": sp.triu(P).tocsc(), "A": A, "b": b, "c": q}
        cone = {"l": linear, "q": list(cones)}
        result = scs.SCS(data, cone, eps_abs=tolerance, eps_rel=tolerance, verbose=False).solve()
        if result["info"]["status"] not in ("solved", "solved_inaccurate"):
            raise RuntimeError(f"SCS: {result['info']['status']}")
        x, z, iterations = np.asarray(result["x"]), np.asarray(result["y"]), int(result["info"]["iter"])
    elif solver == "piqp":
        import piqp

        engine = piqp.SparseSolver()
        engine.settings.eps_abs = engine.settings.eps_rel = tolerance
        engine.settings.verbose = False
        engine.setup(sp.triu(P).tocsc(), q, G=A, h_u=b)  # A x ≤ b (piqp ≥ 0.6: two-sided G rows)
        status = engine.solve()
        if status.name not in ("PIQP_SOLVED",):
            raise RuntimeError(f"PIQP: {status}")
        x, z, iterations = np.asarray(engine.result.x), np.asarray(engine.result.z_u), int(engine.result.info.iter)
    else:
        raise ValueError(f"unknown solver {solver!r}; allowed: {', '.join(SOLVERS)}")
    measured = mehrotra.answer_measures(P.diagonal(), q, A, b, x, z) if not cones else (math.nan,) * 3
    return mehrotra.Solution(x, z, iterations, *measured)


def assemble(scene: Scene, layout: Layout, contacts: Contacts, dt: float) -> tuple[sp.csc_matrix, np.ndarray, list[int], int]:
    """(A, b, cone sizes, linear rows) of the contact cones, in the solver's A x + s = b form."""
    count = len(contacts.i)
    if count == 0:
        return sp.csc_matrix((0, layout.size)), np.zeros(0), [], 0
    normal_rows = _linear_rows(layout, contacts, contacts.normal, with_rotation=False)  # u_n
    tangent_rows = [_linear_rows(layout, contacts, t, with_rotation=True) for t in tangents(contacts.normal, scene.planar)]
    slack = contacts.gap / dt
    if scene.planar:
        # |μ u_t| ≤ D/Δt + u_n as two rows: D/Δt + u_n ∓ μ u_t ≥ 0, i.e. s = b - A x ≥ 0 with
        # A = -(u_n ∓ μ u_t), b = D/Δt
        mu = sp.diags(contacts.mu)
        A = sp.vstack([-(normal_rows - mu @ tangent_rows[0]), -(normal_rows + mu @ tangent_rows[0])]).tocsc()
        return A, np.concatenate([slack, slack]), [], 2 * count
    mu = sp.diags(contacts.mu)
    # interleave per contact: (s0, s1, s2) = (D/Δt + u_n, μ t1·u, μ t2·u)
    stacked = sp.vstack([-normal_rows, -(mu @ tangent_rows[0]), -(mu @ tangent_rows[1])]).tocsr()
    order = np.arange(3 * count).reshape(3, count).T.ravel()
    b = np.concatenate([slack, np.zeros(count), np.zeros(count)])[order]
    return stacked[order].tocsc(), b, [3] * count, 0


def step(scene: Scene, dt: float, solver: str = "clarabel", tolerance: float = 1e-8) -> StepStats:
    """Advance the scene by one step (in place). Contacts within the reach of this step are candidates;
    if a penetration appears that no candidate covered, the step is redone with a wider margin."""
    layout = Layout(scene)
    scale = 1.0
    w = scene.spin * scene.radius[:, None]
    u0 = layout.pack(scene.velocity, w)
    diagonal = mass_diagonal(scene, layout)
    free = _free_flight(u0, scene, layout, dt)
    P = sp.diags(diagonal).tocsc()
    q = -diagonal * free
    missed = 0
    for _attempt in range(3):
        contacts = find_contacts(scene, dt, scale)
        A, b, cones, linear = assemble(scene, layout, contacts, dt)
        keys = scene.contact_keys(contacts)
        started = time.perf_counter()
        if len(contacts.i):
            answer = solve(P, q, A, b, cones, linear, solver, tolerance, _warm_start(scene, keys, u0) if solver == "mehrotra" else None)
            u = answer.x
        else:
            answer = mehrotra.Solution(free, np.zeros(0), 0, math.nan, math.nan, math.nan)
            u = free
        elapsed = time.perf_counter() - started
        v, w_new = layout.unpack(u)
        new_position = scene.position.copy()
        new_position[layout.mobile] += dt * v
        pairs, gap = touching_pairs(new_position, scene.radius, scene.fixed)
        lost = _uncovered_penetrations(pairs, gap, 1e-9 * float(scene.radius.mean()), contacts)
        if lost == 0:
            break
        missed += lost
        scale *= 4.0
    unresolved = lost
    if scene.planar:
        scene.impulses = (keys, answer.z.reshape(2, -1).T.copy())
    scene.position = new_position
    scene.velocity[layout.mobile] = v
    scene.spin[layout.mobile] = w_new / scene.radius[layout.mobile, None]
    smallest = float(gap.min()) if len(gap) else math.inf
    return StepStats(len(contacts.i), answer.iterations, elapsed, missed - unresolved, unresolved, smallest,
                     answer.primal, answer.dual, answer.gap)


def _warm_start(scene: Scene, keys: np.ndarray, u0: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(x0, z0) for mehrotra: this step's velocities and, per contact row, the impulse of the same pair
    in the last step (0 for a new pair). None before a first 2D step."""
    if scene.impulses is None or not scene.planar:
        return None
    known, impulses = scene.impulses
    z = np.zeros((len(keys), 2))
    if len(known):
        order = np.argsort(known)
        found = order[np.minimum(np.searchsorted(known, keys, sorter=order), len(known) - 1)]
        same = known[found] == keys
        z[same] = impulses[found[same]]
    return u0, z.T.ravel()


def _free_flight(u0: np.ndarray, scene: Scene, layout: Layout, dt: float) -> np.ndarray:
    """U = uᵏ + Δt M⁻¹ f_ext: gravity on the translations only."""
    gravity = np.zeros(layout.width)
    if scene.planar:
        gravity[:2] = scene.gravity[[0, 2]]
    else:
        gravity[:3] = scene.gravity
    return u0 + dt * np.tile(gravity, len(layout.mobile))


def touching_pairs(position: np.ndarray, radius: np.ndarray, fixed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(pairs, gaps) of the sphere pairs within reach of touching, at least one of them mobile."""
    pairs = cKDTree(position).query_pairs(2.0 * float(radius.max()), output_type="ndarray")
    if len(pairs):
        pairs = pairs[~(fixed[pairs[:, 0]] & fixed[pairs[:, 1]])]
    gap = np.linalg.norm(position[pairs[:, 1]] - position[pairs[:, 0]], axis=1) - radius[pairs[:, 0]] - radius[pairs[:, 1]] if len(pairs) else np.zeros(0)
    return pairs, gap


def _uncovered_penetrations(pairs: np.ndarray, gap: np.ndarray, tolerance: float, contacts: Contacts) -> int:
    """Pairs overlapping after the step (beyond `tolerance`) that were not candidates."""
    overlapping = pairs[gap < -tolerance]
    if len(overlapping) == 0:
        return 0
    known = set(zip(np.minimum(contacts.i, contacts.j).tolist(), np.maximum(contacts.i, contacts.j).tolist()))
    return sum((min(a, b), max(a, b)) not in known for a, b in overlapping.tolist())


def smallest_gap(scene: Scene) -> float:
    """The smallest sphere/sphere gap in the scene (negative: overlap), over pairs with a mobile body."""
    _, gap = touching_pairs(scene.position, scene.radius, scene.fixed)
    return float(gap.min()) if len(gap) else math.inf
