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
positive semidefinite and A need not be a P-matrix (the damping step can add kinetic energy: measured on a jenga
tower beside a heap, A has real eigenvalues down to -0.009), so there is no convex program, and the problem can
have several solutions; with every bound finite it always has one.

How it is solved: ``models/exact/box_lcp.py``, per component of A (rows coupled through a shared body), each result kept
only when every row's natural residual ``Kt |lam - clip(lam + r / Kt, -L, L)|`` is at most ``DAMPED_ACCEPT`` m/s,
all **from the kernel's start** (zero friction impulses at the contact phase's limit u1, as the kernel starts its
friction passes): projected Gauss-Seidel with the kernel's row update ``lam = clip(lam + r / Kt, -L, L)`` on the
reduced problem (the damping taken to its limit at every row), Anderson-accelerated; semismooth Newton from its
iterate; complementary pivoting (Lemke's method for the box problem, ``models/exact/box_lemke.py``) from the iterate's
active set, then from every row at its lower bound (with finite bounds the pivoting path ends at a solution,
barring cycling on ties).

The first that certifies is kept; the report names it (``DAMPED_KEY`` details, and the solver line) with the
residual. **Uniqueness**: a component's solution is unique when A is a P-matrix; certified here when the symmetric
part of ``D A`` is positive definite for D = I or ``diag(A)^-1`` (then ``x^T D A x > 0`` for every x != 0, and two
solutions would give ``(x1 - x2)^T D A (x1 - x2) <= 0``: the rows' box conditions are separable, so scaling a row
by a positive d_i keeps its solutions). Where no such certificate holds, the limit is not certified unique and the
result is *the fixed point reached from the kernel's start* (steps 1-3 from it), one of possibly several; the
details count such components and ``sim/compare/exact_error.py`` names the reference so in the report.

A small natural residual certifies a fixed point of the passes (``models/tests/test_exact_reference.py`` checks
one pass moves nothing), not a distance from another one.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from models.exact.box_lcp import METHODS as BOX_METHODS, BoxProblem, Outcome, solve_box
from models.exact.box_lemke import PIVOT_ROWS_LIMIT, component_rows, one_blas_thread
from models.exact.assembly import ExactReferenceError, Mass

DAMPED_ACCEPT = 1e-9  # m/s: the solution is kept when its natural residual is at most this
DEFAULT_TIME_S = 60.0
DAMPED_KEY = "friction phase: non-symmetric box problem (damping off the inertia's eigenvectors)"
METHODS = tuple(f"{m} from the kernel's start" if k == 0 else m for k, m in enumerate(BOX_METHODS))
NOT_UNIQUE = "components not certified unique (the fixed point reached from the kernel's start)"


def damped_friction_phase(J: sp.csr_matrix, c: np.ndarray, N: sp.csr_matrix, mass: Mass, u1: np.ndarray,
                          limit: np.ndarray, info: dict[str, float], why: str,
                          time_s: float = DEFAULT_TIME_S) -> tuple[np.ndarray, np.ndarray]:
    """(friction impulse per row of J, velocities u(lam)) of the friction phase's fixed point on these columns;
    ExactReferenceError (with ``why``, the spin row that makes it no QP) when no method certifies."""
    deadline = time.monotonic() + max(time_s, 0.0)
    Pi = (sp.identity(u1.shape[0], format="csr") - N.T @ N).tocsr()
    B = (Pi @ mass.inv).tocsr()
    prob = BoxProblem((J @ B @ J.T).tocsr(), J @ (Pi @ u1) + c, mass.row_norms2(J), -limit, limit)
    with one_blas_thread():
        lam, res, out = solve_box(prob, np.zeros(limit.shape[0]), DAMPED_ACCEPT, deadline)
        components = component_rows(prob.A)
        not_unique = sum(1 for rows in components if not certified_unique(prob.A[rows][:, rows]))
    _record(info, out, res, len(components), not_unique)
    if not res <= DAMPED_ACCEPT:
        raise ExactReferenceError(f"{why}: the friction phase's non-symmetric box problem stopped at a natural "
                                  f"residual of {res:.1e} m/s, above the {DAMPED_ACCEPT:g} accepted ("
                                  + "; ".join(out.failures) + ")")
    return lam, Pi @ (u1 - mass.inv @ (J.T @ lam))


def _record(info: dict[str, float], out: Outcome, res: float, components: int, not_unique: int) -> None:
    def add(key: str, value: float) -> None:
        info[f"{DAMPED_KEY} {key}"] = info.get(f"{DAMPED_KEY} {key}", 0) + value

    info[f"{DAMPED_KEY} natural residual (m/s)"] = max(info.get(f"{DAMPED_KEY} natural residual (m/s)", 0.0), res)
    add("components", components)
    add("components solved by zero impulses", components - len(out.methods))
    for k, name in enumerate(METHODS):
        add(f"components solved by {name}", sum(m == k for m in out.methods))
    add(NOT_UNIQUE, not_unique)
    add("Gauss-Seidel sweeps", out.sweeps)
    add("Newton iterations", out.newton)
    add("pivots", out.pivots)


def describe(info: dict[str, float]) -> str:
    """The solver line's account of the damped friction problem (empty when there was none)."""
    comps = int(info.get(f"{DAMPED_KEY} components", 0))
    if not comps:
        return ""
    used = [f"{name} ({int(info[k])})" for name in ("zero impulses", *METHODS)
            if (k := f"{DAMPED_KEY} components solved by {name}") in info and info[k]]
    not_unique = int(info.get(f"{DAMPED_KEY} {NOT_UNIQUE}", 0))
    unique = ("every component certified unique (P-matrix)" if not not_unique else
              f"{not_unique} of {comps} components not certified unique: the fixed point reached from the kernel's "
              "start")
    return (f"friction phase's non-symmetric box problem (damping off the inertia's eigenvectors): {comps} "
            f"components solved by {', '.join(used)}; natural residual "
            f"{info.get(f'{DAMPED_KEY} natural residual (m/s)', 0.0):.1e} m/s; {unique}")


def not_certified_unique(details: dict[str, float]) -> bool:
    """Whether a reference's damped friction phase holds a component not certified unique."""
    return any(k.startswith(f"{DAMPED_KEY} components not certified unique") and v for k, v in details.items())


# --- uniqueness -----------------------------------------------------------------------------------------------
def certified_unique(A: sp.spmatrix) -> bool:
    """A certificate that A is a P-matrix (so the box problem's solution is unique for every b): the symmetric part
    of ``D A`` positive definite for D = I or ``diag(A)^-1`` (a Cholesky factorisation succeeds)."""
    n = A.shape[0]
    if n > PIVOT_ROWS_LIMIT:
        return False
    dense = A.toarray()
    diag = np.diag(dense)
    scalings = [np.ones(n)] + ([1.0 / diag] if np.all(diag > 0) else [])
    for d in scalings:
        S = d[:, None] * dense
        S = 0.5 * (S + S.T)
        try:
            np.linalg.cholesky(S - 1e-12 * np.abs(S).max(initial=0.0) * np.eye(n))
            return True
        except np.linalg.LinAlgError:
            continue
    return False
