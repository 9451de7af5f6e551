"""A primal-dual interior-point method (Mehrotra predictor-corrector) for convex QPs whose Newton matrix is sparse:

    minimise 1/2 x^T H x + q^T x + sum_i L_i |C x + d|_i   subject to   A x + b >= 0,

with L > 0. Each ``|r_i|`` is an epigraph variable t_i with two rows ``t - r >= 0`` (multiplier a) and
``t + r >= 0`` (multiplier b), ``a + b = L``; the t are eliminated in closed form, so the normal-equations matrix is

    K = H + A^T diag(lam / s) A + C^T diag(4 W1 W2 / (W1 + W2)) C,   W1 = a / s1, W2 = b / s2,

factorised once per iteration (``models/exact/sparse_spd_factor.py``) and solved twice (affine predictor, centred
corrector). (Left to the factorisation, the t-block would cancel ``W1 + W2 - (W2 - W1)^2 / (W1 + W2)`` in
rounding once one side dominates and break positive definiteness.) KKT: ``H x + q - A^T lam + C^T (a - b) = 0``.

For the exact reference the unknowns are body velocities (6 per body): K has 6x6 blocks on the contact graph, as
sparse as the manifolds, where the dual form over contact points (``A M^-1 A^T``) fills in wherever points share a
body. The iterates are not trusted: callers certify the result (``models/exact/bound.py``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp

from models.exact.sparse_spd_factor import SpdFactor, SpdFactorError

STEP_TO_BOUNDARY = 0.995  # fraction of the largest step that keeps every slack and multiplier > 0
MAX_ITERATIONS = 80
CENTRALITY_CORRECTORS = 2  # Gondzio's correctors per iteration (one solve each, no new factorisation)
CENTRALITY_LOW, CENTRALITY_HIGH = 0.1, 10.0  # products outside [LOW, HIGH] x the target are pushed back
FEASIBILITY_TOLERANCE = 1e-13  # relative to 1 + the largest |b|, |d| (primal) and |q|, L (dual)
# Late in a large solve K's conditioning (weights of 1e16) keeps the dual residual near 1e-12 while complementarity
# still falls (thesis frame: 1.4e-13 at iteration 15, 7.8e-12 at 17): after DUAL_FLOOR_AFTER iterations a dual
# residual up to DUAL_FLOOR is accepted (the primal-point certificate, models/exact/bound.py, is insensitive to it).
DUAL_FLOOR = 1e-10
DUAL_FLOOR_AFTER = 15
COMPLEMENTARITY_TOLERANCE = 1e-15  # max slack * multiplier, relative to (1 + max |b|, |d|) (1 + max multiplier)


@dataclass
class QpData:
    """The problem above; C, d, L may have zero rows (no absolute-value terms), A, b too (no inequalities)."""

    H: sp.csr_matrix
    q: np.ndarray
    A: sp.csr_matrix
    b: np.ndarray
    C: sp.csr_matrix
    d: np.ndarray
    L: np.ndarray


@dataclass
class IpmResult:
    x: np.ndarray
    lam: np.ndarray  # multipliers of the rows of A, >= 0
    abs_multiplier: np.ndarray  # a - b per absolute-value term, in [-L, L] (the stationarity's C^T coefficient)
    iterations: int
    factorizations: int
    seconds: float
    converged: bool
    primal_residual: float
    dual_residual: float
    complementarity: float  # max slack * multiplier


class IpmTimeout(RuntimeError):
    """The time limit passed before the tolerances were met; ``result`` holds the last iterate."""

    def __init__(self, result: IpmResult):
        super().__init__(f"interior point stopped by its time limit after {result.iterations} iterations")
        self.result = result


@dataclass
class _State:
    x: np.ndarray
    t: np.ndarray
    s: np.ndarray  # A x + b
    lam: np.ndarray
    s1: np.ndarray  # t - (C x + d)
    a: np.ndarray
    s2: np.ndarray  # t + (C x + d)
    bm: np.ndarray

    def pairs(self) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
        return (self.s, self.lam), (self.s1, self.a), (self.s2, self.bm)

    def mu(self) -> float:
        n = self.s.size + self.s1.size + self.s2.size
        return sum(float(v @ w) for v, w in self.pairs()) / max(n, 1)


def solve_ipm(qp: QpData, x0: np.ndarray, time_limit_s: float,
              log: Callable[[IpmResult], None] | None = None) -> IpmResult:
    """Solve ``qp`` from ``x0`` (any point); ``H + A^T D A + C^T E C`` must be positive definite for D, E > 0.

    Raises :class:`IpmTimeout` when ``time_limit_s`` passes first (checked once per iteration); ``log`` sees each
    iterate. Returns unconverged after MAX_ITERATIONS, or when K can no longer be factorised (weights of 1e16 and
    more near the limit): the caller's certificate decides."""
    t0 = time.monotonic()
    qp = QpData(sp.csr_matrix(qp.H), qp.q, sp.csr_matrix(qp.A), qp.b, sp.csr_matrix(qp.C), qp.d, qp.L)
    AT, CT = qp.A.T.tocsr(), qp.C.T.tocsr()
    st = _start(qp, x0.astype(np.float64))
    factor = SpdFactor()
    scale_p = 1.0 + max(float(np.abs(qp.b).max(initial=0.0)), float(np.abs(qp.d).max(initial=0.0)))
    scale_d = 1.0 + max(float(np.abs(qp.q).max(initial=0.0)), float(np.abs(qp.L).max(initial=0.0)))
    it = 0
    try:
        while True:
            res = _residuals(qp, AT, CT, st)
            worst_mult = max(float(m.max(initial=0.0)) for m in (st.lam, st.a, st.bm))
            result = IpmResult(st.x, st.lam, st.a - st.bm, it, factor.factorizations, time.monotonic() - t0, False,
                               max(float(np.abs(r).max(initial=0.0)) for r in (res[1], res[2], res[3])),
                               max(float(np.abs(r).max(initial=0.0)) for r in (res[0], res[4])),
                               max(float((v * w).max(initial=0.0)) for v, w in st.pairs()))
            if log is not None:
                log(result)
            if (result.primal_residual <= FEASIBILITY_TOLERANCE * scale_p
                    and result.dual_residual <= max(FEASIBILITY_TOLERANCE, DUAL_FLOOR * (it >= DUAL_FLOOR_AFTER))
                    * scale_d
                    and result.complementarity <= COMPLEMENTARITY_TOLERANCE * scale_p * (1.0 + worst_mult)):
                result.converged = True
                return result
            if it >= MAX_ITERATIONS:
                return result
            if time.monotonic() - t0 > time_limit_s:
                raise IpmTimeout(result)
            try:
                st = _step(qp, AT, CT, st, res, factor)
            except SpdFactorError:  # K numerically singular this close to the limit: the last iterate stands
                return result
            it += 1
    finally:
        factor.release()


def _start(qp: QpData, x: np.ndarray) -> _State:
    """Slacks and multipliers strictly inside (Mehrotra's shift); the absolute-value terms start at a = b = L/2."""
    s0 = qp.A @ x + qp.b
    r0 = qp.C @ x + qp.d
    scale = max(float(np.abs(s0).max(initial=0.0)), float(np.abs(r0).max(initial=0.0)), 1e-3)
    s = np.maximum(s0, 0.0) + 0.1 * scale
    lam = np.full_like(s, 0.1 * scale)
    if s.size:
        gap = float(s @ lam)
        s, lam = s + 0.5 * gap / float(lam.sum()), lam + 0.5 * gap / float(s.sum())
    t = np.abs(r0) + 0.1 * scale
    return _State(x, t, s, lam, t - r0, 0.5 * qp.L, t + r0, 0.5 * qp.L)


def _residuals(qp: QpData, AT: sp.csr_matrix, CT: sp.csr_matrix, st: _State) -> tuple[np.ndarray, ...]:
    """(r_x, r_p, r_1, r_2, r_t): stationarity in x, the three slack definitions, stationarity in t."""
    r = qp.C @ st.x + qp.d
    return (qp.H @ st.x + qp.q - AT @ st.lam + CT @ (st.a - st.bm),
            qp.A @ st.x + qp.b - st.s,
            st.t - r - st.s1,
            st.t + r - st.s2,
            qp.L - st.a - st.bm)


def _step(qp: QpData, AT: sp.csr_matrix, CT: sp.csr_matrix, st: _State, res: tuple[np.ndarray, ...],
          factor: SpdFactor) -> _State:
    r_x, r_p, r_1, r_2, r_t = res
    w = st.lam / st.s
    w1, w2 = st.a / st.s1, st.bm / st.s2
    w12 = w1 + w2
    w_eff = 4.0 * w1 * w2 / w12
    K = (qp.H + AT @ sp.diags(w) @ qp.A + CT @ sp.diags(w_eff) @ qp.C).tocsr()
    factor.factor(K)
    mu = st.mu()

    def direction(rc: tuple[np.ndarray, ...], residuals: bool = True) -> _State:
        rx, rp, r1, r2, rt = (r_x, r_p, r_1, r_2, r_t) if residuals else (0.0 * r for r in (r_x, r_p, r_1, r_2, r_t))
        rc_p, rc_1, rc_2 = rc
        g1 = w1 * r1 + rc_1 / st.s1
        g2 = w2 * r2 + rc_2 / st.s2
        h = (2.0 * w1 * g2 - 2.0 * w2 * g1 + (w1 - w2) * rt) / w12
        rhs = -rx - AT @ (w * rp + rc_p / st.s) - CT @ h
        dx = factor.solve(rhs)
        dx = dx + factor.solve(rhs - K @ dx)  # one refinement step on the normal equations
        ds = qp.A @ dx + rp
        dlam = -(rc_p + st.lam * ds) / st.s
        cdx = qp.C @ dx
        dt = ((w1 - w2) * cdx - g1 - g2 - rt) / w12
        ds1 = dt - cdx + r1
        ds2 = dt + cdx + r2
        da = -(rc_1 + st.a * ds1) / st.s1
        db = -(rc_2 + st.bm * ds2) / st.s2
        return _State(dx, dt, ds, dlam, ds1, da, ds2, db)

    aff = direction((st.s * st.lam, st.s1 * st.a, st.s2 * st.bm))
    alpha = _max_step(st, aff, 1.0)
    trial = _advance(st, aff, alpha)
    sigma = (trial.mu() / mu) ** 3
    corr = direction(tuple(v * m + dv * dm - sigma * mu  # type: ignore[arg-type]
                           for (v, m), (dv, dm) in zip(st.pairs(), aff.pairs())))
    alpha = _max_step(st, corr, 1.0 / STEP_TO_BOUNDARY)
    for _ in range(CENTRALITY_CORRECTORS):  # Gondzio: push outlying products towards the target, same factor
        reach = min(1.0, 1.5 * alpha + 0.1)
        target = sigma * mu
        ahead = _advance(st, corr, reach)
        push = tuple(np.clip(v * m, CENTRALITY_LOW * target, CENTRALITY_HIGH * target) - v * m
                     for v, m in ahead.pairs())
        push = tuple(np.maximum(p, -CENTRALITY_HIGH * target) for p in push)
        extra = direction(tuple(-p for p in push), residuals=False)
        better = _advance(corr, extra, 1.0)
        alpha_better = _max_step(st, better, 1.0 / STEP_TO_BOUNDARY)
        if alpha_better < 1.01 * alpha:
            break
        corr, alpha = better, alpha_better
    return _advance(st, corr, min(1.0, STEP_TO_BOUNDARY * alpha))


def _advance(st: _State, d: _State, alpha: float) -> _State:
    return _State(*(getattr(st, f) + alpha * getattr(d, f) for f in ("x", "t", "s", "lam", "s1", "a", "s2", "bm")))


def _max_step(st: _State, d: _State, cap: float) -> float:
    """The largest alpha <= cap keeping every slack and multiplier >= 0."""
    alpha = cap
    for (v, m), (dv, dm) in zip(st.pairs(), d.pairs()):
        for x, dx in ((v, dv), (m, dm)):
            neg = dx < 0
            if np.any(neg):
                alpha = min(alpha, float((-x[neg] / dx[neg]).min()))
    return alpha
