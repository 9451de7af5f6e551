"""World-frame inverse inertia (models/setup/inertia.py), its modes, and the golden solver in the full mode."""

from __future__ import annotations

import numpy as np
import pytest

from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.golden.contact_solver import (SolverParams, _Gathered, contact_solve, cross3, dot3, friction_solve, solve,
                                          solve_sequential)
from models.formats.frame import Frame
from models.formats.frame import BulletConvention, convention_of
from models.setup.inertia import (InertiaMode, convention_inverse_inertia, inertia_product, quat_to_matrix,
                                  world_inverse_inertia)
from models.formats.number_format import FLOAT64, FP32

SYM = ((0, 3, 4), (3, 1, 5), (4, 5, 2))  # FULL_ORDER word of each matrix entry


def _matrix(words: np.ndarray) -> np.ndarray:
    return np.stack([np.stack([words[:, SYM[i][j]] for j in range(3)], -1) for i in range(3)], -2)


def _random_quats(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_world_inverse_inertia_is_r_diag_rt() -> None:
    rng = np.random.default_rng(1)
    q = _random_quats(rng, 50)
    d = rng.uniform(0.1, 3.0, (50, 3))
    m = _matrix(world_inverse_inertia(q, d))
    r = quat_to_matrix(q)
    np.testing.assert_allclose(m, np.einsum("nij,nj,nkj->nik", r, d, r), rtol=1e-13, atol=1e-15)
    # the inverse of the world inertia R diag(I) R^T
    inertia = np.einsum("nij,nj,nkj->nik", r, 1.0 / d, r)
    np.testing.assert_allclose(np.einsum("nij,njk->nik", m, inertia), np.broadcast_to(np.eye(3), m.shape), atol=1e-12)


def test_modes_cubes_scalar_axis_aligned_diagonal_rotated_full() -> None:
    rng = np.random.default_rng(2)
    q = _random_quats(rng, 4)
    ident = np.tile([0.0, 0.0, 0.0, 1.0], (4, 1))
    dyn = np.array([False, True, True, True])
    cube = np.tile([0.4, 0.4, 0.4], (4, 1))
    box = np.tile([0.4, 1.0, 2.5], (4, 1))
    # a rotated cube keeps exact zeros off the diagonal: scalar
    assert _table(world_inverse_inertia(q, cube), dyn).inertia_mode is InertiaMode.SCALAR
    assert _table(world_inverse_inertia(ident, box), dyn).inertia_mode is InertiaMode.DIAGONAL
    assert _table(world_inverse_inertia(q, box), dyn).inertia_mode is InertiaMode.FULL
    assert [m.words for m in InertiaMode] == [1, 3, 6]
    # a static body's values do not count
    mixed = world_inverse_inertia(np.concatenate([q[:1], ident[1:]]), box)
    assert _table(mixed, dyn).inertia_mode is InertiaMode.DIAGONAL


def _table(inv_inertia: np.ndarray, dynamic: np.ndarray) -> BodyTable:
    n = dynamic.shape[0]
    return BodyTable(position=np.zeros((n, 3)), orientation=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                     linear_velocity=np.zeros((n, 3)), angular_velocity=np.zeros((n, 3)),
                     inv_mass=dynamic.astype(float), inv_inertia=inv_inertia)


def test_inertia_product_full_matches_the_matrix_and_diagonal_path_is_unchanged() -> None:
    rng = np.random.default_rng(3)
    words = world_inverse_inertia(_random_quats(rng, 30), rng.uniform(0.1, 2.0, (30, 3)))
    c = rng.normal(size=(30, 3))
    np.testing.assert_allclose(inertia_product(FLOAT64, words, c), np.einsum("nij,nj->ni", _matrix(words), c),
                               rtol=1e-13, atol=1e-15)
    diag = rng.uniform(0.1, 2.0, (30, 3))
    assert np.array_equal(inertia_product(FP32, FP32.round(diag), FP32.round(c)),
                          FP32.mul(FP32.round(diag), FP32.round(c)))
    # a diagonal written in the full layout (zeros off the diagonal) gives the diagonal path's values
    padded = np.concatenate([FP32.round(diag), np.zeros((30, 3))], axis=1)
    assert np.array_equal(inertia_product(FP32, padded, FP32.round(c)), FP32.mul(FP32.round(diag), FP32.round(c)))


def _one_point_frame(q: np.ndarray, half_extents: np.ndarray, convention: BulletConvention) -> Frame:
    """A box (body 1) touching the static ground (body 0) at one off-centre point, falling and spinning."""
    m = 1
    point = np.zeros((m, 4, 3))
    point[0, 0] = (0.3, -0.2, 0.25)
    normal = np.zeros((m, 4, 3))
    normal[0, :] = (0.0, -1.0, 0.0)  # from B (the box) to A (the ground)
    distance = np.zeros((m, 4))
    distance[0, 0] = -0.01
    z4 = np.zeros((m, 4))
    z43 = np.zeros((m, 4, 3))
    return Frame(
        position=np.array([[0.0, -1.0, 0.0], [0.0, 0.4, 0.0]]), orientation=np.stack([[0.0, 0.0, 0.0, 1.0], q]),
        linear_velocity=np.array([[0.0, 0.0, 0.0], [0.2, -1.0, 0.1]]),
        angular_velocity=np.array([[0.0, 0.0, 0.0], [0.5, -0.3, 0.8]]), inv_mass=np.array([0.0, 0.5]),
        inertia_local=np.array([[0.0, 0.0, 0.0], [0.3, 0.9, 1.4]]), half_extents=np.stack([[5.0, 1.0, 5.0],
                                                                                           half_extents]),
        shape_index=np.array([0, 1], np.int32), friction=np.array([0.9, 0.6]),
        body_a=np.array([0], np.int32), body_b=np.array([1], np.int32), num_points=np.array([1], np.int32),
        point_on_a=point, point_on_b=point, normal_on_b=normal, distance=distance,
        normal_force=z4, lateral_friction1=z4, lateral_dir1=z43, lateral_friction2=z4, lateral_dir2=z43,
        post_linear_velocity=np.zeros((2, 3)), post_angular_velocity=np.zeros((2, 3)),
        meta={"bullet_convention": convention.value})


@pytest.mark.parametrize("convention", [BulletConvention.BULLET2, BulletConvention.BULLET_GPU])
def test_full_mode_contact_row_reaches_its_target(convention: BulletConvention) -> None:
    """One unclamped contact row: afterwards vrel = -b exactly when the setup's K and the solve's angular update
    use the same world matrix (the unrotated diagonal in either place misses by far more than round-off)."""
    q = np.array([0.2, 0.5, -0.3, 0.78])
    q /= np.linalg.norm(q)
    frame = _one_point_frame(q, np.array([0.3, 0.1, 0.5]), convention)
    bodies = body_table(frame)
    assert convention_of(frame.meta) is convention and bodies.inertia_mode is InertiaMode.FULL
    cons = setup_constraints(frame, bodies)
    g = _Gathered(bodies, cons.body_a, cons.body_b)
    lam = contact_solve(FLOAT64, g, cons, np.arange(1), np.zeros((1, 4)))
    assert lam[0, 0] > 0
    assert abs(_vrel(g, cons) + cons.bias[0, 0]) < 1e-12
    # the same frame with the diagonal of the world matrix only (rotation ignored) misses the target
    diag = bodies.copy()
    diag.inv_inertia = bodies.inv_inertia[:, :3].copy()
    g2 = _Gathered(diag, cons.body_a, cons.body_b)
    contact_solve(FLOAT64, g2, cons, np.arange(1), np.zeros((1, 4)))
    assert abs(_vrel(g2, cons) + cons.bias[0, 0]) > 1e-3


def _vrel(g: _Gathered, cons: ConstraintSet) -> float:
    """The relative normal velocity at manifold 0's point 0."""
    n, p = cons.normal, cons.points[:, 0]
    ca, cb = cross3(FLOAT64, p - g.xa, n), cross3(FLOAT64, p - g.xb, n)
    return float((dot3(FLOAT64, n, g.va) - dot3(FLOAT64, n, g.vb) + dot3(FLOAT64, ca, g.wa)
                  - dot3(FLOAT64, cb, g.wb))[0])


def test_conventions_differ_as_documented() -> None:
    q = np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, np.sin(0.2), np.cos(0.2)]])
    inv_mass = np.array([0.0, 2.0])
    local = np.array([[0.0, 0.0, 0.0], [0.5, 1.0, 2.0]])
    half = np.array([[1.0, 1.0, 1.0], [0.5, 0.25, 0.4]])
    axes = convention_inverse_inertia(BulletConvention.WORLD_AXES, q, inv_mass, local, half)
    gpu = convention_inverse_inertia(BulletConvention.BULLET_GPU, q, inv_mass, local, half)
    b2 = convention_inverse_inertia(BulletConvention.BULLET2, q, inv_mass, local, half)
    assert axes.shape == (2, 3) and gpu.shape == (2, 6) and b2.shape == (2, 6)
    assert np.all(gpu[0] == 0.0) and np.all(b2[0] == 0.0)  # static
    # bullet_gpu rotates the AABB diagonal that world_axes applies unrotated; the trace is the same
    assert gpu[1, 3] != 0.0 and np.isclose(gpu[1, :3].sum(), axes[1].sum())
    # bullet2: the true inertia, 1/I
    np.testing.assert_allclose(np.linalg.eigvalsh(_matrix(b2[1:]))[0], np.sort(1.0 / local[1]), rtol=1e-12)
    # unrotated, bullet_gpu is world_axes (so the thesis scene is the same in both)
    same = convention_inverse_inertia(BulletConvention.BULLET_GPU, q[:1].repeat(2, 0), inv_mass, local, half)
    assert same.shape == (2, 3) and np.array_equal(same, axes)
    with pytest.raises(ValueError, match="unknown Bullet convention"):
        convention_of({"bullet_convention": "bullet4"})
    with pytest.raises(ValueError, match="local inertia"):
        convention_inverse_inertia(BulletConvention.BULLET2, q, inv_mass, np.zeros((2, 3)), half)


def test_per_manifold_friction_where_it_varies_and_the_register_where_not() -> None:
    q = np.array([0.0, 0.0, 0.0, 1.0])
    frame = _one_point_frame(q, np.array([0.3, 0.1, 0.5]), BulletConvention.BULLET2)
    frame = _two_manifolds(frame)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    assert cons.friction_words == 1
    np.testing.assert_array_equal(cons.friction[:, 0], [0.6 * 0.9, 0.6 * 0.4])
    # one friction for every pair, but not the solver's one coefficient: still a word per manifold
    frame.friction[:] = 0.8
    one = setup_constraints(frame, bodies)
    assert one.friction_words == 1
    np.testing.assert_array_equal(one.friction[:, 0], [0.8 * 0.8] * 2)
    # every pair's combined friction is the solver's coefficient (0.7): no per-manifold words
    frame.friction[:] = (1.0, 0.7, 1.0)
    uniform = setup_constraints(frame, bodies)
    assert uniform.friction_words == 0 and uniform.friction.shape == (2, 0)
    # the bullet_gpu convention ignores the bodies' friction (Bullet GPU's 0.7)
    frame.friction[:] = (0.9, 0.6, 0.4)
    frame.meta["bullet_convention"] = "bullet_gpu"
    assert setup_constraints(frame, body_table(frame)).friction_words == 0
    # a per-manifold coefficient equal to the register gives the register path's values bit for bit
    bodies_r = bodies.rounded(FP32)
    lam_n = np.array([[2.0, 0, 0, 0], [3.0, 0, 0, 0]])
    reg = uniform.rounded(FP32)
    per = ConstraintSet(**{**reg.__dict__, "friction": FP32.round(np.full((2, 1), 0.7))})
    out = []
    for c in (reg, per):
        g = _Gathered(bodies_r, c.body_a, c.body_b)
        out.append(friction_solve(FP32, g, c, np.arange(2), lam_n, np.zeros((2, 2)), 0.7))
    assert np.array_equal(out[0], out[1])
    # and a different coefficient changes the clamp
    cons_r = cons.rounded(FP32)
    g = _Gathered(bodies_r, cons_r.body_a, cons_r.body_b)
    lam_t = friction_solve(FP32, g, cons_r, np.arange(2), lam_n * 1e-3, np.zeros((2, 2)), 0.7)
    limits = cons_r.friction[:, 0] * lam_n[:, 0] * 1e-3
    assert np.all(np.abs(lam_t) <= limits[:, None] * (1 + 1e-6)) and np.any(np.isclose(np.abs(lam_t), limits[:, None]))


def _two_manifolds(frame: Frame) -> Frame:
    """The one-point frame plus a third body (friction 0.4) touching body 1 from above."""
    f = {k: getattr(frame, k) for k in frame.__dataclass_fields__}
    f["position"] = np.concatenate([frame.position, [[0.0, 1.2, 0.0]]])
    f["orientation"] = np.concatenate([frame.orientation, [[0.0, 0.0, 0.0, 1.0]]])
    for k in ("linear_velocity", "angular_velocity", "post_linear_velocity", "post_angular_velocity"):
        f[k] = np.concatenate([f[k], np.zeros((1, 3))])
    f["linear_velocity"][2] = (-0.3, -1.0, 0.0)
    f["inv_mass"] = np.concatenate([frame.inv_mass, [1.0]])
    f["inertia_local"] = np.concatenate([frame.inertia_local, [[0.2, 0.2, 0.2]]])
    f["half_extents"] = np.concatenate([frame.half_extents, [[0.3, 0.3, 0.3]]])
    f["shape_index"] = np.array([0, 1, 2], np.int32)
    f["friction"] = np.array([0.9, 0.6, 0.4])
    for k in ("body_a", "body_b", "num_points"):
        f[k] = np.concatenate([f[k], f[k]])
    f["body_a"][1], f["body_b"][1] = 1, 2  # the top body (B) rests on the box (A): normal -y, B to A
    for k in ("point_on_a", "point_on_b", "normal_on_b", "distance", "normal_force", "lateral_friction1",
              "lateral_dir1", "lateral_friction2", "lateral_dir2"):
        f[k] = np.concatenate([f[k], f[k]])
    f["point_on_a"][1, 0] = f["point_on_b"][1, 0] = (0.1, 0.9, -0.1)
    f["meta"] = dict(frame.meta)
    return Frame(**f)


def test_full_mode_level_solve_is_the_sequential_solve() -> None:
    """The level-vectorized solve stays bit-identical to the one-at-a-time loop in the full mode."""
    q = np.array([0.2, 0.5, -0.3, 0.78])
    frame = _two_manifolds(_one_point_frame(q / np.linalg.norm(q), np.array([0.3, 0.1, 0.5]),
                                            BulletConvention.BULLET2))
    bodies = body_table(frame).rounded(FP32)
    cons = setup_constraints(frame, body_table(frame)).rounded(FP32)
    assert bodies.inertia_mode is InertiaMode.FULL and cons.friction_words == 1
    sched = np.array([1, 0])
    a = solve(bodies, cons, sched, FP32, SolverParams())
    b = solve_sequential(bodies, cons, sched, FP32, SolverParams())
    assert np.array_equal(a.bodies.angular_velocity, b.bodies.angular_velocity)
    assert np.array_equal(a.impulses.friction, b.impulses.friction)
    assert np.any(a.impulses.friction != 0)
