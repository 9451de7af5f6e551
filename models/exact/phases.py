"""The two phases of the exact reference (``models/exact/reference.py``) as QPs over the contact points' impulses:
the problems, Clarabel, the budget's clock, the active-set polish, the contact phase's re-solve of components
above ``PIVOT_TARGET`` and the friction phase (its damped rows by ``models/exact/damped_friction.py``), and the
natural residuals a result is judged by. The orders that build on them: ``reference.py`` (contact, then friction)
and ``interleaved.py`` (the coupled fixed point).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses
from models.exact.assembly import (EIGEN_TOLERANCE, ExactReferenceError, Layout, Rows, contact_rows, friction_limits,
                                   friction_rows, island_of_rows, not_a_qp_message, spin_rows,
                                   spin_rows_off_eigen)
from models.exact.box_lcp import METHODS as BOX_METHODS, BoxProblem, regularized_solve, solve_box
from models.exact.box_lemke import one_blas_thread
from models.exact.damped_friction import damped_friction_phase
from models.exact.large_island import large_contact_phase, large_friction_phase

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


class Clock:
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


def _sharpen(H: sp.csc_matrix, g: np.ndarray, lam: np.ndarray, clock: Clock, info: dict[str, float]) -> np.ndarray:
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
def contact_phase(layout: Layout, cons: ConstraintSet, u0: np.ndarray, labels: np.ndarray, count: int,
                   solver: QpSolver, clock: Clock,
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


def friction_phase(layout: Layout, cons: ConstraintSet, u1: np.ndarray, normal: np.ndarray, mu: float,
                    labels: np.ndarray, count: int, solver: QpSolver, clock: Clock,
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
