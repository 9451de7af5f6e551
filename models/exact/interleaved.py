"""The exact limit of the interleaved pass order (``SolverParams(interleaved=True)``: per iteration a contact pass,
then a friction pass whose boxes ``mu sum(lam_n)`` are the current normal impulses).

Its fixed points solve the coupled problem: the normal LCP on the velocities that include the friction (and spin
damping) impulses, the friction boxes at the normal impulses, ``n.w = 0`` on the damped rows. That is no single
convex program (the boxes depend on the normal impulses, the normal rows see the friction impulses: a
non-symmetric complementarity problem), and for mu > 0 its solution need not be unique. It is computed here by
alternation: the contact phase's QP with the friction impulses fixed (``models/exact/reference.py``, started from
the velocities the friction leaves), then the friction phase's problem with the normal impulses fixed, repeated
until neither changes (``ALTERNATION_TOLERANCE``). Nothing guarantees the alternation converges: the result is kept
only when the coupled problem's natural residuals, all evaluated at the one final state (normal LCP, friction box
at the final normal impulses, spin ``|n.w|``), are at most ``COUPLED_ACCEPT``; then it is a fixed point of the
interleaved passes (``models/tests/test_exact_reference.py`` runs one contact and one friction pass from it), one
of possibly several. At a fixed point the state after a contact pass is the final state, so the reference's
``contact_bodies`` is the final state. Islands above ``DIRECT_ROWS_LIMIT`` rows are refused (each alternation
would be one large-island solve, and their certificate covers the sequential order only).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses, SolverParams
from models.exact import phases
from models.exact.assembly import ExactReferenceError, Layout, contact_rows, island_of_rows, islands

MAX_ALTERNATIONS = 1000
ALTERNATION_TOLERANCE = 1e-13  # m/s, rad/s: the alternation stops when an alternation moves velocities less
RELAXATION = 1.0  # the next alternation starts from shift + RELAXATION (new shift - shift)
COUPLED_ACCEPT = 1e-9  # m/s (rad/s for the spin row): the coupled natural residuals the reference is kept with
COUPLED_KEYS = ("contact phase: normal LCP |min(lam K, e)| max (m/s)", "friction phase: box residual max (m/s)",
                "friction phase: spin |n.w| max (rad/s)")


def interleaved_reference(bodies: BodyTable, cons: ConstraintSet, params: SolverParams, clock: Any,
                          solver: Any) -> tuple[BodyTable, Impulses, dict[str, float], dict[str, float], int]:
    """(final state, impulses, natural residuals of the coupled problem, details, islands), or ExactReferenceError
    when the alternation does not reach a certified fixed point."""
    layout = Layout(bodies)
    count, labels = islands(layout, cons)
    rows, _ = contact_rows(layout, cons)
    per_island = np.bincount(island_of_rows(layout, labels, rows.body_a, rows.body_b), minlength=count)
    if per_island.size and int(per_island.max()) > phases.DIRECT_ROWS_LIMIT:
        raise ExactReferenceError(f"interleaved order: an island of {int(per_island.max()):,} contact rows, above "
                                  f"the {phases.DIRECT_ROWS_LIMIT:,} its alternation solves directly")
    u0 = layout.velocity(bodies)
    shift = np.zeros_like(u0)  # what the friction impulses and the damping add to the velocities
    info: dict[str, float] = {}
    t0 = time.perf_counter()
    last = np.inf
    normal = friction = u2 = None
    for k in range(1, MAX_ALTERNATIONS + 1):
        base = u0 + shift
        try:
            u1, normal, _ = phases.contact_phase(layout, cons, base, labels, count, solver, clock, info)
            u_n = u0 + (u1 - base)
            u2, friction = phases.friction_phase(layout, cons, u_n, normal, params.friction_coeff, labels, count,
                                              solver, clock, info)
        except ExactReferenceError as exc:
            raise ExactReferenceError(f"interleaved order, alternation {k} (last change {last:.1e}): {exc}") from None
        new_shift = u2 - u_n
        last = float(np.abs(new_shift - shift).max(initial=0.0))
        shift = shift + RELAXATION * (new_shift - shift)
        if last <= ALTERNATION_TOLERANCE:
            break
    info["interleaved: alternations (contact QP, then friction problem)"] = k
    info["interleaved: last alternation's velocity change (m/s, rad/s)"] = last
    info["interleaved: alternation seconds"] = time.perf_counter() - t0
    final = layout.with_velocity(bodies, u2)
    imp = Impulses(normal=normal, friction=friction)
    residuals = phases.natural_residuals(final, final, cons, imp, params.friction_coeff)
    worst = max(residuals[key] for key in COUPLED_KEYS)
    if not worst <= COUPLED_ACCEPT:
        raise ExactReferenceError(
            f"interleaved order: the alternation stopped after {k} alternations (last change {last:.1e}) with the "
            f"coupled natural residual {worst:.1e} above the {COUPLED_ACCEPT:g} accepted: no certified fixed point")
    return final, imp, residuals, info, count
