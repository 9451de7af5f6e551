"""How far a solved step is from satisfying its contact constraints (float64, whatever format solved it).

For each active contact point of a manifold (``jac_inv != 0``), with the velocities after the solve:

    e = vrel + b,   vrel = (n.vA - n.vB) + ((rA x n).wA - (rB x n).wB)

is the quantity a contact update drives to zero (``delta = e * jac_inv``, ``models/golden/contact_solver.py``, with
``jac_inv = -1/K < 0``, K the point's effective inverse mass): the solver adds normal impulse while ``e < 0``.
A solution of the contact LCP has, per point, ``lam >= 0``, ``e >= 0`` and ``lam * e = 0``. We report

* the normal velocity violation ``max(-e, 0)`` (m/s; the approach speed, beyond the bias target, that the
  impulses left unresolved), as its maximum and root mean square over the active points;
* the complementarity ``|lam * e|`` (N*s * m/s), as its maximum: impulse still pushing where the bodies
  separate faster than the target.

The friction passes of the GPU scheme run after all contact passes and change the velocities again, so even a
converged solve keeps a small normal violation after friction; compare residuals at equal settings only.
"""

from __future__ import annotations

import numpy as np

from models.formats.number_format import FLOAT64
from models.golden.contact_solver import Impulses, SolverParams, run_pass, schedule_levels
from models.setup.constraints import BodyTable, ConstraintSet


def contact_error(bodies: BodyTable, cons: ConstraintSet) -> tuple[np.ndarray, np.ndarray]:
    """(e, active): e = vrel + b per point (M, 4) in float64 and the mask of active points."""
    a, b = cons.body_a, cons.body_b
    n = cons.normal[:, None, :]
    ra = cons.points - bodies.position[a][:, None, :]
    rb = cons.points - bodies.position[b][:, None, :]
    ca, cb = np.cross(ra, n), np.cross(rb, n)
    va, vb = bodies.linear_velocity[a][:, None, :], bodies.linear_velocity[b][:, None, :]
    wa, wb = bodies.angular_velocity[a][:, None, :], bodies.angular_velocity[b][:, None, :]
    vrel = np.sum(n * va, axis=-1) - np.sum(n * vb, axis=-1) + np.sum(ca * wa, axis=-1) - np.sum(cb * wb, axis=-1)
    return vrel + cons.bias, cons.jac_inv != 0.0


def contact_residual(bodies: BodyTable, cons: ConstraintSet, normal_impulse: np.ndarray) -> dict[str, float]:
    """Normal velocity violation (max, RMS) and complementarity (max) over the active contact points."""
    e, active = contact_error(bodies, cons)
    viol = np.maximum(-e[active], 0.0)
    comp = np.abs(normal_impulse[active] * e[active])
    rms = float(np.sqrt(np.mean(viol ** 2))) if viol.size else 0.0
    return {"max normal velocity violation (m/s)": float(viol.max(initial=0.0)),
            "rms normal velocity violation (m/s)": rms,
            "max complementarity |lambda * e| (N*s*m/s)": float(comp.max(initial=0.0))}


def pass_change(state: BodyTable, imp: Impulses, cons: ConstraintSet, schedule: np.ndarray, kind: int) -> float:
    """The largest velocity component (m/s or rad/s) one float64 pass of ``kind`` changes from ``state`` with the
    impulses ``imp``: 0 at a fixed point of the passes (neither argument is changed)."""
    out = state.copy()
    levels = schedule_levels(schedule, cons, state.dynamic)
    run_pass(out, Impulses(imp.normal.copy(), imp.friction.copy()), cons, levels, FLOAT64, kind, 0, SolverParams(), schedule)
    return float(max(np.abs(out.linear_velocity - state.linear_velocity).max(initial=0.0),
                     np.abs(out.angular_velocity - state.angular_velocity).max(initial=0.0)))
