"""A certified bound on the distance of any contact-phase iterate from the exact limit (no exact solve needed).

For normal impulses ``lam >= 0`` (from PGS passes, an interior-point solver, anything) let ``u = u0 + M^-1 J^T lam``
and ``e = J u + c`` (``models/exact/reference.py``'s primal QP: minimise P(u) = 1/2 |u - u0|_M^2 subject to
``J u + c >= 0``). ``u`` minimises the Lagrangian ``L(., lam)``, a quadratic with Hessian M, so for the exact limit
u* (feasible, hence ``L(u*, lam) <= P(u*)``):

    1/2 |u - u*|_M^2 = L(u*, lam) - L(u, lam) <= P(u_f) - P(u) + lam.e

for any feasible ``u_f``. Take ``u_f = u + k d`` with d a uniform expansion (``v = x - x_ref``, w = 0, x_ref below
every body: a contact whose normal points from B's centre towards A's separates at ``a_r = J_r d > 0``) and the
smallest rate ``k = max_r violation_r / a_r`` over the violated rows, which closes every violation; rows that close
under the expansion (``a_r < 0``) must keep ``e_r + k a_r >= 0``. Then

    |u - u*|_M <= B = sqrt(2 max(0, lam.e + P(u + k d) - P(u))),

a computable bound (zero exactly at the limit: k = 0 and lam.e = 0). Per body it gives
``|dv| <= B sqrt(1/m)`` and ``|dw| <= B sqrt(lambda_max(I^-1))``. When no expansion separates every contact (a
normal pointing against the centres, a static body above a dynamic one), there is no certificate and
:class:`~models.exact.reference.ExactReferenceError` says so.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from models.setup.constraints import BodyTable, ConstraintSet
from models.exact.assembly import ExactReferenceError, Layout, Mass, contact_rows

SEPARATION_MARGIN = 1.0 + 1e-9  # the expansion rate just above the one that closes every violation


def contact_phase_bound(bodies: BodyTable, cons: ConstraintSet, normal: np.ndarray,
                        primal: np.ndarray | None = None) -> dict[str, float]:
    """The certified distance (M-norm and per body) of the contact-phase state the impulses ``normal`` (M, 4)
    give, starting from ``bodies``' velocities. With ``primal`` (a velocity vector over the dynamic bodies, 6 per
    body, e.g. an interior point's primal iterate) the feasible point is made from it instead of from u; see
    :func:`_primal_gap`."""
    layout = Layout(bodies)
    rows, active = contact_rows(layout, cons)
    lam = normal[active]
    if np.any(lam < 0):
        raise ExactReferenceError("negative normal impulses: not a contact-phase iterate")
    u0 = layout.velocity(bodies)
    u = u0 + layout.mass.inv @ (rows.J.T @ lam)
    e = rows.J @ u + rows.c

    def objective(x: np.ndarray) -> float:
        return 0.5 * layout.mass.norm2(x - u0)

    if primal is not None:
        return _primal_gap(bodies, layout, rows.J, rows.c, lam, u, primal)
    k, expand = _expansion_rate(bodies, rows.J, e)
    p_f = objective(u)
    if k > 0.0:
        u_f = u + k * expand
        p_f = objective(u_f)
    gap = float(lam @ e) + p_f - objective(u)
    bound = float(np.sqrt(2.0 * max(gap, 0.0)))
    dv, dw = per_body_bounds(bodies, bound)
    return {"certified |u - u*|_M (sqrt(kg) m/s)": bound, "certified max |dv| (m/s)": dv,
            "certified max |dw| (rad/s)": dw, "expansion rate k (1/s)": k, "lam.e (N s m/s)": float(lam @ e)}


def per_body_bounds(bodies: BodyTable, bound: float) -> tuple[float, float]:
    """(max |dv|, max |dw|) per body from an M-norm bound B: ``|dv| <= B sqrt(1/m)``, ``|dw| <= B
    sqrt(lambda_max(I^-1))`` (the largest eigenvalue of a body's world inverse inertia; its largest diagonal entry
    when diagonal)."""
    layout = Layout(bodies)
    return (bound * float(np.sqrt(bodies.inv_mass[bodies.dynamic].max(initial=0.0))),
            bound * float(np.sqrt(layout.max_inv_inertia)))


def _primal_gap(bodies: BodyTable, layout: Layout, J: sp.csr_matrix, c: np.ndarray, lam: np.ndarray,
                u: np.ndarray, primal: np.ndarray) -> dict[str, float]:
    """The bound from a primal point x: v = x + k d feasible (d the uniform expansion), then for the exact limit u*

        1/2 |v - u*|_M^2 <= P(v) - P(u*) <= P(v) - L(u, lam) = lam.(J v + c) + 1/2 |v - u|_M^2

    (strong convexity of P over the feasible set, weak duality; the right-hand side is P(v) - P(u) + lam.e
    written without its cancelling terms, since u - u0 = M^-1 J^T lam), and ``|u - u*|_M <= |u - v|_M + that``.
    Near an interior point's limit x is feasible to rounding (k ~ 0) while u = u(lam) carries the dual residual:
    this bound is the dual-residual size, where the one from u alone is the square root of (violation x sum lam)."""
    e = J @ primal + c
    k, d = _expansion_rate(bodies, J, e)
    v = primal + k * d if k > 0.0 else primal
    gap = float(lam @ np.maximum(J @ v + c, 0.0)) + 0.5 * layout.mass.norm2(v - u)
    bound = float(np.sqrt(max(layout.mass.norm2(u - v), 0.0))) + float(np.sqrt(2.0 * max(gap, 0.0)))
    dv, dw = per_body_bounds(bodies, bound)
    return {"certified |u - u*|_M (sqrt(kg) m/s)": bound, "certified max |dv| (m/s)": dv,
            "certified max |dw| (rad/s)": dw, "expansion rate k (1/s)": k,
            "lam.(J v + c) (N s m/s)": float(lam @ (J @ v + c))}


def _expansion_rate(bodies: BodyTable, J: sp.csr_matrix, e: np.ndarray) -> tuple[float, np.ndarray]:
    """(k, d): the uniform expansion d and the smallest rate k that closes every violation of ``e`` (0 when none);
    ExactReferenceError when no expansion does."""
    violation = np.maximum(-e, 0.0)
    if not np.any(violation > 0):
        return 0.0, np.zeros(J.shape[1])
    expand = _expansion(bodies)
    a = J @ expand  # the rows' separation speed per unit expansion rate
    viol = violation > 0
    if np.any(a[viol] <= 0):
        raise ExactReferenceError(f"no certificate: {int(np.sum(a[viol] <= 0))} violated contact rows do not "
                                  "separate under a uniform expansion")
    k = float(np.max(violation[viol] / a[viol])) * SEPARATION_MARGIN
    closing = a < 0
    k_max = float(np.min(e[closing] / -a[closing], initial=np.inf))
    if k > k_max:
        raise ExactReferenceError(f"no certificate: the expansion that closes the violations ({k:.2e}/s) opens "
                                  f"a violation on rows that close under it (allowed {k_max:.2e}/s)")
    return k, expand


def _expansion(bodies: BodyTable) -> np.ndarray:
    pos = bodies.position[bodies.dynamic]
    ref = pos.mean(axis=0)
    ref[1] = min(float(bodies.position[:, 1].min()), float(pos[:, 1].min())) - 1.0
    return np.concatenate([pos - ref, np.zeros_like(pos)], axis=1).ravel()


def friction_phase_bound(G: sp.csr_matrix, N: sp.csr_matrix, mass: Mass, u1: np.ndarray, y: np.ndarray,
                         c: np.ndarray, limit: np.ndarray) -> float:
    """The certified M-norm distance ``|u(y) - u*|_M`` of the friction-phase state ``u(y) = u1 - M^-1 G^T y`` from
    the phase's exact limit with the same friction boxes (``models/exact/reference.py``: G is the friction rows
    stacked on the spin rows N, y = (lam_t, s), ``|lam_t| <= limit``, c the friction rows' constant).

    The box QP in y is the dual of the primal P(u) = 1/2 |u - u1|_M^2 + sum_r limit_r |J_r u + c_r| subject to
    N u = 0, which is 1-strongly convex in the M-norm; with D(y) the dual objective and u_f the projection of u(y)
    onto N u = 0 (N has orthonormal rows on disjoint columns: ``u_f = u(y) - N^T N u(y)``, feasible),
    ``1/2 |u_f - u*|_M^2 <= P(u_f) - P(u*) <= P(u_f) - D(y)``, so

        |u(y) - u*|_M <= |u(y) - u_f|_M + sqrt(2 max(0, P(u_f) - D(y))).

    Zero at the limit (then N u = 0 and the duality gap closes)."""
    nr = limit.shape[0]
    if np.any(np.abs(y[:nr]) > limit * (1.0 + 1e-12) + 1e-300):
        raise ExactReferenceError("friction impulses outside their boxes: not a friction-phase iterate")
    gty = G.T @ y
    u = u1 - mass.inv @ gty
    u_f = u - N.T @ (N @ u)
    jt = G[:nr]
    primal = 0.5 * mass.norm2(u_f - u1) + float(limit @ np.abs(jt @ u_f + c))
    dual = -0.5 * float(gty @ (mass.inv @ gty)) + float(y @ (G @ u1)) + float(y[:nr] @ c)
    gap = primal - dual
    return float(np.sqrt(max(mass.norm2(u - u_f), 0.0))) + float(np.sqrt(2.0 * max(gap, 0.0)))
