"""Both phases of the exact reference solved over body velocities by an interior-point method
(``models/exact/body_space_ipm.py``, Newton matrices factorised by PARDISO): the path for islands too large for the
dual (per contact point) QPs that Clarabel solves (``models/exact/reference.py``, ``DIRECT_ROWS_LIMIT``).

* contact phase: minimise ``1/2 |u - u0|_M^2`` subject to ``J u + c >= 0``; the multipliers are the normal
  impulses, Newton matrix ``M + J^T W J`` (6x6 blocks on the contact graph);
* friction phase (boxes ``L = mu sum(lam_n)`` fixed): the primal of the box QP, minimise
  ``1/2 |u - u1|_M^2 + sum L |J_t u + c_t|`` subject to ``n.w = 0`` on the spin rows. The spin rows are eliminated
  (``u = T z``, T an orthonormal basis of their null space, body by body); the absolute values are the interior
  point's epigraph terms, whose multipliers ``a - b`` (``a + b = L``) are the friction impulses; the spin
  multipliers follow from ``n.w = 0`` body by body.

The results are dual points (impulses); the caller computes the velocities from them and certifies the distance
from the exact limit (``models/exact/bound.py``) before keeping them.
"""

from __future__ import annotations

import sys
from typing import Callable

import numpy as np
import scipy.sparse as sp

from models.exact.body_space_ipm import IpmResult, IpmTimeout, QpData, solve_ipm
from models.exact.assembly import ExactReferenceError, Mass

PROGRESS_ROWS = 100_000  # problems with more constraint rows print a line per iteration (stderr)
SPIN_COMPLEMENT = 0.5  # eigenvalue of I - N^T N above which a direction is free of the spin rows (exactly 0 or 1)


def contact_phase_ipm(J: sp.csc_matrix, c: np.ndarray, mass: Mass, u0: np.ndarray, time_s: float,
                      info: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The normal impulses of the contact phase's limit (per row of J) and the primal velocities (for the
    certificate, ``models.exact.bound.contact_phase_bound``)."""
    n = u0.shape[0]
    none = sp.csr_matrix((0, n))
    qp = QpData(mass.mass, -(mass.mass @ u0), sp.csr_matrix(J), c, none, np.zeros(0), np.zeros(0))
    res = _run(qp, u0, time_s, info, "contact")
    return res.lam, res.x


def friction_phase_ipm(J: sp.csc_matrix, c: np.ndarray, N: sp.csc_matrix, mass: Mass, u1: np.ndarray,
                       limit: np.ndarray, time_s: float, info: dict[str, float]) -> np.ndarray:
    """y = (friction impulse per row of J, spin multiplier per row of N) of the friction phase's limit."""
    T = spin_null_space(N, u1.shape[0])
    qp = QpData((T.T @ mass.mass @ T).tocsr(), -(T.T @ (mass.mass @ u1)), sp.csr_matrix((0, T.shape[1])), np.zeros(0),
                (J @ T).tocsr(), c, limit)
    lam_t = np.clip(_run(qp, T.T @ u1, time_s, info, "friction").abs_multiplier, -limit, limit)
    return np.concatenate([lam_t, spin_multipliers(J, N, mass, u1, lam_t)])


def spin_null_space(N: sp.csc_matrix, n_cols: int) -> sp.csr_matrix:
    """T (n_cols x k) with orthonormal columns spanning {u : N u = 0}; N's rows each lie in one body's w columns
    and are orthonormal per body (``exact_reference_assembly.spin_rows``)."""
    bodies = n_cols // 6
    P = np.broadcast_to(np.eye(3), (bodies, 3, 3)).copy()
    Nc = sp.coo_matrix(N)
    if Nc.nnz:
        vec = np.zeros((N.shape[0], 3))
        body = np.zeros(N.shape[0], dtype=np.int64)
        vec[Nc.row, Nc.col % 6 - 3] = Nc.data
        body[Nc.row] = Nc.col // 6
        np.subtract.at(P, body, vec[:, :, None] * vec[:, None, :])
    vals, vecs = np.linalg.eigh(P)
    keep = vals > SPIN_COMPLEMENT  # (bodies, 3)
    ang_count = keep.sum(axis=1)
    per_body = 3 + ang_count
    start = np.r_[0, np.cumsum(per_body)[:-1]]
    rows, cols, data = [], [], []
    lin_rows = (6 * np.arange(bodies)[:, None] + np.arange(3)[None, :]).ravel()
    lin_cols = (start[:, None] + np.arange(3)[None, :]).ravel()
    rows.append(lin_rows)
    cols.append(lin_cols)
    data.append(np.ones(lin_rows.shape[0]))
    kb, ke = np.nonzero(keep)  # body, eigenvector index (ascending eigenvalue: kept ones are the last)
    col_of = start[kb] + 3 + (ke - (3 - ang_count[kb]))
    for comp in range(3):
        rows.append(6 * kb + 3 + comp)
        cols.append(col_of)
        data.append(vecs[kb, comp, ke])
    return sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(n_cols, int(per_body.sum())))


def spin_multipliers(J: sp.csc_matrix, N: sp.csc_matrix, mass: Mass, u1: np.ndarray,
                     lam_t: np.ndarray) -> np.ndarray:
    """s with ``N (u1 - M^-1 (J^T lam_t + N^T s)) = 0`` (N M^-1 N^T is block diagonal per body)."""
    if N.shape[0] == 0:
        return np.zeros(0)
    from scipy.sparse.linalg import splu

    Nm = (N @ mass.inv @ N.T).tocsc()
    return splu(Nm).solve(N @ (u1 - mass.inv @ (J.T @ lam_t)))


def _run(qp: QpData, x0: np.ndarray, time_s: float, info: dict[str, float], phase: str) -> IpmResult:
    from models.exact.sparse_spd_factor import SpdFactorError

    try:
        big = qp.A.shape[0] + qp.C.shape[0] > PROGRESS_ROWS
        res = solve_ipm(qp, x0, max(time_s, 0.0), _progress(phase) if big else None)
    except IpmTimeout as exc:
        _record(info, phase, exc.result)
        raise ExactReferenceError(f"{phase} phase: body-space interior point hit the time budget after "
                                  f"{exc.result.iterations} iterations ({exc.result.seconds:.0f} s; primal / dual "
                                  f"residual {exc.result.primal_residual:.1e} / {exc.result.dual_residual:.1e}, "
                                  f"max s lam {exc.result.complementarity:.1e})") from None
    except SpdFactorError as exc:
        raise ExactReferenceError(f"{phase} phase: {exc}") from None
    _record(info, phase, res)
    return res


def _progress(phase: str) -> Callable[[IpmResult], None]:
    def log(res: IpmResult) -> None:
        print(f"exact reference, {phase} phase: interior point iteration {res.iterations}, {res.seconds:.0f} s, "
              f"primal / dual residual {res.primal_residual:.1e} / {res.dual_residual:.1e}, max s lam "
              f"{res.complementarity:.1e}", file=sys.stderr, flush=True)
    return log


def _record(info: dict[str, float], phase: str, res: IpmResult) -> None:
    key = f"{phase} phase: body-space interior point"
    info[f"{key} iterations"] = res.iterations
    info[f"{key} seconds"] = res.seconds
    info[f"{key} converged"] = float(res.converged)
    info[f"{key} primal residual"] = res.primal_residual
    info[f"{key} dual residual"] = res.dual_residual
    info[f"{key} max s lam"] = res.complementarity
