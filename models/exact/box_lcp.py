"""The box-constrained linear complementarity problem the exact reference meets twice, solved component by
component by methods that each keep going where the one before stopped:

    r(x) = b - A x,   lo <= x <= hi,   per row: r = 0 inside the box, r <= 0 at lo, r >= 0 at hi,

A square and sparse, not necessarily symmetric (the friction phase where the spin damping is no QP,
``models/exact/damped_friction.py``) or symmetric positive semidefinite and singular (the contact phase's
normal LCP, lo = 0, hi = inf, ``models/exact/reference.py``). A row's natural residual is
``k |x - clip(x + r / k, lo, hi)|`` with k the row's step (its effective inverse mass: the velocity one projected
update of that row alone would remove, m/s).

Per component of A (rows coupled through a shared body), from ``start``:

1. **projected Gauss-Seidel**, rows of one colour of A's graph at once (exactly as one after the other), the row
   update ``x = clip(x + r / k, lo, hi)``, Anderson-accelerated (depth ANDERSON_DEPTH; an extrapolated point kept only
   when its sweep changes less than the plain one's), in rounds of GS_ROUND sweeps after which converged components
   stop, until the residual is at most TARGET or GS_MAX_SWEEPS;
2. **semismooth Newton** from that iterate (rows whose projected update lands on a bound fixed there, the others
   solving ``A_FF x_F = b_F - A_FB x_B`` by a regularised sparse LU with refinement; a backtracking line search on
   the residual's norm);
3. **complementary pivoting** (``models/exact/box_lemke.py``) on ``A + eps I`` (eps in PIVOT_REGULARIZATIONS times A's
   largest diagonal, in turn: a singular A otherwise gives nearly singular bases) from the iterate's active set, then
   from every row at its lower bound, each result sharpened by Newton steps on A itself;
4. **proximal point** from the Gauss-Seidel iterate: the outer steps ``x <- solution of the problem with A + rho I
   and b + rho x`` (rho in PROXIMAL_REGULARIZATIONS times A's largest diagonal, in turn), each by semismooth Newton.
   Every inner problem is strictly monotone where A is monotone, and the outer steps tend to a solution of the
   singular one. This is for A with near-null modes, where Newton on A stalls and pivoting ends on a basis no better
   than Gauss-Seidel. One random world's contact component of 418 rows has rank 176, with eigenvalues
   2.6e-7 and 1.7e-6 beside 1.9e3. There Gauss-Seidel, Newton and pivoting stopped at 6.0e-10 m/s; this method
   reached 1.4e-14 m/s in one outer step;
5. **MPRGP** (``models/exact/mprgp.py``) from the Gauss-Seidel iterate where A is symmetric (the contact phase's LCP is
   the convex QP ``minimise 1/2 x^T A x - b^T x`` over the box): conjugate gradients on the active face with projected
   steps, which converge for any positive semidefinite A. Another random world's contact component of 502 rows has
   rank 195; there every method above stopped at 2.8e-8 m/s (Newton and the proximal point's inner Newton find no
   descent at the start, the pivoting ends on a ray), and MPRGP reached 4.1e-13 m/s in 18,437 iterations (4 s).

A component keeps the first result whose largest natural residual is at most ``accept``, else the best of all,
with what each method reached (``Outcome.failures``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import partial

import numpy as np
import scipy.sparse as sp

from models.exact.box_lemke import PIVOT_ROWS_LIMIT, box_lemke, component_rows
from models.exact.mprgp import mprgp

TARGET = 1e-13  # the iterations stop at this natural residual (m/s)
NEWTON_MAX_ITERATIONS = 60
REGULARIZATION = 1e-13  # relative to the largest |diagonal| of a reduced Newton system (singular A_FF)
REFINEMENTS = 6
GS_MAX_SWEEPS = 2000
GS_ROUND = 50  # sweeps between the checks that stop converged components
ANDERSON_DEPTH = 8
PIVOTS_PER_ROW = 20
# pivoting works on A + eps times its largest |diagonal| (then Newton on A), for each eps in turn until one
# certifies: a singular A (the contact LCP of coplanar points: rank 98 of 192 rows on a random world's heap)
# otherwise gives nearly singular bases whose basic solutions are noise (measured there: 9.5e3 m/s unregularised,
# 1.3e-11 at 1e-12), and on ties the path depends on rounding (a component of 192 rows of rank 99: at 1e-12 1.3e-11
# m/s with one BLAS thread, 2.8e-2 with two; at 1e-9 the solution is 1.3e-8 away and Newton then reaches 2e-15)
PIVOT_REGULARIZATIONS = (1e-12, 1e-9, 1e-14, 1e-7)
# the proximal point's rho, in turn, times A's largest |diagonal|, and its outer steps per rho (on the 418-row
# component above the outer steps were 1 at 1e-10 and 1e-8, 4 at 1e-7, 15 at 1e-6, over 60 at 1e-5)
PROXIMAL_REGULARIZATIONS = (1e-10, 1e-7)
PROXIMAL_STEPS = 30
METHODS = ("projected Gauss-Seidel", "semismooth Newton from the Gauss-Seidel iterate",
           "complementary pivoting from the Gauss-Seidel iterate's active set",
           "complementary pivoting from every row at its lower bound",
           "proximal point from the Gauss-Seidel iterate", "MPRGP from the Gauss-Seidel iterate")
MPRGP_TOLERANCE = 1e-15  # the projected gradient of MPRGP's Jacobi-scaled problem (m/s)
MPRGP_ITERATIONS = 200_000
MPRGP_SECONDS = 120.0
SYMMETRY_TOLERANCE = 1e-14  # |A - A^T| against A's largest |entry|: the contact LCP's J M^-1 J^T
KEPT = -1  # a component's method index when none certified (the best result kept)


@dataclass
class BoxProblem:
    """``r = b - A x`` over ``lo <= x <= hi``; ``k`` each row's step (its effective inverse mass)."""

    A: sp.csr_matrix
    b: np.ndarray
    k: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    def natural(self, x: np.ndarray) -> np.ndarray:
        """Per row ``k |x - clip(x + (b - A x) / k, lo, hi)|``."""
        return self.k * np.abs(x - np.clip(x + (self.b - self.A @ x) / self.k, self.lo, self.hi))

    def worst(self, x: np.ndarray) -> float:
        return float(self.natural(x).max(initial=0.0))

    def sub(self, rows: np.ndarray) -> "BoxProblem":
        return BoxProblem(self.A[rows][:, rows].tocsr(), self.b[rows], self.k[rows], self.lo[rows], self.hi[rows])


@dataclass
class Outcome:
    """What solved each component, and what it took."""

    methods: list[int] = field(default_factory=list)  # per component solved: an index into METHODS, or KEPT
    rows: list[np.ndarray] = field(default_factory=list)  # the rows of each of those components
    sweeps: int = 0
    newton: int = 0
    pivots: int = 0
    failures: list[str] = field(default_factory=list)


def solve_box(prob: BoxProblem, start: np.ndarray, accept: float, deadline: float = np.inf,
              target: float = TARGET) -> tuple[np.ndarray, float, Outcome]:
    """The solution from ``start`` (module docstring), its largest natural residual and what solved it; components
    already at most ``target`` at the start are left as they are (and not counted)."""
    out = Outcome()
    x = np.clip(start, prob.lo, prob.hi)
    start_res = prob.natural(x)
    gs, out.sweeps = gauss_seidel(prob, x, deadline, target=target)
    res = prob.natural(gs)
    worst = 0.0
    for rows in component_rows(prob.A):
        if float(start_res[rows].max(initial=0.0)) <= target:
            worst = max(worst, float(start_res[rows].max(initial=0.0)))
            continue
        sub = prob.sub(rows)
        best, r, method = _solve_component(sub, gs[rows], float(res[rows].max(initial=0.0)), accept, target, out,
                                           deadline)
        if float(start_res[rows].max(initial=0.0)) < r:  # nothing beat the start
            best, r = x[rows], float(start_res[rows].max(initial=0.0))
        x[rows] = best
        worst = max(worst, r)
        out.methods.append(method)
        out.rows.append(rows)
    return x, worst, out


def _solve_component(prob: BoxProblem, x: np.ndarray, res: float, accept: float, target: float, out: Outcome,
                     deadline: float) -> tuple[np.ndarray, float, int]:
    """The first of Gauss-Seidel's iterate, Newton from it, pivoting from its active set, pivoting from the lower
    bounds whose natural residual is at most ``accept``; else the best, with what each reached recorded."""
    if res <= target:
        return x, res, 0
    best, best_res, tried = x, res, []
    y, r, its = newton(prob, x, target)
    out.newton += its
    if r <= accept and r < res:
        return y, r, 1
    if res <= accept:
        return x, res, 0
    tried.append(f"Newton {r:.1e} m/s after {its} iterations")
    if r < best_res:
        best, best_res = y, r
    n = prob.b.shape[0]
    if n > PIVOT_ROWS_LIMIT:
        tried.append(f"a component of {n:,} rows, above the {PIVOT_ROWS_LIMIT:,} pivoted")
    else:
        dense = prob.A.toarray()
        scale = float(np.abs(np.diag(dense)).max(initial=0.0))
        for eps in PIVOT_REGULARIZATIONS:
            A = dense + eps * scale * np.eye(n)
            for method, guess in ((2, x), (3, None)):
                piv = box_lemke(A, prob.b, prob.lo, prob.hi, guess, PIVOTS_PER_ROW * n, deadline)
                out.pivots += piv.pivots
                y, r, its = _polish(prob, piv.x, target)
                out.newton += its
                if piv.solved and r <= accept:
                    return y, r, method
                if r < best_res:
                    best, best_res = y, r
            tried.append(f"pivoting (regularised {eps:g}) {best_res:.1e} m/s"
                         + (f" ({piv.reason})" if piv.reason else ""))
            if time.monotonic() > deadline:
                break
    # the last resorts, in turn (method index, what the failure line calls it, the attempt)
    attempts = [(4, f"proximal point (rho {rho:g})", partial(proximal_point, prob, x, rho, target, deadline))
                for rho in PROXIMAL_REGULARIZATIONS]
    if _symmetric(prob.A):
        attempts.append((5, "MPRGP", partial(mprgp_point, prob, x, target, deadline)))
    for method, label, attempt in attempts:
        if time.monotonic() > deadline:
            break
        y, r, its = attempt()
        out.newton += its
        if r <= accept:
            return y, r, method
        if r < best_res:
            best, best_res = y, r
        tried.append(f"{label} {r:.1e} m/s")
    if time.monotonic() > deadline:
        tried.append("time budget spent")
    out.failures.append(f"a component of {n:,} rows: Gauss-Seidel {res:.1e} m/s after {out.sweeps} sweeps, "
                        + ", ".join(tried))
    return best, best_res, KEPT


def proximal_point(prob: BoxProblem, x: np.ndarray, rho: float, target: float = TARGET,
                   deadline: float = np.inf) -> tuple[np.ndarray, float, int]:
    """Up to PROXIMAL_STEPS outer steps of the proximal point from ``x`` (module docstring, step 4), ``rho``
    relative to A's largest |diagonal|: (the best point, its largest residual on the original problem, Newton
    iterations)."""
    shift = rho * float(np.abs(prob.A.diagonal()).max(initial=0.0))
    shifted = (prob.A + shift * sp.identity(prob.A.shape[0], format="csr")).tocsr()
    best, best_res, iterations = x, prob.worst(x), 0
    for _ in range(PROXIMAL_STEPS):
        if best_res <= target or time.monotonic() > deadline:
            break
        x, _, its = newton(BoxProblem(shifted, prob.b + shift * x, prob.k + shift, prob.lo, prob.hi), x, target)
        iterations += its
        r = prob.worst(x)
        if r < best_res:
            best, best_res = x, r
    return best, best_res, iterations


def _symmetric(A: sp.csr_matrix) -> bool:
    scale = float(abs(A).max()) if A.nnz else 0.0
    return A.shape[0] == A.shape[1] and (A.nnz == 0 or float(abs(A - A.T).max()) <= SYMMETRY_TOLERANCE * scale)


def mprgp_point(prob: BoxProblem, x: np.ndarray, target: float = TARGET,
                deadline: float = np.inf) -> tuple[np.ndarray, float, int]:
    """MPRGP from ``x`` on a symmetric problem (module docstring, step 5), sharpened by Newton steps: (the point,
    its largest residual, Newton iterations)."""
    A = prob.A
    res = mprgp(lambda v: A @ v, A.diagonal(), -prob.b, prob.lo, prob.hi, x, MPRGP_TOLERANCE, MPRGP_ITERATIONS,
                min(MPRGP_SECONDS, max(deadline - time.monotonic(), 0.0)))
    return _polish(prob, np.clip(res.x, prob.lo, prob.hi), target)


def _polish(prob: BoxProblem, x: np.ndarray, target: float) -> tuple[np.ndarray, float, int]:
    """A pivoting result sharpened by Newton steps (kept only when they lower the residual)."""
    res = prob.worst(x)
    if res <= target:
        return x, res, 0
    y, r, its = newton(prob, x, target)
    return (y, r, its) if r < res else (x, res, its)


# --- projected Gauss-Seidel -----------------------------------------------------------------------------------
def colours(A: sp.csr_matrix) -> list[np.ndarray]:
    """Rows in classes that share no entry of A (greedy colouring of A's graph, in row order): the rows of one class
    update at once exactly as one after the other."""
    G = (abs(A) + abs(A.T)).tocsr()
    n = A.shape[0]
    colour = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        nb = G.indices[G.indptr[i]:G.indptr[i + 1]]
        used = set(colour[nb].tolist())
        c = 0
        while c in used:
            c += 1
        colour[i] = c
    return [np.flatnonzero(colour == c) for c in range(int(colour.max(initial=-1)) + 1)]


def gauss_seidel(prob: BoxProblem, x: np.ndarray, deadline: float = np.inf, max_sweeps: int | None = None,
                 target: float = TARGET) -> tuple[np.ndarray, int]:
    """Projected Gauss-Seidel from ``x`` (module docstring, step 1) until every component's natural residual is at
    most ``target``, ``max_sweeps`` (default GS_MAX_SWEEPS) or the deadline. Returns the iterate and the sweeps of
    the component that took most."""
    max_sweeps = GS_MAX_SWEEPS if max_sweeps is None else max_sweeps
    x = np.clip(x, prob.lo, prob.hi)
    label = np.zeros(prob.b.shape[0], dtype=np.int64)
    for k, rows in enumerate(component_rows(prob.A)):
        label[rows] = k
    classes = colours(prob.A)
    active = np.ones(prob.b.shape[0], dtype=bool)
    sweeps = 0
    while sweeps < max_sweeps and time.monotonic() < deadline:
        done = np.ones(int(label.max(initial=-1)) + 1, dtype=bool)
        np.logical_and.at(done, label, prob.natural(x) <= target)
        active &= ~done[label]
        if not active.any():
            break
        rows = np.flatnonzero(active)
        x[rows] = _accelerated_round(prob, x, rows, [c[active[c]] for c in classes],
                                     min(GS_ROUND, max_sweeps - sweeps), deadline)
        sweeps += min(GS_ROUND, max_sweeps - sweeps)
    return x, sweeps


def _accelerated_round(prob: BoxProblem, x0: np.ndarray, rows: np.ndarray, classes: list[np.ndarray], sweeps: int,
                       deadline: float) -> np.ndarray:
    """``sweeps`` Anderson-accelerated sweeps over ``rows`` (the others held): their new values."""
    parts = [(c, prob.A[c].tocsr()) for c in classes if c.size]
    full = x0.copy()
    lo, hi = prob.lo[rows], prob.hi[rows]

    def sweep(x: np.ndarray) -> np.ndarray:
        full[rows] = x
        for c, A_c in parts:
            full[c] = np.clip(full[c] + (prob.b[c] - A_c @ full) / prob.k[c], prob.lo[c], prob.hi[c])
        return full[rows].copy()

    x = x0[rows]
    g = sweep(x)
    xs: list[np.ndarray] = []
    fs: list[np.ndarray] = []
    done = 1
    while done < sweeps and time.monotonic() < deadline:
        f = g - x
        xs.append(x)
        fs.append(f)
        if len(xs) > ANDERSON_DEPTH + 1:
            xs.pop(0)
            fs.pop(0)
        if len(xs) > 1:
            dF = np.column_stack([fs[k + 1] - fs[k] for k in range(len(fs) - 1)])
            dX = np.column_stack([xs[k + 1] - xs[k] for k in range(len(xs) - 1)])
            gamma = np.linalg.lstsq(dF, f, rcond=None)[0]
            trial = np.clip(g - (dX + dF) @ gamma, lo, hi)
            tg = sweep(trial)
            done += 1
            if np.linalg.norm(tg - trial) < np.linalg.norm(f):
                x, g = trial, tg
                continue
            xs, fs = [], []
        x, g = g, sweep(g)
        done += 1
    return g


# --- semismooth Newton ----------------------------------------------------------------------------------------
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


def newton(prob: BoxProblem, x: np.ndarray, target: float = TARGET) -> tuple[np.ndarray, float, int]:
    """Semismooth Newton on the natural residual from ``x``: (result, its largest residual, iterations)."""
    A, b, k, lo, hi = prob.A.tocsc(), prob.b, prob.k, prob.lo, prob.hi
    x = np.clip(x, lo, hi)
    res = prob.natural(x)
    merit = float(res @ res)
    for it in range(NEWTON_MAX_ITERATIONS):
        if float(res.max(initial=0.0)) <= target:
            return x, float(res.max(initial=0.0)), it
        step = x + (b - A @ x) / k
        at_lo, at_hi = step <= lo, step >= hi
        free = ~(at_lo | at_hi)
        cand = np.where(at_lo, lo, np.where(at_hi, hi, x))
        f = np.flatnonzero(free)
        if f.size:
            cand[f] = regularized_solve(A[f][:, f].tocsc(), b[f] - A[f] @ np.where(free, 0.0, cand), cand[f],
                                        REGULARIZATION, REFINEMENTS)
        cand = np.clip(cand, lo, hi)
        t = 1.0
        while t >= 1e-6:
            trial = x + t * (cand - x)
            trial_res = prob.natural(trial)
            if float(trial_res @ trial_res) < merit:
                break
            t *= 0.5
        else:
            return x, float(res.max(initial=0.0)), it  # no descent: stalled
        x, res, merit = trial, trial_res, float(trial_res @ trial_res)
    return x, float(res.max(initial=0.0)), NEWTON_MAX_ITERATIONS
