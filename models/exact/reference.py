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
from typing import Any

import numpy as np

from models.exact import phases
from models.exact.assembly import ExactReferenceError, Layout, islands
from models.exact.damped_friction import describe
from models.exact.interleaved import interleaved_reference
from models.exact.large_island import certify, large_island_solver, needs_certificate
from models.exact.phases import Budget, QpSolver
from models.golden.contact_solver import Impulses, SolverParams
from models.setup.constraints import BodyTable, ConstraintSet

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


# --- entry point ----------------------------------------------------------------------------------------------
def exact_reference(bodies: BodyTable, cons: ConstraintSet, params: SolverParams = SolverParams(),
                    budget: Budget = Budget(), solver: QpSolver = phases.clarabel_solve,
                    solver_name: str = "") -> ExactReference:
    """The exact limit of ``params``'s pass order on this step (float64 inputs: ``bodies``, ``cons`` unrounded)."""
    _check_finite(bodies, cons)
    clock = phases.Clock(budget)
    if params.interleaved:
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
    u1, normal, primal = phases.contact_phase(layout, cons, u0, labels, count, solver, clock, info)
    seconds["contact phase"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    u2, friction = phases.friction_phase(layout, cons, u1, normal, params.friction_coeff, labels, count, solver, clock,
                                   info)
    seconds["friction phase"] = time.perf_counter() - t0
    contact_bodies = layout.with_velocity(bodies, u1)
    final = layout.with_velocity(bodies, u2)
    imp = Impulses(normal=normal, friction=friction)
    residuals = phases.natural_residuals(contact_bodies, final, cons, imp, params.friction_coeff)
    if needs_certificate(info):
        certify(bodies, cons, normal, info, residuals["contact phase: normal LCP |min(lam K, e)| max (m/s)"],
                primal)
    if not all(np.isfinite(v) for v in residuals.values()):
        raise ExactReferenceError("the solver returned non-finite values")
    name = solver_name or f"clarabel {_clarabel_version()}"
    if needs_certificate(info):
        name += f"; an island above {phases.DIRECT_ROWS_LIMIT:,} rows: {large_island_solver()}"
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
                            budget: Budget = Budget(), solver: QpSolver = phases.clarabel_solve) -> ExactReference:
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
