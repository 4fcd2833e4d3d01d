"""Mehrotra's predictor–corrector interior point for cocd's 2D step, on the normal equations.

In 2D every contact's cone is two linear rows (solver.assemble), so the step is the QP

    minimise ½ xᵀPx + qᵀx   subject to   A x + s = b,  s ≥ 0        (P diagonal, positive)

with multipliers z ≥ 0 (the contact impulses, in the solver's scaled units). Each iteration takes a
Newton step on the perturbed KKT conditions; eliminating Δs and Δz leaves the normal equations

    (P + Aᵀ diag(z/s) A) Δx = r                                         (n × n, symmetric positive definite)

whose pattern is the contact graph's (3 × 3 blocks per touching pair) and does not change within a
step. It is analysed once per step and refactored at each iteration by CHOLMOD's supernodal Cholesky
(the copy cvxopt ships); the new values are one sparse product of the weights z/s. Two solves per
iteration: the affine (predictor) direction, then the centred and corrected one, with σ = (μ_aff/μ)³
(Mehrotra 1992, SIAM J. Optim. 2, 575–601; Nocedal & Wright 2006, Numerical Optimization, §16.6).

Stopping uses the interior-point solvers' three measures, each relative:
primal ‖Ax + s − b‖∞ ≤ ε (1 + ‖b‖∞), dual ‖Px + q + Aᵀz‖∞ ≤ ε (1 + ‖q‖∞) and the duality gap
sᵀz ≤ ε (1 + |½xᵀPx + qᵀx|).

Warm start: given the previous step's velocities and impulses (matched by contact identity in
solver.step), x starts there and s, z at those values floored at WARM_FLOOR, which keeps the start
inside the cone while the interior point can still move away from a stale active set. Measured on
steps recorded from a collapsing 2 000-grain column (2026-12-04): 15–20 % fewer iterations than the
cold start; floors of 1e-3 or below took more iterations than cold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

MAX_ITERATIONS = 80
STEP_TO_BOUNDARY = 0.99  # fraction of the largest step that keeps s, z > 0
NEIGHBOURHOOD = 1e-3  # γ: every s_i z_i stays above γ × their mean (_centred)
# z/s is capped: rows with s → 0 (a contact closed exactly, as in a static pile, where complementarity
# is not strict) otherwise make the normal equations singular in double precision. Measured on a
# 200-disc confined pile: uncapped, CHOLMOD failed at step 35; capped at 1e8, 1e10 or 1e12 all 200
# steps converged, the primal residual's floor falling from 6e-10 to 2e-12 (solver units, P ≈ 1).
D_MAX = 1e12
WARM_FLOOR = 0.1  # s, z of a warm start are at least this (solver units: m/s, the program is scaled)


@dataclass
class Solution:
    """x (n,), impulses z (m,), the iterations and the three measures at the end."""

    x: np.ndarray
    z: np.ndarray
    iterations: int
    primal: float
    dual: float
    gap: float


class NotConverged(RuntimeError):
    """The iterations stopped short of the tolerance; `iterations` were spent."""

    def __init__(self, message: str, iterations: int):
        super().__init__(message)
        self.iterations = iterations


class NormalEquations:
    """H(d) = diag(p) + Aᵀ diag(d) A for a fixed A (m × n): analysed once, refactored for each d.

    The unknowns come in groups of `block` per body (solver.Layout: v_x, v_z, r ω_y in 2D) and a row
    of A touches at most two bodies (a contact), so H is made of dense block × block blocks: one per
    body on the diagonal and one per touching pair. Its lower triangle is stored column by column
    (CHOLMOD's layout), each entry's place found by arithmetic from its two bodies. `weights` (CSC,
    one column per row of A) maps d to the triangle's values: entry e is Σ_r A[r, i] A[r, j] d_r.
    """

    def __init__(self, p: np.ndarray, A: sp.csr_matrix, block: int):
        import cvxopt
        import cvxopt.cholmod as cholmod

        self._cvxopt, self._cholmod = cvxopt, cholmod
        m, n = A.shape
        bodies = n // block
        A.sort_indices()
        count = np.diff(A.indptr)
        # every pair (a, b ≤ a) of a row's entries: with sorted indices, column a ≥ column b (the lower triangle)
        pairs_per_row = count * (count + 1) // 2
        row = np.repeat(np.arange(m), pairs_per_row)
        local = np.arange(int(pairs_per_row.sum())) - np.repeat(np.cumsum(pairs_per_row) - pairs_per_row, pairs_per_row)
        a = np.floor((np.sqrt(8.0 * local + 1.0) - 1.0) / 2.0).astype(np.int64)  # the triangle's row of `local`
        b = local - a * (a + 1) // 2
        first = np.repeat(A.indptr[:-1], pairs_per_row)
        a, b = first + a, first + b
        i, j = A.indices[a], A.indices[b]
        upper_body, lower_body = i // block, j // block  # i ≥ j, so upper_body ≥ lower_body
        # each row's two bodies (one for a wall contact): the body-level pattern below the diagonal
        # is their distinct pairs (column body, row body)
        row_low, row_high = np.zeros(m, np.int64), np.zeros(m, np.int64)
        filled = count > 0
        if filled.any():
            row_low[filled] = np.minimum.reduceat(A.indices, A.indptr[:-1][filled]) // block
            row_high[filled] = np.maximum.reduceat(A.indices, A.indptr[:-1][filled]) // block
        row_key = row_low * bodies + row_high
        pairs = np.unique(row_key[row_high > row_low])
        below = np.bincount(pairs // bodies, minlength=bodies)  # neighbour blocks below each body's diagonal block
        start = np.cumsum(below) - below
        # column c = block·B + β holds (block − β) entries of the diagonal block, then `block` per neighbour
        beta = np.tile(np.arange(block), bodies)
        length = (block - beta) + block * np.repeat(below, block)
        pointer = np.concatenate([[0], np.cumsum(length)])
        k = (np.searchsorted(pairs, row_key) - start[row_low])[row]
        place = pointer[j] + np.where(upper_body == lower_body, i - j, (block - j % block) + block * k + i % block)
        self.weights = sp.csc_matrix((A.data[a] * A.data[b], place, np.concatenate([[0], np.cumsum(np.bincount(row, minlength=m))])),
                                     shape=(int(pointer[-1]), m))
        self.diagonal = pointer[:-1]
        self.p = p
        # the pattern's row indices, column by column: the diagonal block's lower part, then each neighbour's block
        neighbours = pairs % bodies
        column_body = np.repeat(np.arange(n) // block, length)
        offset = np.arange(int(pointer[-1])) - np.repeat(pointer[:-1], length)
        in_diagonal = offset < np.repeat(block - beta, length)
        column = np.repeat(np.arange(n), length)
        slot = np.where(in_diagonal, 0, offset - np.repeat(block - beta, length))
        neighbour = np.zeros(len(column), np.int64)
        if len(neighbours):
            neighbour = neighbours[np.minimum(start[column_body] + slot // block, len(neighbours) - 1)]
        rows = np.where(in_diagonal, column + offset, block * neighbour + slot % block)
        self.matrix = cvxopt.spmatrix(cvxopt.matrix(np.ones(int(pointer[-1]))), cvxopt.matrix(rows), cvxopt.matrix(column), (n, n))
        cholmod.options["supernodal"] = 2
        self.factor = cholmod.symbolic(self.matrix, uplo="L")

    def refactor(self, d: np.ndarray) -> None:
        values = self.weights @ d
        values[self.diagonal] += self.p
        self.matrix.V = self._cvxopt.matrix(values)
        self._cholmod.numeric(self.matrix, self.factor)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        out = self._cvxopt.matrix(rhs)
        self._cholmod.solve(self.factor, out)
        return np.asarray(out).ravel()


def measures(p: np.ndarray, q: np.ndarray, b: np.ndarray, x: np.ndarray, s: np.ndarray, z: np.ndarray,
             primal_residual: np.ndarray, dual_residual: np.ndarray) -> tuple[float, float, float]:
    """(primal, dual, gap): ‖Ax + s − b‖∞ / (1 + ‖b‖∞), ‖Px + q + Aᵀz‖∞ / (1 + ‖q‖∞) and
    sᵀz / (1 + |½xᵀPx + qᵀx|), from the two residual vectors."""
    objective = 0.5 * float(x @ (p * x)) + float(q @ x)
    return (float(np.abs(primal_residual).max(initial=0.0)) / (1.0 + float(np.abs(b).max(initial=0.0))),
            float(np.abs(dual_residual).max(initial=0.0)) / (1.0 + float(np.abs(q).max(initial=0.0))),
            float(s @ z) / (1.0 + abs(objective)))


def answer_measures(p: np.ndarray, q: np.ndarray, A: sp.spmatrix, b: np.ndarray, x: np.ndarray, z: np.ndarray) -> tuple[float, float, float]:
    """The three measures of another solver's answer (x, z), with s = max(b − Ax, 0): its primal
    measure is then the infeasibility of the rows A x ≤ b."""
    slack = b - A @ x
    s = np.maximum(slack, 0.0)
    return measures(p, q, b, x, s, z, np.minimum(slack, 0.0) * -1.0, p * x + q + A.T @ z)


def _centred(s: np.ndarray, z: np.ndarray, ds: np.ndarray, dz: np.ndarray, alpha: float) -> float:
    """α shortened (by 10 % at a time, 30 times at most) until every product s_i z_i at the new point
    is at least NEIGHBOURHOOD × their mean: the wide neighbourhood of path-following methods
    (Nocedal & Wright 2006, §14.1). Without it a row's s can reach 1e-20 long before the others
    converge and block every later step. Measured 2026-12-04 on a step of the 22° collapse on a 5 mm bed
    that stalled warm-started (80 iterations, primal 9e-8): γ = 1e-5, 1e-4, 1e-3 converge in 62, 59,
    40 iterations (cold: 35); recorded column steps and a static pile take as many as without."""
    for _ in range(30):
        products = (s + alpha * ds) * (z + alpha * dz)
        if products.min() >= NEIGHBOURHOOD * products.mean():
            break
        alpha *= 0.9
    return alpha


def _largest_step(v: np.ndarray, dv: np.ndarray) -> float:
    """The largest α ≤ 1 with v + α dv ≥ 0 (v > 0)."""
    negative = dv < 0
    return min(1.0, float(np.min(-v[negative] / dv[negative]))) if negative.any() else 1.0


def solve(p: np.ndarray, q: np.ndarray, A: sp.csc_matrix, b: np.ndarray, tolerance: float,
          warm: tuple[np.ndarray, np.ndarray] | None = None, block: int = 3) -> Solution:
    """Minimise ½ xᵀ diag(p) x + qᵀx subject to A x ≤ b; p (n,) > 0, A (m × n), b (m,), the unknowns
    in groups of `block` per body and each row of A touching at most two bodies (NormalEquations).

    `warm`: (x0 (n,), z0 (m,)) from the previous step; if the warm-started run fails, the problem is
    solved again from the cold start (the iterations of both are counted). Raises RuntimeError when
    the measures are not met within MAX_ITERATIONS from the cold start, or when CHOLMOD finds the
    normal equations not positive definite.
    """
    A = A.tocsr()
    At = A.T.tocsr()
    normal = NormalEquations(p, A, block)
    if warm is not None:
        try:
            return _iterate(p, q, A, At, b, tolerance, normal, warm)
        except NotConverged as failure:
            cold = _iterate(p, q, A, At, b, tolerance, normal, None)
            cold.iterations += failure.iterations
            return cold
    return _iterate(p, q, A, At, b, tolerance, normal, None)


def _iterate(p: np.ndarray, q: np.ndarray, A: sp.csr_matrix, At: sp.csr_matrix, b: np.ndarray, tolerance: float,
             normal: NormalEquations, warm: tuple[np.ndarray, np.ndarray] | None) -> Solution:
    """Mehrotra's iterations from the cold start (warm None) or from (x0, z0); At is Aᵀ."""
    m = A.shape[0]
    if warm is None:
        normal.refactor(np.ones(m))
        x = normal.solve(At @ b - q)
        s = b - A @ x
        if s.min() <= 0.0:
            s = s - s.min() + 1.0
        z = np.ones(m)
    else:
        x = warm[0].copy()
        s = np.maximum(b - A @ x, WARM_FLOOR)
        z = np.maximum(warm[1], WARM_FLOOR)
    for iteration in range(MAX_ITERATIONS + 1):
        dual_residual = p * x + q + At @ z
        primal_residual = A @ x + s - b
        primal, dual, relative_gap = measures(p, q, b, x, s, z, primal_residual, dual_residual)
        if primal <= tolerance and dual <= tolerance and relative_gap <= tolerance:
            return Solution(x, z, iteration, primal, dual, relative_gap)
        if iteration == MAX_ITERATIONS:
            break
        d = np.minimum(z / s, D_MAX)
        mu = float(s @ z) / m
        try:
            normal.refactor(d)
        except ArithmeticError as error:
            raise NotConverged(f"mehrotra: the normal equations lost positive definiteness after {iteration} iterations ({error})",
                               iteration) from None

        def direction(complementarity: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            dx = normal.solve(-dual_residual - At @ (d * primal_residual - complementarity / s))
            dz = d * (A @ dx + primal_residual) - complementarity / s
            return dx, -(complementarity + s * dz) / z, dz

        dx, ds, dz = direction(s * z)
        alpha = min(_largest_step(s, ds), _largest_step(z, dz))
        sigma = (float((s + alpha * ds) @ (z + alpha * dz)) / m / mu) ** 3
        dx, ds, dz = direction(s * z - sigma * mu + ds * dz)
        alpha = min(1.0, STEP_TO_BOUNDARY * min(_largest_step(s, ds), _largest_step(z, dz)))
        alpha = _centred(s, z, ds, dz, alpha)
        x, s, z = x + alpha * dx, s + alpha * ds, z + alpha * dz
    raise NotConverged(f"mehrotra: not converged after {MAX_ITERATIONS} iterations (primal {primal:.1e}, dual {dual:.1e}, "
                       f"gap {relative_gap:.1e}, tolerance {tolerance:.0e})", MAX_ITERATIONS)
