"""The exact limit of the scheme the kernel iterates (float64): ground truth for the solver's error.

The kernel's default pass order (``SolverParams(interleaved=False)``, Bullet GPU) is all contact passes, then all
friction passes with the normal impulses fixed. As the iteration count grows, each phase tends to the solution
of a convex program, which this module solves directly with an interior-point QP solver (Clarabel, pinned in
``requirements.txt``) instead of iterating:

* **contact phase**: per active contact point r (``jac_inv != 0``) the pass drives ``e_r = J_r u + c_r`` (normal
  relative velocity plus bias, ``models/exact/residual.py``) towards the LCP ``lam >= 0, e >= 0, lam e = 0`` with
  impulses along ``M^-1 J^T``. Its solution is the primal QP over the dynamic bodies' velocities u (6 per body)

      minimise 1/2 (u - u0)^T M (u - u0)   subject to   J u + c >= 0,

  whose multipliers are the normal impulses. M is block diagonal, so the matrices are as sparse as the contact
  graph; the velocities u are unique (M is positive definite) even where the impulses are not.
* **friction phase** (normal impulses fixed at the contact phase's): per friction row (manifold m, tangent j) the
  pass projects ``lam_t`` onto the box ``|lam_t| <= mu * sum(lam_n[m])`` with impulses along ``-M^-1 J_t^T``; the
  spin-damping update ``w -= 0.1 (n.w) n`` of a damped manifold is stationary exactly when ``n.w = 0`` for its
  dynamic bodies. The joint fixed point solves the box QP over the friction impulses and free spin multipliers s

      minimise 1/2 y^T G M^-1 G^T y - y^T (G u1 + c_t)   subject to   |lam_t| <= L,   y = (lam_t, s),

  with G the friction rows J_t stacked on the spin rows (n on the w columns) and ``u = u1 - M^-1 G^T y``. Its
  stationarity condition moves w along ``I^-1 n``, the damping along n: the two agree only where the damped
  directions span a subspace the body's world inverse inertia (diagonal or full 3x3, M block diagonal) maps into
  itself, true for cubes and for axis-aligned normals of diagonal bodies. Where they do not (rotated non-cube
  bodies), the passes' limit solves a non-symmetric box problem instead (``models/exact/damped_friction.py``,
  started from this QP's solution).
  (The primal form, minimise 1/2 |u - u1|_M^2 + sum L |J_t u + c_t| with n.w = 0, is sparser but Clarabel
  reached only 2e-5 m/s of box residual on the pile against 1e-6 for this dual form.)

Bodies that share no manifold through a dynamic body (islands) are independent problems; they are solved
separately, small ones gathered into one solve (a block-diagonal problem is the same problem).

An island with more than ``DIRECT_ROWS_LIMIT`` rows (the thesis frame is one island of 589,940 contact rows) is
too large for Clarabel's factorisations of these dual forms within the budget: both phases are then solved over
body velocities by an interior point whose Newton matrices PARDISO factorises
(``models/exact/large_island.py``), and the result is kept only with a certificate
(``models/exact/bound.py``, weak duality): the contact phase's distance from its exact limit plus the friction
phase's from its limit with the same boxes (the friction map is the M-proximal map of a convex function, hence
non-expansive), at most ``CERTIFIED_ACCEPT`` per body; otherwise :class:`ExactReferenceError` gives the bound.
Problem assembly (rows, spin rows, islands): ``models/exact/assembly.py``.

The interleaved order (``interleaved=True``: contact, friction, contact, ...) has a coupled fixed point (the friction
box ``mu * sum(lam_n)`` depends on the normal impulses and the normal rows see the friction impulses: a non-symmetric
complementarity problem, no convex program, possibly several solutions); ``models/exact/interleaved.py``
reaches one by alternating the two phases' problems and keeps it only when the coupled natural residuals certify it.

Where the normal impulses are not unique (A = J M^-1 J^T singular: four coplanar points, statically indeterminate
supports), the friction boxes depend on which normal solution is taken; the interior-point solver returns one
(the central one), the passes may tend to another. The reference is then one exact fixed point of the scheme,
verified as such (``models/tests/test_exact_reference.py``), not necessarily the one the passes approach.

Natural residuals (what each phase leaves unsatisfied, all in m/s except the spin row):

* normal LCP: ``|min(lam K, e)|`` per active point (K the point's effective inverse mass, ``-1/jac_inv``);
* friction box: ``Kt |lam_t - clip(lam_t + u_t / Kt, -L, L)|`` per row (``u_t`` the tangent velocity the pass
  reads, Kt the row's effective inverse mass): the velocity one friction update would remove;
* spin damping: ``|n.w|`` per damped manifold and dynamic body (rad/s).

Failures (the solver stops without an optimal solution, an infeasible or unbounded problem, a non-finite input, the
time budget, an estimated memory need above the budget) raise :class:`ExactReferenceError`; callers print
"no exact reference" instead of a number.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import scipy.sparse as sp

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses, SolverParams
from models.exact.assembly import (EIGEN_TOLERANCE, ExactReferenceError, Layout, Rows, contact_rows, friction_limits,
                                   friction_rows, islands, island_of_rows, not_a_qp_message, spin_rows,
                                   spin_rows_off_eigen)
from models.exact.box_lcp import METHODS as BOX_METHODS, BoxProblem, regularized_solve, solve_box
from models.exact.box_lemke import one_blas_thread
from models.exact.damped_friction import damped_friction_phase, describe
from models.exact.large_island import (certify, large_contact_phase, large_friction_phase, large_island_solver,
                                       needs_certificate)

DEFAULT_TIME_BUDGET_S = 600.0
DEFAULT_MEMORY_BUDGET_BYTES = 8 * 1024 ** 3
ISLAND_BATCH_ROWS = 4096  # small islands are gathered into one solve of about this many rows
SOLVER_TOLERANCE = 1e-10  # Clarabel's gap and feasibility tolerances (1e-12 ends AlmostSolved on the pile)
KKT_BYTES_PER_NONZERO = 400  # pre-solve memory estimate per KKT non-zero: a bound on the inputs, blind to fill-in
ALMOST_SOLVED_ACCEPT = 1e-6  # m/s: an "almost solved" QP is kept when its polished natural residual is below this
# A batch with more rows than this is solved over body velocities (models/exact/large_island.py) and
# certified (models/exact/bound.py): Clarabel's factorisations of the dual-form KKT system of the thesis frame's single
# island (589,940 rows) take minutes each (docs/exact_reference.md).
DIRECT_ROWS_LIMIT = 50_000



@dataclass(frozen=True)
class Budget:
    time_s: float = DEFAULT_TIME_BUDGET_S
    memory_bytes: int = DEFAULT_MEMORY_BUDGET_BYTES


@dataclass
class ExactReference:
    """The exact limit of both phases (velocities before integration) and what it took."""

    contact_bodies: BodyTable  # after the contact phase
    bodies: BodyTable  # after the friction phase: the scheme's limit
    impulses: Impulses  # normal (contact phase) and friction impulses, N*s
    residuals: dict[str, float]
    seconds: dict[str, float]
    islands: int
    solver: str
    details: dict[str, float] = field(default_factory=dict)


# --- QP problems and the solver -------------------------------------------------------------------------------
@dataclass
class QpProblem:
    """minimise 1/2 x^T P x + q^T x subject to A x + s = b, s in (zero cone)^n_eq x (nonnegative cone)^n_ineq."""

    P: sp.csc_matrix
    q: np.ndarray
    A: sp.csc_matrix
    b: np.ndarray
    n_eq: int
    n_ineq: int


@dataclass
class QpSolution:
    x: np.ndarray
    z: np.ndarray  # multipliers of the rows of A (>= 0 on the inequality rows)
    iterations: int
    seconds: float
    almost: bool = False  # the solver reached only its reduced tolerances: kept if the polish certifies it


QpSolver = Callable[[QpProblem, float], QpSolution]


class InfeasibleQp(ExactReferenceError):
    """The QP has no feasible point; ``certificate`` is the solver's (``z >= 0`` with ``A^T z = 0``, ``b.z < 0``)."""

    def __init__(self, message: str, certificate: np.ndarray) -> None:
        super().__init__(message)
        self.certificate = certificate


CERTIFICATE_TOLERANCE = 1e-8  # relative: |J^T y| against |J|^T y, and c.y against |c|.y


def no_contact_fixed_point(exc: InfeasibleQp, J: sp.csr_matrix, c: np.ndarray, body_a: np.ndarray,
                           body_b: np.ndarray) -> ExactReferenceError:
    """The contact phase's infeasible QP, named: its normal LCP has no solution, so the contact passes have no fixed
    point (their impulses grow without bound), certified when the solver's Farkas vector verifies: weights
    ``y >= 0`` on the rows with ``J^T y = 0`` (they cancel in every velocity) and ``c.y < 0`` (their demands do
    not), so no velocities meet every row's ``J u + c >= 0``. The bodies named are those of the rows with most
    weight (interlocked or interpenetrating bodies: a compound's children on both sides of another body)."""
    y = np.maximum(exc.certificate, 0.0)
    scale = float((abs(J).T @ y).sum())
    residual = float(np.abs(J.T @ y).sum())
    demand = float(c @ y)
    verified = y.size > 0 and demand < -CERTIFICATE_TOLERANCE * float(np.abs(c) @ y) and \
        residual <= CERTIFICATE_TOLERANCE * max(scale, 1e-300)
    heavy = np.flatnonzero(y > 1e-3 * float(y.max(initial=0.0)))
    pairs: dict[tuple[int, int], float] = {}
    for r in heavy:
        key = (int(body_a[r]), int(body_b[r]))
        pairs[key] = pairs.get(key, 0.0) + float(y[r])
    named = ", ".join(f"{a}-{b}" for (a, b), _ in sorted(pairs.items(), key=lambda kv: -kv[1])[:4])
    how = (f"certified: weights y >= 0 on {heavy.size} rows that cancel in every velocity (|J^T y| / |J|^T y = "
           f"{residual / max(scale, 1e-300):.1e}) while their demands do not (c.y / sum(y) = "
           f"{demand / max(float(y.sum()), 1e-300):.2e} m/s)"
           if verified else "the solver's certificate does not verify")
    return ExactReferenceError(f"{exc}: the contact phase has no fixed point (no velocities separate every contact "
                               f"of the bodies {named}: interlocked or interpenetrating; {how})")


def clarabel_solve(prob: QpProblem, time_limit_s: float) -> QpSolution:
    """Solve with Clarabel (interior point, direct sparse LDL); raise ExactReferenceError unless Solved."""
    import clarabel

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = SOLVER_TOLERANCE
    settings.tol_ktratio = 1e-8
    settings.time_limit = max(time_limit_s, 1e-3)
    settings.max_iter = 200
    cones = ([clarabel.ZeroConeT(prob.n_eq)] if prob.n_eq else []) + (
        [clarabel.NonnegativeConeT(prob.n_ineq)] if prob.n_ineq else [])
    P = sp.triu(prob.P, format="csc")
    t0 = time.perf_counter()
    sol = clarabel.DefaultSolver(P, prob.q, prob.A.tocsc(), prob.b, cones, settings).solve()
    seconds = time.perf_counter() - t0
    status = str(sol.status)
    if "MaxTime" in status:
        raise ExactReferenceError(f"QP solver hit the time budget ({time_limit_s:.0f} s left) after "
                                  f"{sol.iterations} iterations")
    almost = status in ("AlmostSolved", "SolverStatus.AlmostSolved")
    if status not in ("Solved", "SolverStatus.Solved") and not almost:
        message = (f"QP solver stopped with status {status} after {sol.iterations} iterations ({prob.A.shape[0]} "
                   f"rows, {prob.P.shape[0]} unknowns)")
        if "PrimalInfeasible" in status:
            raise InfeasibleQp(message, np.asarray(sol.z))
        raise ExactReferenceError(message)
    return QpSolution(np.asarray(sol.x), np.asarray(sol.z), int(sol.iterations), seconds, almost)


def _batches(labels: np.ndarray, row_island: np.ndarray, count: int) -> list[np.ndarray]:
    """Groups of island labels, each with about ISLAND_BATCH_ROWS rows or one island alone."""
    rows = np.bincount(row_island, minlength=count)
    groups: list[list[int]] = [[]]
    size = 0
    for island in np.argsort(-rows, kind="stable"):
        if rows[island] == 0:
            continue
        if size and size + rows[island] > ISLAND_BATCH_ROWS:
            groups.append([])
            size = 0
        groups[-1].append(int(island))
        size += int(rows[island])
    return [np.array(g) for g in groups if g]


class _Clock:
    def __init__(self, budget: Budget):
        self.budget = budget
        self.t0 = time.monotonic()

    def left(self) -> float:
        left = self.budget.time_s - (time.monotonic() - self.t0)
        if left <= 0:
            raise ExactReferenceError(f"time budget of {self.budget.time_s:.0f} s spent")
        return left

    def check_memory(self, prob: QpProblem) -> None:
        nnz = prob.P.nnz + prob.A.nnz + prob.A.shape[0] + prob.P.shape[0]
        need = nnz * KKT_BYTES_PER_NONZERO
        if need > self.budget.memory_bytes:
            raise ExactReferenceError(
                f"estimated memory {need / 2 ** 30:.1f} GiB for a QP of {prob.A.shape[0]:,} rows and "
                f"{prob.P.shape[0]:,} unknowns exceeds the budget of {self.budget.memory_bytes / 2 ** 30:.1f} GiB")


def _sub(rows: Rows, sel: np.ndarray, cols: np.ndarray) -> tuple[sp.csc_matrix, np.ndarray]:
    return rows.J[sel][:, cols].tocsc(), rows.c[sel]


# --- active-set polish --------------------------------------------------------------------------------------
PIVOT_TARGET = 1e-12  # m/s: a contact-phase component above this after the polish is re-solved (models/exact/box_lcp.py)
SHARPEN_ACCEPT = 1e-10  # m/s: a re-solved component stops trying further methods at this residual
SHARPEN_KEY = f"contact phase: components above {PIVOT_TARGET:g} m/s after the polish, re-solved"
POLISH_ROUNDS = 3
POLISH_REFINEMENTS = 8
POLISH_REGULARIZATION = 1e-11  # relative to the largest diagonal entry of the reduced system


def box_residual(H: sp.csc_matrix, g: np.ndarray, y: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Natural residual of minimise 1/2 y^T H y + g^T y, lo <= y <= hi, per row and scaled by the row's diagonal
    K (so in the rows' velocity units): ``K |y - clip(y - (H y + g) / K, lo, hi)|``, the change one projected
    Gauss-Seidel update of that row alone would make to its velocity."""
    k = H.diagonal()
    return k * np.abs(y - np.clip(y - (H @ y + g) / k, lo, hi))


def polish_box_qp(H: sp.csc_matrix, g: np.ndarray, y: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Sharpen an interior-point solution of the box QP by active-set steps (kept only when the largest natural
    residual falls): rows whose projected update lands on a bound are fixed there, the others solve
    ``H_FF y_F = -(g_F + H_FB y_B)`` (a regularised sparse LU plus refinement, for singular H)."""
    best = np.clip(y, lo, hi)
    best_res = float(box_residual(H, g, best, lo, hi).max(initial=0.0))
    k = H.diagonal()
    for _ in range(POLISH_ROUNDS):
        step = best - (H @ best + g) / k
        at_lo, at_hi = step <= lo, step >= hi
        free = ~(at_lo | at_hi)
        cand = np.where(at_lo, lo, np.where(at_hi, hi, best))
        f = np.flatnonzero(free)
        if f.size:
            cand[f] = regularized_solve(H[f][:, f].tocsc(), -(g[f] + H[f] @ np.where(free, 0.0, cand)), cand[f],
                                        POLISH_REGULARIZATION, POLISH_REFINEMENTS)
        cand = np.clip(cand, lo, hi)
        res = float(box_residual(H, g, cand, lo, hi).max(initial=0.0))
        if not res < best_res:
            break
        best, best_res = cand, res
    return best


def _sharpen(H: sp.csc_matrix, g: np.ndarray, lam: np.ndarray, clock: _Clock, info: dict[str, float]) -> np.ndarray:
    """The contact LCP's polished solution with every component still above ``PIVOT_TARGET`` re-solved from it by
    ``models/exact/box_lcp.py`` (Gauss-Seidel, semismooth Newton, complementary pivoting; H is symmetric positive
    semidefinite, so Lemke's method ends at a solution), each kept only where it lowers the residual: Clarabel's
    point carries about 1e-6 relative, which rows of a large effective inverse mass (light, small bodies: 1/I near
    7e4) turn into residuals of 1e-4 m/s that the active-set polish, on the singular H of coplanar points, does
    not remove."""
    lo, hi = np.zeros(g.shape[0]), np.full(g.shape[0], np.inf)
    if float(box_residual(H, g, lam, lo, hi).max(initial=0.0)) <= PIVOT_TARGET:
        return lam
    with one_blas_thread():
        out, _, how = solve_box(BoxProblem(H.tocsr(), -g, H.diagonal(), lo, hi), lam, SHARPEN_ACCEPT,
                                time.monotonic() + clock.left(), target=PIVOT_TARGET)
    for k, name in enumerate(BOX_METHODS):
        key = f"{SHARPEN_KEY} by {name}"
        info[key] = info.get(key, 0) + sum(m == k for m in how.methods)
    info[f"{SHARPEN_KEY}: pivots"] = info.get(f"{SHARPEN_KEY}: pivots", 0) + how.pivots
    return out


def _check_almost(sol: QpSolution, residual: np.ndarray, phase: str) -> None:
    worst = float(residual.max(initial=0.0))
    if sol.almost and not worst <= ALMOST_SOLVED_ACCEPT:
        raise ExactReferenceError(f"{phase} QP only almost solved and its natural residual {worst:.1e} m/s stays "
                                  f"above {ALMOST_SOLVED_ACCEPT:g} m/s after polishing")


# --- the two phases -------------------------------------------------------------------------------------------
def _contact_phase(layout: Layout, cons: ConstraintSet, u0: np.ndarray, labels: np.ndarray, count: int,
                   solver: QpSolver, clock: _Clock,
                   info: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The contact phase's limit: velocities u, normal impulses (M, 4), and a primal point for the certificate (u
    except on large islands, where the interior point's primal iterate)."""
    rows, active = contact_rows(layout, cons)
    lam = np.zeros(rows.c.shape[0])
    primal = np.full(u0.shape, np.nan)
    row_island = island_of_rows(layout, labels, rows.body_a, rows.body_b)
    body_island = np.repeat(labels, 6)
    for group in _batches(labels, row_island, count):
        sel = np.flatnonzero(np.isin(row_island, group))
        cols = np.flatnonzero(np.isin(body_island, group))
        J, c = _sub(rows, sel, cols)
        inf = np.full(sel.shape[0], np.inf)
        if sel.shape[0] > DIRECT_ROWS_LIMIT:
            lam[sel], primal[cols] = large_contact_phase(J, c, layout.mass.sub(cols), u0[cols], clock.left(), info)
            continue
        mass = layout.mass.sub(cols)
        prob = QpProblem(mass.mass.tocsc(), -(mass.mass @ u0[cols]), -J, c, 0, sel.shape[0])
        clock.check_memory(prob)
        try:
            sol = solver(prob, clock.left())
        except InfeasibleQp as exc:
            raise no_contact_fixed_point(exc, J, c, rows.body_a[sel], rows.body_b[sel]) from None
        H = (J @ mass.inv @ J.T).tocsc()
        lam[sel] = polish_box_qp(H, J @ u0[cols] + c, np.maximum(sol.z, 0.0), np.zeros(sel.shape[0]), inf)
        lam[sel] = _sharpen(H, J @ u0[cols] + c, lam[sel], clock, info)
        _check_almost(sol, box_residual(H, J @ u0[cols] + c, lam[sel], np.zeros(sel.shape[0]), inf), "contact")
        info["contact QP iterations (largest island)"] = max(info.get("contact QP iterations (largest island)", 0),
                                                             sol.iterations)
    u = u0 + layout.mass.inv @ (rows.J.T @ lam)
    normal = np.zeros(cons.jac_inv.shape)
    normal[active] = lam
    return u, normal, np.where(np.isnan(primal), u, primal)


def _friction_phase(layout: Layout, cons: ConstraintSet, u1: np.ndarray, normal: np.ndarray, mu: float,
                    labels: np.ndarray, count: int, solver: QpSolver, clock: _Clock,
                    info: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The friction phase's limit (normal impulses fixed): velocities u and friction impulses (M, 2)."""
    active = cons.f_jac_inv[:, 0] != 0.0
    limit = friction_limits(cons, normal, mu)
    boxed = np.flatnonzero(active & (limit > 0.0))
    rows = friction_rows(layout, cons, boxed)
    L = np.repeat(limit[boxed], 2)
    N, spin_body = spin_rows(layout, cons, np.flatnonzero(active & cons.spin_damp))
    off_eigen = spin_rows_off_eigen(layout, N)
    lam_rows = np.zeros(L.shape[0])
    spin = np.zeros(N.shape[0])
    damped: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # batches solved as the non-symmetric box problem: their columns' velocities
    row_island = island_of_rows(layout, labels, rows.body_a, rows.body_b)
    spin_island = labels[layout.index[spin_body]]
    body_island = np.repeat(labels, 6)
    for group in _batches(labels, np.concatenate([row_island, spin_island]), count):
        sel = np.flatnonzero(np.isin(row_island, group))
        ssel = np.flatnonzero(np.isin(spin_island, group))
        cols = np.flatnonzero(np.isin(body_island, group))
        J, c = _sub(rows, sel, cols)
        Ns = N[ssel][:, cols].tocsc()
        nr, ns = sel.shape[0], Ns.shape[0]
        G = sp.vstack([J, Ns], format="csc")
        q = -(G @ u1[cols] + np.concatenate([c, np.zeros(ns)]))
        inf = np.full(ns, np.inf)
        lo, hi = np.concatenate([-L[sel], -inf]), np.concatenate([L[sel], inf])
        qp = not np.any(off_eigen[ssel] > EIGEN_TOLERANCE)
        mass = layout.mass.sub(cols)
        if nr + ns > DIRECT_ROWS_LIMIT:
            if not qp:
                raise ExactReferenceError(not_a_qp_message(layout, N, off_eigen, ssel) + "; an island of "
                                          f"{nr + ns:,} rows, above the {DIRECT_ROWS_LIMIT:,} the non-symmetric "
                                          "problem's direct solve takes")
            y = large_friction_phase(J, c, Ns, mass, u1[cols], L[sel], clock.left(), info)
            lam_rows[sel] = y[:nr]
            spin[ssel] = y[nr:]
            continue
        if not qp:  # the non-symmetric box problem (its own methods, from the kernel's start)
            lam_rows[sel], damped_u = damped_friction_phase(J, c, Ns, mass, u1[cols], L[sel], info,
                                                            not_a_qp_message(layout, N, off_eigen, ssel),
                                                            clock.left())
            damped[int(group[0])] = (cols, damped_u)
            continue
        P = (G @ mass.inv @ G.T).tocsc()
        eye = sp.identity(nr, format="csc")
        A = sp.vstack([sp.hstack([eye, sp.csc_matrix((nr, ns))]), sp.hstack([-eye, sp.csc_matrix((nr, ns))])],
                      format="csc")
        prob = QpProblem(P, q, A, np.concatenate([L[sel], L[sel]]), 0, 2 * nr)
        clock.check_memory(prob)
        sol = solver(prob, clock.left())
        info["friction QP iterations (largest island)"] = max(
            info.get("friction QP iterations (largest island)", 0), sol.iterations)
        y = polish_box_qp(P, q, sol.x, lo, hi)
        _check_almost(sol, box_residual(P, q, y, lo, hi), "friction")
        lam_rows[sel] = y[:nr]
        spin[ssel] = y[nr:]
    u = u1 - layout.mass.inv @ (rows.J.T @ lam_rows + N.T @ spin)
    for cols, damped_u in damped.values():
        u[cols] = damped_u
    friction = np.zeros(cons.f_jac_inv.shape)
    friction[boxed] = lam_rows.reshape(-1, 2)
    return u, friction


# --- natural residuals ----------------------------------------------------------------------------------------
def natural_residuals(contact_bodies: BodyTable, bodies: BodyTable, cons: ConstraintSet, imp: Impulses,
                      mu: float) -> dict[str, float]:
    """The natural residuals at the end of each phase (see the module docstring), maxima over rows."""
    layout = Layout(bodies)
    rows, active = contact_rows(layout, cons)
    e = rows.J @ layout.velocity(contact_bodies) + rows.c
    k = -1.0 / cons.jac_inv[active]
    normal = np.abs(np.minimum(imp.normal[active] * k, e))
    fa = cons.f_jac_inv[:, 0] != 0.0
    manifolds = np.flatnonzero(fa)
    frows = friction_rows(layout, cons, manifolds)
    ut = frows.J @ layout.velocity(bodies) + frows.c
    kt = -1.0 / cons.f_jac_inv[manifolds].ravel()
    limit = np.repeat(friction_limits(cons, imp.normal, mu)[manifolds], 2)
    lt = imp.friction[manifolds].ravel()
    box = kt * np.abs(lt - np.clip(lt + ut / kt, -limit, limit))
    damped = fa & cons.spin_damp
    spin = []
    for side in (cons.body_a, cons.body_b):
        body = side[damped]
        keep = bodies.dynamic[body]
        spin.append(np.abs(np.sum(cons.normal[damped][keep] * bodies.angular_velocity[body[keep]], axis=1)))
    spin_all = np.concatenate(spin)
    return {"contact phase: normal LCP |min(lam K, e)| max (m/s)": float(normal.max(initial=0.0)),
            "contact phase: normal velocity violation max (m/s)": float(np.maximum(-e, 0).max(initial=0.0)),
            "friction phase: box residual max (m/s)": float(box.max(initial=0.0)),
            "friction phase: spin |n.w| max (rad/s)": float(spin_all.max(initial=0.0)),
            "friction phase: normal velocity violation max (m/s), not a residual of the scheme": float(
                np.maximum(-(rows.J @ layout.velocity(bodies) + rows.c), 0).max(initial=0.0))}


# --- entry point ----------------------------------------------------------------------------------------------
def exact_reference(bodies: BodyTable, cons: ConstraintSet, params: SolverParams = SolverParams(),
                    budget: Budget = Budget(), solver: QpSolver = clarabel_solve,
                    solver_name: str = "") -> ExactReference:
    """The exact limit of ``params``'s pass order on this step (float64 inputs: ``bodies``, ``cons`` unrounded)."""
    _check_finite(bodies, cons)
    clock = _Clock(budget)
    if params.interleaved:
        from models.exact.interleaved import interleaved_reference

        t0 = time.perf_counter()
        final, imp, residuals, info, count = interleaved_reference(bodies, cons, params, clock, solver)
        return ExactReference(final, final, imp, residuals, {"interleaved alternation": time.perf_counter() - t0},
                              count, (solver_name or f"clarabel {_clarabel_version()}") + "; interleaved order: "
                              "alternation to the coupled fixed point", info)
    layout = Layout(bodies)
    count, labels = islands(layout, cons)
    info: dict[str, float] = {}
    seconds: dict[str, float] = {}
    u0 = layout.velocity(bodies)
    t0 = time.perf_counter()
    u1, normal, primal = _contact_phase(layout, cons, u0, labels, count, solver, clock, info)
    seconds["contact phase"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    u2, friction = _friction_phase(layout, cons, u1, normal, params.friction_coeff, labels, count, solver, clock,
                                   info)
    seconds["friction phase"] = time.perf_counter() - t0
    contact_bodies = layout.with_velocity(bodies, u1)
    final = layout.with_velocity(bodies, u2)
    imp = Impulses(normal=normal, friction=friction)
    residuals = natural_residuals(contact_bodies, final, cons, imp, params.friction_coeff)
    if needs_certificate(info):
        certify(bodies, cons, normal, info, residuals["contact phase: normal LCP |min(lam K, e)| max (m/s)"],
                primal)
    if not all(np.isfinite(v) for v in residuals.values()):
        raise ExactReferenceError("the solver returned non-finite values")
    name = solver_name or f"clarabel {_clarabel_version()}"
    if needs_certificate(info):
        name += f"; an island above {DIRECT_ROWS_LIMIT:,} rows: {large_island_solver()}"
    if describe(info):
        name += f"; {describe(info)}"
    return ExactReference(contact_bodies, final, imp, residuals, seconds, count, name, info)


def _check_finite(bodies: BodyTable, cons: ConstraintSet) -> None:
    for name in ("position", "linear_velocity", "angular_velocity", "inv_mass", "inv_inertia"):
        if not np.all(np.isfinite(getattr(bodies, name))):
            raise ExactReferenceError(f"body {name} holds NaN or Inf")
    for name in ConstraintSet._REAL_FIELDS:
        if not np.all(np.isfinite(getattr(cons, name))):
            raise ExactReferenceError(f"constraint {name} holds NaN or Inf")


def _clarabel_version() -> str:
    import importlib.metadata

    return importlib.metadata.version("clarabel")


class ExactReferenceInterrupted(ExactReferenceError):
    """The solving process was killed from outside (not by its budget): no verdict on the problem, not recorded."""


# --- the budget, enforced from outside the solver -------------------------------------------------------------
BUDGET_GRACE_S = 5.0  # seconds the parent waits past the time budget before it stops the solving process


def exact_reference_bounded(bodies: BodyTable, cons: ConstraintSet, params: SolverParams = SolverParams(),
                            budget: Budget = Budget(), solver: QpSolver = clarabel_solve) -> ExactReference:
    """:func:`exact_reference` in a child process that cannot exceed the budget: its address space is capped at
    ``budget.memory_bytes`` and it is stopped when ``budget.time_s`` has passed (Clarabel checks its own time limit
    only between iterations, and one factorisation of a large island can outlast the whole budget)."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_bounded_child, args=(send, bodies, cons, params, budget, solver),
                        daemon=True)
    child.start()
    send.close()
    try:
        if not recv.poll(budget.time_s + BUDGET_GRACE_S):
            raise ExactReferenceError(f"time budget of {budget.time_s:.0f} s spent (the solve was stopped)")
        kind, value = recv.recv()
    except EOFError:
        child.join(1.0)
        if child.exitcode is not None and child.exitcode < 0:  # a signal from outside: the machine's OOM killer, ...
            raise ExactReferenceInterrupted(f"the solving process was killed by signal {-child.exitcode} from outside "
                                            "(the machine out of memory, or stopped by hand; its own address space "
                                            f"is capped at {budget.memory_bytes / 2 ** 30:.1f} GiB)") from None
        raise ExactReferenceError(f"the solving process died (exit {child.exitcode}; memory budget "
                                  f"{budget.memory_bytes / 2 ** 30:.1f} GiB)") from None
    finally:
        if child.is_alive():
            child.kill()
        child.join(5.0)
        recv.close()
    if kind == "error":
        raise ExactReferenceError(value)
    return value


def _bounded_child(send: Any, bodies: BodyTable, cons: ConstraintSet, params: SolverParams, budget: Budget,
                   solver: QpSolver) -> None:
    import resource

    _die_with_parent()
    try:
        resource.setrlimit(resource.RLIMIT_AS, (budget.memory_bytes, budget.memory_bytes))
        send.send(("ok", exact_reference(bodies, cons, params, budget, solver)))
    except ExactReferenceError as exc:
        send.send(("error", str(exc)))
    except MemoryError:
        send.send(("error", f"memory budget of {budget.memory_bytes / 2 ** 30:.1f} GiB exceeded"))
    except Exception as exc:  # a solver library failing (under the address-space cap: a shared object not mapped)
        send.send(("error", f"the solve failed ({type(exc).__name__}: {str(exc)[:200]}; memory budget "
                            f"{budget.memory_bytes / 2 ** 30:.1f} GiB)"))
    finally:
        send.close()


PR_SET_PDEATHSIG = 1  # Linux prctl option: the signal this process gets when its parent dies


def _die_with_parent() -> None:
    """On Linux, have the kernel kill this solving process when its parent dies (a parent killed by a signal
    never reaches the daemon clean-up, and the solve would run on to the end of its budget unobserved)."""
    import ctypes
    import signal
    import sys

    if sys.platform.startswith("linux"):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL))
