"""The box LCP solvers of the exact reference (models/exact/box_lcp.py, models/exact/box_lemke.py) and the damped
friction phase built on them (models/exact/damped_friction.py), on small synthetic problems whose solutions are
known: every solution found by enumerating the active sets, the kernel's own passes run to their limit, a P-matrix
(one solution) and a matrix with several."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.sparse as sp

from models.exact.box_lcp import BoxProblem, gauss_seidel, newton, solve_box
from models.exact import box_lcp
from models.exact.box_lemke import PivotResult, box_lemke
from models.exact.assembly import ExactReferenceError, Mass, block_mass
from models.exact.damped_friction import certified_unique, damped_friction_phase


def all_solutions(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    """Every solution of the box LCP ``r = b - A x`` (r = 0 inside, <= 0 at lo, >= 0 at hi), by enumerating the
    3^n active sets (isolated solutions; n small)."""
    n = b.shape[0]
    found: list[np.ndarray] = []
    for state in itertools.product((-1, 0, 1), repeat=n):
        s = np.array(state)
        x = np.where(s < 0, lo, np.where(s > 0, hi, 0.0))
        free = s == 0
        if free.any():
            sub = A[np.ix_(free, free)]
            if abs(np.linalg.det(sub)) < 1e-12:
                continue
            x[free] = np.linalg.solve(sub, b[free] - A[np.ix_(free, ~free)] @ x[~free])
        r = b - A @ x
        ok = np.all(x[free] >= lo[free] - 1e-12) and np.all(x[free] <= hi[free] + 1e-12)
        ok = ok and np.all(r[s < 0] <= 1e-12) and np.all(r[s > 0] >= -1e-12)
        if ok and not any(np.allclose(x, y, atol=1e-9) for y in found):
            found.append(x)
    return found


def residual(prob: BoxProblem, x: np.ndarray) -> float:
    return prob.worst(x)


def _problem(A: np.ndarray, b: np.ndarray, L: float = 1.0) -> BoxProblem:
    n = b.shape[0]
    return BoxProblem(sp.csr_matrix(A), b, np.abs(np.diag(A)).copy(), np.full(n, -L), np.full(n, L))


def test_unique_solution_of_a_non_symmetric_p_matrix_is_found_by_every_method() -> None:
    """A non-symmetric A whose symmetric part is positive definite (one solution, certified): Gauss-Seidel, Newton,
    pivoting from a guess and pivoting from the lower bounds all reach the one solution enumeration finds, with
    rows inside the box and at both bounds."""
    A = np.array([[4.0, 1.5, -1.0, 0.5], [-1.0, 3.0, 1.2, 0.0], [0.8, -0.7, 2.5, 0.9], [0.3, 0.0, -0.9, 2.0]])
    b = np.array([1.0, -6.0, 2.0, 5.5])
    prob = _problem(A, b)
    truth = all_solutions(A, b, prob.lo, prob.hi)
    assert len(truth) == 1 and certified_unique(sp.csr_matrix(A))
    x_star = truth[0]
    assert np.any(np.abs(x_star) < 1.0 - 1e-6) and np.any(x_star == 1.0) and np.any(x_star == -1.0)
    x, res, out = solve_box(prob, np.zeros(4), accept=1e-12)
    assert res <= 1e-12 and np.allclose(x, x_star, atol=1e-10)
    gs, _ = gauss_seidel(prob, np.zeros(4))
    assert np.allclose(gs, x_star, atol=1e-10)
    y, r, _ = newton(prob, np.zeros(4))
    assert r <= 1e-12 and np.allclose(y, x_star, atol=1e-10)
    for guess in (None, np.zeros(4), x_star):
        piv = box_lemke(A, b, prob.lo, prob.hi, guess, 100)
        assert piv.solved and np.allclose(piv.x, x_star, atol=1e-10), (guess, piv)
    assert box_lemke(A, b, prob.lo, prob.hi, x_star, 100).pivots == 0  # started at the solution: nothing to do


def test_several_solutions_are_not_certified_unique_and_each_result_is_one_of_them() -> None:
    """A = [[1, 2], [2, 1]] is no P-matrix (det < 0): with b = (0.5, 0.5) the box problem has three solutions.
    The uniqueness certificate refuses it; every method returns one of the enumerated solutions; Gauss-Seidel from
    zero (the kernel's start) and pivoting from the lower bounds may end at different ones."""
    A = np.array([[1.0, 2.0], [2.0, 1.0]])
    b = np.array([0.5, 0.5])
    prob = _problem(A, b)
    truth = all_solutions(A, b, prob.lo, prob.hi)
    assert len(truth) == 3
    assert not certified_unique(sp.csr_matrix(A))
    x, res, _ = solve_box(prob, np.zeros(2), accept=1e-12)
    assert res <= 1e-12 and any(np.allclose(x, t, atol=1e-9) for t in truth)
    cold = box_lemke(A, b, prob.lo, prob.hi, None, 50)
    assert cold.solved and any(np.allclose(cold.x, t, atol=1e-9) for t in truth)
    for t in truth:  # each solution is its own warm start's answer
        assert np.allclose(box_lemke(A, b, prob.lo, prob.hi, t, 50).x, t, atol=1e-12)


def test_pivoting_solves_what_gauss_seidel_and_newton_cannot() -> None:
    """A matrix with a negative real eigenvalue whose Gauss-Seidel sweeps cycle and whose Newton iteration stalls:
    the pipeline still certifies, by pivoting, a solution enumeration confirms."""
    A = np.array([[1.0, 0.0, 3.0], [3.0, 1.0, 0.0], [0.0, 3.0, 1.0]])  # cyclic coupling: GS oscillates
    b = np.array([0.3, -0.2, 0.1])
    prob = _problem(A, b)
    truth = all_solutions(A, b, prob.lo, prob.hi)
    assert truth and np.min(np.linalg.eigvals(A).real) < 0
    gs, _ = gauss_seidel(prob, np.zeros(3), max_sweeps=200)
    assert residual(prob, gs) > 1e-6  # the sweeps do not settle
    x, res, out = solve_box(prob, np.zeros(3), accept=1e-12)
    assert res <= 1e-12 and any(np.allclose(x, t, atol=1e-9) for t in truth)
    assert out.methods and out.methods[0] in (2, 3)  # a pivoting method gave it


def _damped_body(seed: int = 3) -> tuple[sp.csr_matrix, np.ndarray, sp.csr_matrix, Mass, np.ndarray, np.ndarray]:
    """One turned non-cube body (full 3x3 inverse inertia) resting on the ground: two friction rows at a point off
    its centre, a spin row along the normal, which is no eigenvector of the inverse inertia."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    inv_inertia = q @ np.diag([2.0, 7.0, 15.0]) @ q.T
    n = np.array([0.0, 1.0, 0.0])
    assert np.linalg.norm(np.cross(inv_inertia @ n, n)) > 0.5  # not an eigenvector
    r = np.array([0.12, -0.05, 0.07])  # contact point from the centre
    tangents = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    J = sp.csr_matrix(np.hstack([tangents, np.cross(r, tangents)]))
    N = sp.csr_matrix(np.hstack([np.zeros(3), n])[None, :])
    mass = block_mass(np.array([0.5]), inv_inertia[None])
    u1 = np.array([0.4, 0.0, -0.3, 1.5, 2.0, -1.0])
    return J, np.zeros(2), N, mass, u1, np.array([0.05, 0.05])


def _kernel_passes(J: sp.csr_matrix, N: sp.csr_matrix, mass: Mass, u1: np.ndarray, limit: np.ndarray,
                   passes: int) -> np.ndarray:
    """The kernel's friction passes in float64: each row ``lam = clip(lam + (J u) / Kt, -L, L)``, velocities along
    ``-M^-1 J^T``, then the damping ``w -= 0.1 (n.w) n``."""
    Jd, Nd, Minv = J.toarray(), N.toarray(), mass.inv.toarray()
    kt = np.einsum("ij,jk,ik->i", Jd, Minv, Jd)
    u, lam = u1.copy(), np.zeros(Jd.shape[0])
    for _ in range(passes):
        for j in range(Jd.shape[0]):
            new = np.clip(lam[j] + (Jd[j] @ u) / kt[j], -limit[j], limit[j])
            u -= Minv @ Jd[j] * (new - lam[j])
            lam[j] = new
        for row in Nd:
            u -= 0.1 * (row @ u) * row
    return u


@pytest.mark.parametrize("seed, limit", [(3, 0.05), (3, 5.0), (11, 0.05)])
def test_damped_friction_phase_is_the_limit_of_the_kernels_passes(seed: int, limit: float) -> None:
    """A damped direction that is no eigenvector of the inverse inertia (sliding and sticking boxes): the damped
    friction phase's velocities are where the kernel's passes end (20,000 passes), and not the convex QP's (the
    damping along I^-1 n), which a solver that treated the problem as the QP would return."""
    J, c, N, mass, u1, _ = _damped_body(seed)
    L = np.full(2, limit)
    info: dict[str, float] = {}
    lam, u = damped_friction_phase(J, c, N, mass, u1, L, info, "test body")
    passes = _kernel_passes(J, N, mass, u1, L, 20000)
    assert np.abs(u - passes).max() <= 1e-9
    assert abs(N.toarray() @ u).max() <= 1e-12
    # the convex QP's answer: stationarity moves w along I^-1 n instead
    G = sp.vstack([J, N]).tocsr()
    H = (G @ mass.inv @ G.T).toarray()
    qp = BoxProblem(sp.csr_matrix(H), G @ u1, np.diag(H).copy(), np.array([-limit, -limit, -np.inf]),
                    np.array([limit, limit, np.inf]))
    y, r, _ = newton(qp, np.zeros(3))
    u_qp = u1 - mass.inv @ (G.T @ y)
    assert r <= 1e-12 and np.abs(u_qp - u).max() > 1e-3
    assert info["friction phase: non-symmetric box problem (damping off the inertia's eigenvectors) natural residual "
                "(m/s)"] <= 1e-9


def test_damped_friction_phase_that_cannot_certify_names_every_method(monkeypatch: pytest.MonkeyPatch) -> None:
    """With Gauss-Seidel cut to one sweep, Newton to no step and pivoting off: ExactReferenceError with the reason,
    the residual reached and what each method reached."""
    from models.exact import box_lcp

    J, c, N, mass, u1, _ = _damped_body()
    L = np.full(2, 5.0)  # sticking: one sweep does not settle the coupled rows
    monkeypatch.setattr(box_lcp, "GS_MAX_SWEEPS", 1)
    monkeypatch.setattr(box_lcp, "NEWTON_MAX_ITERATIONS", 0)
    monkeypatch.setattr(box_lcp, "PIVOT_ROWS_LIMIT", 0)
    with pytest.raises(ExactReferenceError, match=r"test body: .*stopped at a natural residual of .* m/s, above the "
                                                  r"1e-09 accepted \(a component of 2 rows: Gauss-Seidel .* after 1 "
                                                  r"sweeps, Newton .*, a component of 2 rows, above the 0 pivoted"):
        damped_friction_phase(J, c, N, mass, u1, L, {}, "test body")


def _singular_contact_problem() -> BoxProblem:
    """A contact phase's LCP (x >= 0, b = -g): symmetric positive semidefinite and singular, two coincident rows, as
    four coplanar points give."""
    G = np.array([[1.0, 0.2, 0.0], [1.0, 0.2, 0.0], [0.0, 1.0, 0.5], [0.3, 0.0, 1.0]])
    H = G @ G.T
    g = np.array([-1.0, -1.0, 0.4, -0.2])
    return BoxProblem(sp.csr_matrix(H), -g, np.diag(H).copy(), np.zeros(4), np.full(4, np.inf))


def test_contact_lcp_of_a_singular_matrix_is_solved_by_regularised_pivoting() -> None:
    """The contact phase's LCP of `_singular_contact_problem`: Gauss-Seidel, Newton and regularised pivoting reach a
    solution whose velocities-side residual is at rounding."""
    prob = _singular_contact_problem()
    H, g = prob.A.toarray(), -prob.b
    n = g.shape[0]
    assert np.linalg.matrix_rank(H) < n
    x, res, _ = solve_box(prob, np.zeros(n), accept=1e-12, target=1e-14)
    assert res <= 1e-12 and np.all(x >= 0)
    e = H @ x + g
    assert np.all(e >= -1e-12) and abs(x @ e) <= 1e-12
    piv = box_lemke(H + 1e-12 * np.eye(n), -g, np.zeros(n), np.full(n, np.inf), None, 100)
    assert piv.solved and prob.worst(piv.x) <= 1e-9


@pytest.mark.parametrize("method", [4, 5])
def test_the_last_resorts_certify_a_singular_component_when_every_method_before_them_stops_short(
        method: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The proximal point (method 4) and MPRGP (5, symmetric components) are reached only where Gauss-Seidel, Newton
    and pivoting stop short, which on real worlds depends on the machine's rounding (a near-singular component that
    one machine's Newton certifies, another's does not). Here those methods are made to stop short: Gauss-Seidel
    leaves the start, the component's first Newton and every pivoting fail (the Newton steps inside the last resorts
    run), and for MPRGP the proximal point fails too. The component is then certified by the method under test."""
    prob = _singular_contact_problem()
    real_newton, calls = box_lcp.newton, []

    def newton_failing_first(p: BoxProblem, x: np.ndarray, target: float = box_lcp.TARGET):
        calls.append(1)
        return (x, np.inf, 0) if len(calls) == 1 else real_newton(p, x, target)

    monkeypatch.setattr(box_lcp, "gauss_seidel", lambda p, x, deadline=np.inf, target=0.0: (x.copy(), 0))
    monkeypatch.setattr(box_lcp, "newton", newton_failing_first)
    monkeypatch.setattr(box_lcp, "box_lemke", lambda A, b, lo, hi, guess, max_pivots, deadline=np.inf:
                        PivotResult(np.zeros_like(b), 0, False, "made to fail"))
    if method == 5:
        monkeypatch.setattr(box_lcp, "proximal_point", lambda p, x, rho, target=0.0, deadline=np.inf: (x, np.inf, 0))
    x, res, out = solve_box(prob, np.zeros(4), accept=1e-12, target=1e-14)
    assert out.methods == [method] and not out.failures
    assert res <= 1e-12 and prob.worst(x) <= 1e-12 and np.all(x >= 0)


def test_the_last_resorts_alone_reach_the_singular_components_solution() -> None:
    """Called directly from zero impulses: the proximal point at each of its regularisations and MPRGP."""
    prob = _singular_contact_problem()
    for rho in box_lcp.PROXIMAL_REGULARIZATIONS:
        _, res, _ = box_lcp.proximal_point(prob, np.zeros(4), rho, 1e-14)
        assert res <= 1e-12, rho
    _, res, _ = box_lcp.mprgp_point(prob, np.zeros(4), 1e-14)
    assert res <= 1e-12
