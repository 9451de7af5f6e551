"""MPRGP: a matrix-free solver for the box-constrained convex QP  minimise 1/2 x^T H x + g^T x,  lo <= x <= hi.

Modified proportioning with reduced gradient projections (Dostal, "Optimal Quadratic Programming Algorithms",
2009, ch. 7): conjugate-gradient steps on the current face while the iterate is proportional (its chopped
gradient, the part pointing out of the box at the active bounds, is no larger than its free gradient), expansion
steps (a fixed-length projected gradient step, ``step`` at most 2 / |H|) where CG would leave the box, and
proportioning steps that release bounds otherwise. It needs only products with H (here ``J M^-1 J^T`` applied as
two sparse products, never formed), converges for any positive semidefinite H with a bounded-below objective
(singular H included: the contact problem's four coplanar points), and identifies the active set in finitely many
steps on non-degenerate problems, after which it is CG on the solution's face.

The variables are scaled by the square root of H's diagonal (Jacobi), which keeps the bounds boxes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

Operator = Callable[[np.ndarray], np.ndarray]

POWER_ITERATIONS = 40  # estimate of |H| for the expansion step
STEP_FRACTION = 1.8  # expansion step = STEP_FRACTION / |H| (convergence needs < 2 / |H|)
PROPORTIONING = 1.0  # Gamma: proportional when |chopped gradient| <= Gamma |reduced free gradient|


@dataclass
class MprgpResult:
    x: np.ndarray
    iterations: int
    products: int  # products with H
    projected_gradient: float  # |projected gradient| of the scaled problem at the end
    seconds: float
    converged: bool


def _norm_estimate(h: Operator, n: int) -> float:
    v = np.random.default_rng(0).standard_normal(n)
    v /= np.linalg.norm(v)
    lam = 0.0
    for _ in range(POWER_ITERATIONS):
        w = h(v)
        lam = float(np.linalg.norm(w))
        if lam == 0.0:
            return 1.0
        v = w / lam
    return lam * 1.05  # the power iteration approaches |H| from below


def mprgp(h: Operator, diag: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray,
          tolerance: float, max_iterations: int, time_limit_s: float) -> MprgpResult:
    """Minimise 1/2 x^T H x + g^T x over lo <= x <= hi (H given by products ``h``, its diagonal ``diag``).

    Stops when the projected gradient of the Jacobi-scaled problem (units of the rows' velocity) is below
    ``tolerance``, or after ``max_iterations`` or ``time_limit_s`` (then ``converged`` is False)."""
    t0 = time.monotonic()
    d = np.sqrt(np.maximum(diag, 1e-300))
    products = 0

    def hs(y: np.ndarray) -> np.ndarray:  # the scaled operator D^-1 H D^-1
        nonlocal products
        products += 1
        return h(y / d) / d

    gs = g / d
    los, his = lo * d, hi * d
    x = np.clip(x0 * d, los, his)
    step = STEP_FRACTION / _norm_estimate(hs, x.size)
    grad = hs(x) + gs
    p = _free_gradient(x, grad, los, his)
    it = 0
    converged = False
    while it < max_iterations:
        free_g = _free_gradient(x, grad, los, his)
        chop = _chopped_gradient(x, grad, los, his)
        pg = float(np.sqrt(free_g @ free_g + chop @ chop))
        if pg <= tolerance:
            converged = True
            break
        if time.monotonic() - t0 > time_limit_s:
            break
        it += 1
        reduced = _reduced_free_gradient(x, free_g, los, his, step)
        if chop @ chop <= PROPORTIONING ** 2 * (reduced @ free_g):
            hp = hs(p)
            php = float(p @ hp)
            if php <= 0.0:  # p in H's null space: an expansion step moves on
                x, grad = _expand(x, grad, free_g, los, his, step, hs, gs)
                p = _free_gradient(x, grad, los, his)
                continue
            a_cg = float(grad @ p) / php
            a_feas = _max_feasible_step(x, p, los, his)
            if a_cg <= a_feas:
                x = x - a_cg * p
                grad = grad - a_cg * hp
                free_g = _free_gradient(x, grad, los, his)
                p = free_g - (float(free_g @ hp) / php) * p
            else:
                x = x - a_feas * p
                grad = grad - a_feas * hp
                x, grad = _expand(x, grad, _free_gradient(x, grad, los, his), los, his, step, hs, gs)
                p = _free_gradient(x, grad, los, his)
        else:
            hc = hs(chop)
            a = float(grad @ chop) / max(float(chop @ hc), 1e-300)
            x = np.clip(x - a * chop, los, his)
            grad = hs(x) + gs  # recomputed: the clip keeps x exactly on its bounds
            p = _free_gradient(x, grad, los, his)
    free_g = _free_gradient(x, grad, los, his)
    chop = _chopped_gradient(x, grad, los, his)
    pg = float(np.sqrt(free_g @ free_g + chop @ chop))
    return MprgpResult(x / d, it, products, pg, time.monotonic() - t0, converged or pg <= tolerance)


def _expand(x: np.ndarray, grad: np.ndarray, free_g: np.ndarray, lo: np.ndarray, hi: np.ndarray, step: float,
            hs: Operator, gs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x = np.clip(x - step * free_g, lo, hi)
    return x, hs(x) + gs


def _free_gradient(x: np.ndarray, grad: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.where((x > lo) & (x < hi), grad, 0.0)


def _chopped_gradient(x: np.ndarray, grad: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    at_lo = x <= lo
    at_hi = x >= hi
    return np.where(at_lo, np.minimum(grad, 0.0), np.where(at_hi, np.maximum(grad, 0.0), 0.0))


def _reduced_free_gradient(x: np.ndarray, free_g: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                           step: float) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        up = np.minimum((x - lo) / step, free_g)
        down = np.maximum((x - hi) / step, free_g)
    return np.where(free_g > 0, up, np.where(free_g < 0, down, 0.0))


def _max_feasible_step(x: np.ndarray, p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """The largest a with lo <= x - a p <= hi."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a_lo = np.where(p > 0, (x - lo) / p, np.inf)
        a_hi = np.where(p < 0, (x - hi) / p, np.inf)
    return float(min(a_lo.min(initial=np.inf), a_hi.min(initial=np.inf)))


def unconstrained_start(h: Operator, diag: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                        steps: int) -> np.ndarray:
    """A warm start: ``steps`` Jacobi-preconditioned CG steps on H x = -g with every bound ignored (a resting
    stack with every contact active, every friction row sticking), clipped into the box. Any start is valid;
    this one puts most rows near their final face at once, where a start at zero would discover the active set
    one layer of the stack at a time."""
    x = np.zeros_like(g)
    r = -g.copy()
    z = r / diag
    p = z.copy()
    rz = float(r @ z)
    for _ in range(steps):
        hp = h(p)
        php = float(p @ hp)
        if not php > 0.0 or rz == 0.0:
            break
        a = rz / php
        x += a * p
        r -= a * hp
        z = r / diag
        rz, rz_old = float(r @ z), rz
        p = z + (rz / rz_old) * p
    return np.clip(x, lo, hi)
