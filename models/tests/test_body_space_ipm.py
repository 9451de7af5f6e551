"""The body-space interior point's active-set polish (``models/body_space_ipm.py``) on small QPs of the exact
reference's two shapes: the contact phase (inequalities, some of them combinations of others, as a cube face's
four coplanar contact points are) and the friction phase (absolute values, some with an almost empty box)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from models import body_space_ipm as ipm

SEED = 7


def _rows(rng: np.random.Generator, m: int, n: int, per_row: int = 4) -> sp.csr_matrix:
    """m sparse rows of ``per_row`` normal entries each (as a contact row couples two bodies' few velocities)."""
    cols = np.stack([rng.choice(n, per_row, replace=False) for _ in range(m)])
    return sp.csr_matrix((rng.normal(size=m * per_row), (np.repeat(np.arange(m), per_row), cols.ravel())),
                         shape=(m, n))


def _contact_qp(rng: np.random.Generator) -> ipm.QpData:
    """minimise 1/2 |x - x0|_H^2 subject to A x + b >= 0, rows 40-44 dependent on rows 0-24, about half the rows
    active at the solution."""
    n, m = 30, 40
    H = sp.diags(rng.uniform(0.5, 4.0, n)).tocsr()
    A = _rows(rng, m, n)
    x0 = rng.normal(size=n)
    b = -(A @ x0) + rng.normal(scale=0.5, size=m)
    A = sp.vstack([A, A[:5] + A[10:15] - A[20:25]]).tocsr()  # a face's fourth corner: the other three's sum
    b = np.concatenate([b, b[:5] + b[10:15] - b[20:25]])
    none = sp.csr_matrix((0, n))
    return ipm.QpData(H, -(H @ x0), A, b, none, np.zeros(0), np.zeros(0))


def _friction_qp(rng: np.random.Generator) -> ipm.QpData:
    """minimise 1/2 |x - x0|_H^2 + sum L |C x + d|, with some boxes almost zero (manifolds without normal impulse)."""
    n, m = 30, 24
    H = sp.diags(rng.uniform(0.5, 4.0, n)).tocsr()
    C = _rows(rng, m, n)
    L = rng.uniform(0.0, 2.0, m)
    L[::6] = 1e-15  # the interior point needs L > 0
    x0 = rng.normal(size=n)
    return ipm.QpData(H, -(H @ x0), sp.csr_matrix((0, n)), np.zeros(0), C, rng.normal(scale=0.3, size=m), L)


QPS = {"contact": _contact_qp, "friction": _friction_qp}
TRIES = ipm.POLISH_TRIES


def _solve(qp: ipm.QpData, monkeypatch: pytest.MonkeyPatch, tries: int) -> ipm.IpmResult:
    monkeypatch.setattr(ipm, "POLISH_TRIES", tries)
    return ipm.solve_ipm(qp, np.zeros(qp.H.shape[0]), 60.0)


def _assert_optimal(qp: ipm.QpData, r: ipm.IpmResult) -> None:
    """The optimality conditions, checked here rather than by the solver's own residuals: feasibility,
    multipliers in their bounds, complementarity, stationarity (``H x + q - A^T lam + C^T m = 0``)."""
    s = qp.A @ r.x + qp.b
    assert s.min(initial=0.0) >= -1e-12 and r.lam.min(initial=0.0) >= 0.0
    assert np.abs(r.lam * s).max(initial=0.0) <= 1e-13 * (1.0 + r.lam.max(initial=0.0))  # s to rounding
    res = qp.C @ r.x + qp.d
    m = r.abs_multiplier
    assert np.all(np.abs(m) <= qp.L)
    sliding = np.abs(res) > 1e-9
    assert np.abs(m - qp.L * np.sign(res))[sliding].max(initial=0.0) <= 1e-9
    assert np.abs(qp.H @ r.x + qp.q - qp.A.T @ r.lam + qp.C.T @ m).max() <= 1e-10


@pytest.mark.parametrize("shape", sorted(QPS))
def test_polish_ends_sooner_on_the_solution(shape: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """With the polish the solve ends in fewer iterations on a point that meets the interior point's tolerances
    and the optimality conditions, the point the interior point alone approaches. (On the contact QP's dependent
    rows the interior point alone stops unconverged: its Newton matrix becomes singular first.)"""
    print(f"seed {SEED}")
    qp = QPS[shape](np.random.default_rng(SEED))
    plain = _solve(qp, monkeypatch, 0)
    polished = _solve(qp, monkeypatch, TRIES)
    assert polished.converged and polished.polished and not plain.polished
    assert polished.iterations < plain.iterations
    _assert_optimal(qp, polished)
    assert np.abs(polished.x - plain.x).max() <= (1e-10 if plain.converged else 1e-8)


@pytest.mark.parametrize("shape", sorted(QPS))
def test_active_set_rounds_correct_a_guess_from_the_first_iterate(shape: str,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Guessed from the starting point, the active set is wrong; the primal-dual active-set rounds correct it and
    the solve ends on the solution at once."""
    qp = QPS[shape](np.random.default_rng(SEED))
    monkeypatch.setattr(ipm, "POLISH_FROM", np.inf)
    guessed = _solve(qp, monkeypatch, TRIES)
    assert guessed.converged and guessed.polished and guessed.iterations == 0
    _assert_optimal(qp, guessed)


@pytest.mark.parametrize("shape", sorted(QPS))
def test_a_wrong_guess_costs_time_not_the_answer(shape: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Guesses from the first iterates without the rounds' corrections are refused by the tolerances, every try;
    the interior point goes on to where it goes without the polish."""
    qp = QPS[shape](np.random.default_rng(SEED))
    plain = _solve(qp, monkeypatch, 0)
    monkeypatch.setattr(ipm, "POLISH_FROM", np.inf)
    monkeypatch.setattr(ipm, "POLISH_ROUNDS", 1)
    guessed = _solve(qp, monkeypatch, TRIES)
    assert not guessed.polished and guessed.converged == plain.converged
    assert guessed.factorizations == plain.factorizations + TRIES
    assert np.array_equal(guessed.x, plain.x)
