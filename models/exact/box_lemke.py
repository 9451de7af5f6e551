"""Complementary pivoting (Lemke's method) for the box-constrained linear complementarity problem, started from a
guessed active set: find ``lo <= x <= hi`` with, per row, ``w = A x - b`` equal to 0 where ``lo < x < hi``, at least
0 where ``x = lo`` and at most 0 where ``x = hi``. A is any square matrix (not symmetric, not positive definite);
every bound finite.

The variables are x, w and an artificial z0 (``w = A x - b + d z0``). A basis holds, per row, x (w = 0) or w (x at
one of its bounds), and z0 in the place of the one row whose pair is out (Lemke's almost complementary basis). The
start (the warm start of Dirkse and Ferris's PATH crash): the guess's active set names a complementary basis; its
basic solution ``s`` (at z0 = 0) breaks some bounds; the covering vector ``d = B (t - s)`` with t the basic values
moved inside their bounds makes the basis feasible at z0 = 1. z0 then falls: the first basic variable to reach a
bound leaves and z0 takes its place; from there, each step enters the complement of the variable that left, moves
it until a basic variable reaches a bound (the ratio test; an entering x may instead cross its box, a bound flip
that makes its w enter next), and pivots. The method ends when z0 leaves the basis at 0: the basis is then a
solution. With every bound finite the path cannot run off to infinity (x is boxed, and w and z0 are then fixed by
the basis), so it ends at a solution unless degeneracy (ties in the ratio test) makes it cycle: ties go to z0, then
to the largest pivot; ``max_pivots`` bounds the work.

The basis inverse is held dense and updated by one rank-one step per pivot (refactorised every ``REFACTOR_EVERY``
pivots, its basic values recomputed): for the friction phase's components of up to a few thousand rows
(``models/exact/damped_friction.py``).
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator

import numpy as np

REFACTOR_EVERY = 64
REFINEMENTS = 2  # iterative refinement steps of the basic values at each refactorisation
PIVOT_ROWS_LIMIT = 3000  # the largest component pivoted (dense: A and B^-1 take 16 n^2 bytes, B^-1 n^3 flops)
ZERO_PIVOT = 1e-11  # relative to the entering column's largest entry: smaller pivots are not taken
FEASIBILITY = 1e-12  # relative slack in the ratio test (bounds reached up to rounding)
RANK_TOLERANCE = 1e-10  # relative |R_kk| of the starting basis's pivoted QR below which a column is dependent
INSIDE = 1e-3  # the warm start moves an out-of-bound basic x this share of its box inside


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Dense linear algebra on one BLAS thread: the components pivoted here are small (up to PIVOT_ROWS_LIMIT rows),
    and on a loaded 2-core machine OpenBLAS's threads wait on each other (measured on a random world of 434 bodies:
    the same pivoting took 121 s with two threads under a load of 9-13 and 2.4 s with one)."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


@dataclass
class PivotResult:
    x: np.ndarray
    pivots: int
    solved: bool  # z0 left the basis: the basis is a solution (up to rounding; check the natural residual)
    reason: str = ""  # why not, when not solved


class _Basis:
    """The basis: ``var[k]`` (row position k) is x_i (i), w_i (n + i) or z0 (2n); B^-1 dense; basic values."""

    def __init__(self, A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray, basic_x: np.ndarray,
                 at_hi: np.ndarray) -> None:
        self.A, self.b, self.lo, self.hi = A, b, lo, hi
        self.n = b.shape[0]
        self.var = np.where(basic_x, np.arange(self.n), self.n + np.arange(self.n))
        self.at_hi = at_hi.copy()  # for a non-basic x: which bound it sits at
        self.d = np.zeros(self.n)  # covering vector (z0's column is -d)
        self.z0 = 0.0  # z0's value while non-basic (the warm start's homotopy parameter)
        self.refactor()

    def column(self, v: int) -> np.ndarray:
        """The column of variable v in ``w - A x - d z0 = -b``."""
        if v < self.n:
            return -self.A[:, v]
        if v < 2 * self.n:
            e = np.zeros(self.n)
            e[v - self.n] = 1.0
            return e
        return -self.d

    def nonbasic_x(self) -> np.ndarray:
        """Values of every x as non-basic (at its bound); basic ones are overwritten by the caller."""
        return np.where(self.at_hi, self.hi, self.lo)

    def refactor(self) -> None:
        """B^-1 afresh and the basic values from it, with REFINEMENTS steps of iterative refinement."""
        B = np.column_stack([self.column(int(v)) for v in self.var])
        self.Binv = np.linalg.inv(B)
        xn = self.nonbasic_x()
        xn[self.var[self.var < self.n]] = 0.0
        rhs = -self.b + self.A @ xn + (self.d * self.z0 if 2 * self.n not in self.var else 0.0)
        self.values = self.Binv @ rhs
        for _ in range(REFINEMENTS):
            self.values += self.Binv @ (rhs - B @ self.values)
        self.since = 0

    def lower_upper(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of each basic variable: x in its box, w >= 0 (its x at lo) or <= 0 (at hi), z0 >= 0."""
        lo = np.full(self.n, -np.inf)
        hi = np.full(self.n, np.inf)
        is_x = self.var < self.n
        is_w = (self.var >= self.n) & (self.var < 2 * self.n)
        i = self.var[is_x]
        lo[is_x], hi[is_x] = self.lo[i], self.hi[i]
        j = self.var[is_w] - self.n
        lo[is_w] = np.where(self.at_hi[j], -np.inf, 0.0)
        hi[is_w] = np.where(self.at_hi[j], 0.0, np.inf)
        lo[self.var == 2 * self.n] = 0.0
        return lo, hi

    def pivot(self, row: int, v: int, alpha: np.ndarray, value: float) -> None:
        self.var[row] = v
        piv = self.Binv[row] / alpha[row]
        self.Binv -= np.outer(alpha, piv)
        self.Binv[row] = piv
        self.values[row] = value
        self.since += 1

    def solution(self) -> np.ndarray:
        x = self.nonbasic_x()
        is_x = self.var < self.n
        x[self.var[is_x]] = self.values[is_x]
        return np.clip(x, self.lo, self.hi)


def _ratio(values: np.ndarray, rate: np.ndarray, lo: np.ndarray, hi: np.ndarray, var: np.ndarray,
           z0: int) -> tuple[float, int]:
    """The largest step t >= 0 along ``values + t rate`` that keeps every basic value within its bounds, and the
    position that blocks it (-1: none). Ties go to z0, then to the largest |rate| (the largest pivot)."""
    scale = np.maximum(np.abs(values), 1.0) * FEASIBILITY
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(rate > 0, (hi - values + scale) / rate, np.inf)
        down = np.where(rate < 0, (lo - values - scale) / rate, np.inf)
    t = np.maximum(np.minimum(up, down), 0.0)
    best = float(t.min(initial=np.inf))
    if not np.isfinite(best):
        return best, -1
    # the exact step to each bound (without the slack) among the near-ties
    ties = np.flatnonzero(t <= best * (1 + 1e-9) + 1e-300)
    if np.any(var[ties] == z0):
        pos = int(ties[var[ties] == z0][0])
    else:
        pos = int(ties[np.argmax(np.abs(rate[ties]))])
    target = hi[pos] if rate[pos] > 0 else lo[pos]
    return max(float((target - values[pos]) / rate[pos]), 0.0), pos


def box_lemke(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray, guess: np.ndarray | None,
              max_pivots: int, deadline: float = np.inf) -> PivotResult:
    """:func:`_lemke`, with a basis that rounding made singular reported as a failure."""
    try:
        return _lemke(A, b, lo, hi, guess, max_pivots, deadline)
    except np.linalg.LinAlgError:
        fallback = np.clip(np.zeros(b.shape[0]) if guess is None else guess, lo, hi)
        return PivotResult(fallback, 0, False, "the basis became singular (degenerate pivots)")


def _lemke(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray, guess: np.ndarray | None,
           max_pivots: int, deadline: float = np.inf) -> PivotResult:
    """A solution of the box LCP (module docstring) by complementary pivoting from the active set of ``guess``
    (rows whose projected step ``guess + (b - A guess) / diag`` lands on a bound are non-basic there), or, with
    ``guess`` None, Lemke's own start: every x at its lower bound and the covering vector all ones (its path cannot
    end on a ray but the one it starts on, so it ends at a solution unless ties make it cycle)."""
    n = b.shape[0]
    if guess is None:
        free, at_hi = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    else:
        diag = np.abs(np.diag(A))
        diag = np.where(diag > 0, diag, 1.0)
        step = guess + (b - A @ guess) / diag
        at_lo, at_hi = step <= lo, step >= hi
        free = _independent(A, ~(at_lo | at_hi))
        at_hi = at_hi | (~free & ~at_lo & (guess > 0.5 * (lo + hi)))  # dropped from the basis: the nearer bound
    basis = _Basis(A, b, lo, hi, free, at_hi)
    z0 = 2 * n
    blo, bhi = basis.lower_upper()
    s = basis.values
    if np.all((s >= blo - FEASIBILITY * np.maximum(np.abs(s), 1)) & (s <= bhi + FEASIBILITY * np.maximum(np.abs(s), 1))):
        return PivotResult(basis.solution(), 0, True)
    if guess is None:  # every w basic (B = I): d all ones, scaled so that z0 = 1 lifts every w above 0
        delta = np.full(n, max(-float(s.min()), 0.0) * (1.0 + INSIDE) + INSIDE * max(float(np.abs(s).max()), 1e-300))
        target = s + delta
    else:  # the warm start: basic values moved inside their bounds at z0 = 1
        width = np.where(np.isfinite(bhi - blo), bhi - blo, np.maximum(np.abs(s), 1.0))
        target = np.where(s > bhi, bhi - INSIDE * width, np.where(s < blo, blo + INSIDE * width, s))
        delta = target - s  # B^-1 d
    basis.d = np.column_stack([basis.column(int(v)) for v in basis.var]) @ delta
    # z0 falls from 1: values = target - t delta, t = 1 - z0
    basis.values = target.copy()
    basis.z0 = 1.0
    t, pos = _ratio(basis.values, -delta, blo, bhi, basis.var, -1)
    if pos < 0 or t >= 1.0:
        return PivotResult(basis.solution(), 0, False, "the warm start's basis is not blocked before z0 = 0")
    basis.values = basis.values - t * delta
    leaving = int(basis.var[pos])
    alpha = basis.Binv @ basis.column(z0)
    basis.pivot(pos, z0, alpha, 1.0 - t)
    basis.z0 = 0.0
    for pivots in range(1, max_pivots + 1):
        if time.monotonic() > deadline:
            return PivotResult(basis.solution(), pivots, False, "out of time")
        enter, direction = _complement(basis, leaving, n)
        alpha = basis.Binv @ basis.column(enter)
        rate = -alpha * direction
        blo, bhi = basis.lower_upper()
        tiny = np.abs(rate) < ZERO_PIVOT * max(float(np.abs(rate).max(initial=0.0)), 1e-300)
        rate = np.where(tiny, 0.0, rate)
        t, pos = _ratio(basis.values, rate, blo, bhi, basis.var, z0)
        flip = np.inf if enter >= n else float(hi[enter] - lo[enter])
        if pos < 0 and not np.isfinite(flip):
            return PivotResult(basis.solution(), pivots, False, "a ray (no basic variable blocks the entering one)")
        if flip <= t:  # an entering x crosses its box: it stays non-basic at the other bound, its w enters next
            basis.values = basis.values + flip * rate
            basis.at_hi[enter] = not basis.at_hi[enter]
            leaving = enter
            continue
        start = (hi[enter] if basis.at_hi[enter] else lo[enter]) if enter < n else 0.0
        basis.values = basis.values + t * rate
        leaving = int(basis.var[pos])
        if leaving < n:
            basis.at_hi[leaving] = rate[pos] > 0  # it left at the bound it reached
        basis.pivot(pos, enter, alpha, start + direction * t)
        if leaving == z0:
            basis.refactor()  # the basic solution from a fresh factorisation (the rank-one updates drift)
            return PivotResult(basis.solution(), pivots, True)
        if basis.since >= REFACTOR_EVERY:
            basis.refactor()
    return PivotResult(basis.solution(), max_pivots, False, f"no solution within {max_pivots} pivots")


def _independent(A: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``free`` less the rows whose x would make the starting basis singular: the principal submatrix A_FF's
    columns that a pivoted QR finds dependent (a singular A_FF: impulses that are not unique)."""
    from scipy.linalg import qr

    f = np.flatnonzero(free)
    if not f.size:
        return free
    sub = A[np.ix_(f, f)]
    _, r, perm = qr(sub, mode="economic", pivoting=True)
    diag = np.abs(np.diag(r))
    keep = f[perm[diag > RANK_TOLERANCE * max(float(diag[0]), 1e-300)]]
    out = np.zeros_like(free)
    out[keep] = True
    if keep.size and np.linalg.cond(A[np.ix_(keep, keep)]) > 1.0 / RANK_TOLERANCE:
        return np.zeros_like(free)  # no well-conditioned basis from the guess: start from every x at a bound
    return out


def _complement(basis: _Basis, leaving: int, n: int) -> tuple[int, float]:
    """The variable that enters after ``leaving`` left, and the direction it moves in (+1 or -1)."""
    if leaving < n:  # x left at a bound: its w enters, >= 0 at lo, <= 0 at hi
        return n + leaving, (-1.0 if basis.at_hi[leaving] else 1.0)
    i = leaving - n  # w left at 0: its x enters, away from its bound
    return i, (-1.0 if basis.at_hi[i] else 1.0)


def component_rows(A) -> list[np.ndarray]:
    """The rows of each connected component of A's graph (rows i, j joined where A_ij or A_ji is not 0)."""
    from scipy.sparse.csgraph import connected_components

    count, label = connected_components(abs(A) + abs(A.T), directed=False)
    order = np.argsort(label, kind="stable")
    starts = np.searchsorted(label[order], np.arange(count + 1))
    return [order[starts[k]:starts[k + 1]] for k in range(count)]
