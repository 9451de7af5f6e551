"""The friction phase's limit where the spin damping is no QP (``models/exact/reference.py``): a damped direction n
that is no eigenvector of its body's inverse inertia (rotated non-cube bodies, full 3x3 I^-1).

The friction pass moves velocities along ``M^-1 J_t^T`` (the friction impulses) and the damping moves w along the
damped directions n themselves (``w -= 0.1 (n.w) n``). Every state the passes reach from u1 is therefore
``u = u1 - M^-1 J_t^T lam - N^T sigma`` (N the spin rows, orthonormal per body, sigma what the damping has
accumulated), and at a fixed point ``N u = 0``, so ``sigma = N (u1 - M^-1 J_t^T lam)`` and

    u(lam) = Pi (u1 - M^-1 J_t^T lam),   Pi = 1 - N^T N   (the Euclidean projection removing the damped w),

with each friction row at its box's natural condition: ``lam = clip(lam + r / Kt, -L, L)``, ``r = J_t u(lam) + c``
the tangent velocity the pass reads. That is the box-constrained linear complementarity problem

    r(lam) = b - A lam,   A = J_t Pi M^-1 J_t^T,   b = J_t Pi u1 + c,

with A not symmetric where Pi and M^-1 do not commute (the QP's stationarity would move w along ``M^-1 N^T``
instead: a fixed point of the pass map, but one the passes cannot reach from u1). A's symmetric part need not be
positive semidefinite, so there is no convex program and no uniqueness guarantee; it is solved by a semismooth
Newton iteration on the natural residual (rows whose projected update lands on a bound fixed there, the others
solving ``A_FF lam_F = b_F - A_FB lam_B``, a backtracking line search on the residual's norm), started from the
convex QP's solution, and kept only when every row's natural residual ``Kt |lam - clip(lam + r / Kt, -L, L)|`` is at
most ``DAMPED_ACCEPT`` m/s. No distance certificate: a small natural residual certifies a fixed point of the passes
(``models/tests/test_exact_reference.py`` checks one pass moves nothing), not that it is the only one.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from models.exact.assembly import ExactReferenceError, Mass

DAMPED_MAX_ITERATIONS = 60
DAMPED_TARGET = 1e-13  # m/s: the Newton iteration stops at this natural residual
DAMPED_ACCEPT = 1e-9  # m/s: the solution is kept when its natural residual is at most this
DAMPED_REGULARIZATION = 1e-13  # relative to the largest |diagonal| of the reduced system (singular A_FF)
DAMPED_REFINEMENTS = 6
DAMPED_KEY = "friction phase: non-symmetric box problem (damping off the inertia's eigenvectors)"


def damped_friction_phase(J: sp.csr_matrix, c: np.ndarray, N: sp.csr_matrix, mass: Mass, u1: np.ndarray,
                          limit: np.ndarray, start: np.ndarray, info: dict[str, float],
                          why: str) -> tuple[np.ndarray, np.ndarray]:
    """(friction impulse per row of J, velocities u(lam)) of the friction phase's fixed point on these columns;
    ExactReferenceError (with ``why``, the spin row that makes it no QP) when the iteration does not certify."""
    Pi = (sp.identity(u1.shape[0], format="csr") - N.T @ N).tocsr()
    B = (Pi @ mass.inv).tocsr()
    A = (J @ B @ J.T).tocsc()
    b = J @ (Pi @ u1) + c
    kt = mass.row_norms2(J)
    lam, res, its = _newton(A, b, kt, limit, np.clip(start, -limit, limit))
    info[f"{DAMPED_KEY} Newton iterations"] = max(info.get(f"{DAMPED_KEY} Newton iterations", 0), its)
    info[f"{DAMPED_KEY} natural residual (m/s)"] = max(info.get(f"{DAMPED_KEY} natural residual (m/s)", 0.0), res)
    if not res <= DAMPED_ACCEPT:
        raise ExactReferenceError(f"{why}: the friction phase's non-symmetric box problem stopped at a natural "
                                  f"residual of {res:.1e} m/s after {its} Newton iterations, above the "
                                  f"{DAMPED_ACCEPT:g} accepted")
    return lam, Pi @ (u1 - mass.inv @ (J.T @ lam))


def natural(A: sp.csc_matrix, b: np.ndarray, kt: np.ndarray, limit: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Per row ``Kt |lam - clip(lam + (b - A lam) / Kt, -L, L)|`` (m/s)."""
    return kt * np.abs(lam - np.clip(lam + (b - A @ lam) / kt, -limit, limit))


def regularized_solve(A: sp.csc_matrix, rhs: np.ndarray, x0: np.ndarray, regularization: float,
                      refinements: int) -> np.ndarray:
    """x with ``A x = rhs`` for a possibly singular sparse A: LU of ``A + reg I`` (reg = ``regularization`` times the
    largest |diagonal|), then ``refinements`` steps of iterative refinement on A itself, from ``x0``."""
    from scipy.sparse.linalg import splu

    reg = regularization * float(np.abs(A.diagonal()).max(initial=1.0))
    lu = splu((A + reg * sp.identity(A.shape[0], format="csc")).tocsc())
    x = x0.copy()
    for _ in range(refinements):
        x = x + lu.solve(rhs - A @ x)
    return x


def _newton(A: sp.csc_matrix, b: np.ndarray, kt: np.ndarray, limit: np.ndarray,
            lam: np.ndarray) -> tuple[np.ndarray, float, int]:
    res = natural(A, b, kt, limit, lam)
    merit = float(res @ res)
    for it in range(DAMPED_MAX_ITERATIONS):
        if float(res.max(initial=0.0)) <= DAMPED_TARGET:
            return lam, float(res.max(initial=0.0)), it
        step = lam + (b - A @ lam) / kt
        at_lo, at_hi = step <= -limit, step >= limit
        free = ~(at_lo | at_hi)
        cand = np.where(at_lo, -limit, np.where(at_hi, limit, lam))
        f = np.flatnonzero(free)
        if f.size:
            cand[f] = regularized_solve(A[f][:, f].tocsc(), b[f] - A[f] @ np.where(free, 0.0, cand), cand[f],
                                        DAMPED_REGULARIZATION, DAMPED_REFINEMENTS)
        cand = np.clip(cand, -limit, limit)
        t = 1.0
        while t >= 1e-6:
            trial = lam + t * (cand - lam)
            trial_res = natural(A, b, kt, limit, trial)
            if float(trial_res @ trial_res) < merit:
                break
            t *= 0.5
        else:
            return lam, float(res.max(initial=0.0)), it  # no descent: stalled
        lam, res, merit = trial, trial_res, float(trial_res @ trial_res)
    return lam, float(res.max(initial=0.0)), DAMPED_MAX_ITERATIONS
