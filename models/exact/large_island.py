"""The exact reference's path for islands too large for the dual QPs (``models/exact/reference.py``,
``DIRECT_ROWS_LIMIT``): either method below, then a certificate of the distance from the exact limit
(``models/exact/bound.py``) that must be at most ``CERTIFIED_ACCEPT`` per body, else no reference.

* ``"ipm"`` (default): both phases over body velocities by an interior-point method whose Newton matrices are
  factorised by PARDISO (``models/exact/body_space.py``);
* ``"mprgp"``: both phases' dual QPs by MPRGP (``models/exact/mprgp.py``, products with J and J^T only): cheap steps,
  but on the thesis frame its residual stalls near 5e-3 m/s, far above what the certificate needs.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from models.setup.constraints import BodyTable, ConstraintSet
from models.exact.assembly import ExactReferenceError, Mass

LARGE_ISLAND_METHOD = "ipm"  # "ipm" or "mprgp"
ITERATIVE_TOLERANCE = 1e-11  # MPRGP's projected-gradient tolerance (Jacobi-scaled rows)
CERTIFIED_ACCEPT = 1e-3  # m/s and rad/s: a large island's reference is kept when its certified distance is below this
CONTACT_TIME_SHARE = 0.5  # of the time left, the most the large island's contact phase may take
ITERATIVE_MARGIN_S = 20.0  # kept back from the friction phase for the residuals and the certificates
SOLVED_KEY = "large island solved by"  # info key prefix: the reference must be certified


def large_contact_phase(J: sp.csc_matrix, c: np.ndarray, mass: Mass, u0: np.ndarray, time_s: float,
                        info: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The normal impulses (per row of J) of a large island's contact phase, and a primal velocity point for its
    certificate (the interior point's primal iterate; MPRGP's u(lam) itself)."""
    info[f"contact phase: {SOLVED_KEY} {LARGE_ISLAND_METHOD}"] = 1.0
    if LARGE_ISLAND_METHOD == "ipm":
        from models.exact.body_space import contact_phase_ipm

        return contact_phase_ipm(J, c, mass, u0, time_s * CONTACT_TIME_SHARE, info)
    rows = J.shape[0]
    lam = _mprgp(J, mass, J @ u0 + c, np.zeros(rows), np.full(rows, np.inf), time_s * CONTACT_TIME_SHARE, info,
                 "contact")
    return lam, u0 + mass.inv @ (J.T @ lam)


def large_friction_phase(J: sp.csc_matrix, c: np.ndarray, N: sp.csc_matrix, mass: Mass, u1: np.ndarray,
                         limit: np.ndarray, time_s: float, info: dict[str, float]) -> np.ndarray:
    """y = (friction impulse per row of J, spin multiplier per row of N) of a large island's friction phase,
    certified given its boxes (the bound accumulates in ``info``)."""
    info[f"friction phase: {SOLVED_KEY} {LARGE_ISLAND_METHOD}"] = 1.0
    time_s -= ITERATIVE_MARGIN_S
    if LARGE_ISLAND_METHOD == "ipm":
        from models.exact.body_space import friction_phase_ipm

        y = friction_phase_ipm(J, c, N, mass, u1, limit, time_s, info)
    else:
        G = sp.vstack([J, N], format="csc")
        inf = np.full(N.shape[0], np.inf)
        q = -(G @ u1 + np.concatenate([c, np.zeros(N.shape[0])]))
        y = _mprgp(G, mass, q, np.concatenate([-limit, -inf]), np.concatenate([limit, inf]), time_s, info,
                   "friction")
    _certify_friction(sp.vstack([J, N], format="csc"), N, mass, u1, y, c, limit, info)
    return y


def _mprgp(G: sp.csc_matrix, mass: Mass, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, time_s: float,
           info: dict[str, float], phase: str) -> np.ndarray:
    """minimise 1/2 y^T G M^-1 G^T y + g^T y over lo <= y <= hi by MPRGP (products with G and G^T only)."""
    from models.exact.mprgp import mprgp

    Gr = G.tocsr()
    Gr.eliminate_zeros()
    GT = Gr.T.tocsr()
    diag = mass.row_norms2(Gr)
    if np.any(~(diag > 0)):
        raise ExactReferenceError(f"{phase} phase: a row without a dynamic body's velocity in it")
    res = mprgp(lambda v: Gr @ (mass.inv @ (GT @ v)), diag, g, lo, hi, np.clip(np.zeros_like(g), lo, hi),
                ITERATIVE_TOLERANCE, 10 ** 7, max(time_s, 0.0))
    info[f"{phase} phase: iterative (MPRGP) iterations"] = res.iterations
    info[f"{phase} phase: iterative (MPRGP) seconds"] = res.seconds
    info[f"{phase} phase: iterative (MPRGP) projected gradient at the end"] = res.projected_gradient
    info[f"{phase} phase: iterative (MPRGP) converged to {ITERATIVE_TOLERANCE:g}"] = float(res.converged)
    return res.x


FRICTION_BOUND_KEY = "certified |u - u*|_M of the friction phase, given its boxes (sqrt(kg) m/s)"


def _certify_friction(G: sp.csc_matrix, N: sp.csc_matrix, mass: Mass, u1: np.ndarray, y: np.ndarray,
                      c: np.ndarray, limit: np.ndarray, info: dict[str, float]) -> None:
    from models.exact.bound import friction_phase_bound

    bound = friction_phase_bound(G.tocsr(), N.tocsr(), mass, u1, y, c, limit)
    info[FRICTION_BOUND_KEY] = float(np.hypot(info.get(FRICTION_BOUND_KEY, 0.0), bound))  # islands: squares add


def large_island_solver() -> str:
    """The large-island method and its pinned package, for the report."""
    import importlib.metadata

    if LARGE_ISLAND_METHOD == "ipm":
        return f"body-space interior point, PARDISO (pypardiso {importlib.metadata.version('pypardiso')}), certified"
    return "MPRGP, certified"


def needs_certificate(info: dict[str, float]) -> bool:
    return any(SOLVED_KEY in k for k in info)


def certify(bodies: BodyTable, cons: ConstraintSet, normal: np.ndarray, info: dict[str, float],
            normal_residual: float, primal: np.ndarray) -> None:
    """The certified distance of a large island's reference from the exact limit (models/exact/bound.py):
    contact phase by weak duality (the smaller of the bounds from u(lam) and from the primal point ``primal``, both
    valid); the friction phase's map u1 -> u2 is the M-proximal map of a convex function
    (boxes fixed), hence non-expansive, so the final state's distance is at most the sum of both phases' bounds.
    Raises ExactReferenceError when it exceeds CERTIFIED_ACCEPT."""
    from models.exact.bound import contact_phase_bound, per_body_bounds

    key = "certified |u - u*|_M (sqrt(kg) m/s)"
    contact = min(contact_phase_bound(bodies, cons, normal)[key], contact_phase_bound(bodies, cons, normal, primal)[key])
    total = contact + info.get(FRICTION_BOUND_KEY, 0.0)
    dv, dw = per_body_bounds(bodies, total)
    info["certified |u - u*|_M of the contact phase (sqrt(kg) m/s)"] = contact
    info["certified max |dv| of the final state (m/s)"] = dv
    info["certified max |dw| of the final state (rad/s)"] = dw
    if not max(dv, dw) <= CERTIFIED_ACCEPT:
        runs = "; ".join(f"{k} {v:.3g}" for k, v in info.items() if k.endswith(("iterations", "seconds")))
        raise ExactReferenceError(f"the large-island solve stopped {dv:.1e} m/s and {dw:.1e} rad/s (certified) "
                                  f"from the exact limit, above the {CERTIFIED_ACCEPT:g} accepted ({runs}; normal "
                                  f"LCP residual {normal_residual:.1e} m/s)")
