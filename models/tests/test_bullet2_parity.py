"""Our float64 btSequentialImpulseConstraintSolver against pybullet's own step (same frame, same rows)."""

from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import numpy as np
import pytest

import pybullet as p

from models import scenes
from models.golden.bullet2_solver import (SolverSettings, compare_with_pybullet, plane_space, quat_to_matrix,
                                          solve_frame, solver_order)
from models.setup.constraints import body_table, setup_constraints
from models.formats.frame import Frame
from models.setup.inertia import InertiaMode
from models.scenes.specs import BoxSpec, SceneSpec
from models.scenes.world import SpecSource

VEL_TOL = 1e-9  # m/s, rad/s
FORCE_TOL = 1e-6  # N (pybullet reports impulse / fixedTimeStep)

CASES: dict[str, dict] = {
    "pile_8x8x8": dict(scene="pile", nx=8, ny=8, nz=8, step=30),
    "stack": dict(scene="stack"),
    "incline": dict(scene="incline"),
    "incline_sliding": dict(scene="incline", angle_deg=40.0),
    "mass_ratio": dict(scene="mass_ratio"),
    "mass_ratio_deep": dict(scene="mass_ratio", ratio=1e4, layers=3),
    "pyramid": dict(scene="pyramid"),
    "impact": dict(scene="impact"),
    "thesis_6x6x6": dict(scene="thesis", nx=6, ny=6, nz=6),
    "pile_4_iterations": dict(scene="pile", nx=4, ny=4, nz=4, step=40, pybullet_iterations=4),
}


@pytest.fixture(scope="module")
def frames(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Frame]:
    cache = tmp_path_factory.mktemp("parity_frames")
    out = {}
    for name, kw in CASES.items():
        kw = dict(kw)
        out[name] = scenes.load_or_capture(kw.pop("scene"), cache_dir=cache, **kw)
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_parity_with_pybullet(frames: dict[str, Frame], name: str) -> None:
    f = frames[name]
    assert f.num_manifolds > 0
    result = solve_frame(f)
    err = compare_with_pybullet(f, result)
    print(f"\n{name}: {f.summary()}; max errors: " + ", ".join(f"{k} {v:.2e}" for k, v in err.items()))
    assert err["linear_velocity"] <= VEL_TOL and err["angular_velocity"] <= VEL_TOL, err
    assert err["normal_force"] <= FORCE_TOL, err
    assert err["lateral_friction1"] <= FORCE_TOL and err["lateral_friction2"] <= FORCE_TOL, err
    assert err["lateral_dir1"] <= 1e-12 and err["lateral_dir2"] <= 1e-12, err
    # the solve did something: bodies in contact do not simply free-fall
    dyn = f.inv_mass > 0
    free = f.linear_velocity + f.gravity * f.dt
    assert np.abs(result.linear_velocity[dyn] - free[dyn]).max() > 1e-3


def test_pile_is_big_and_in_contact(frames: dict[str, Frame]) -> None:
    f = frames["pile_8x8x8"]
    assert f.num_bodies >= 501 and f.num_manifolds > f.num_bodies
    touched = np.zeros(f.num_bodies, bool)
    touched[f.body_a] = touched[f.body_b] = True
    assert touched[1:].all()


def test_cases_cover_the_split_impulse_and_both_friction_branches(frames: dict[str, Frame]) -> None:
    f = frames["impact"]
    valid = np.arange(4)[None, :] < f.num_points[:, None]
    assert (f.distance[valid] + 1e-5 <= -0.04).any(), "impact must exercise the split-impulse rows"
    r = solve_frame(f)
    assert np.abs(r.push_velocity).max() > 0
    # a split row's positional error goes to push/turn velocities only: switching split impulse off changes v
    s = SolverSettings.from_frame(f)
    s.split_impulse = False
    r_off = solve_frame(f, s)
    assert np.abs(r_off.linear_velocity - r.linear_velocity).max() > 1e-3
    assert np.abs(r_off.push_velocity).max() == 0


def test_settings_from_metadata(frames: dict[str, Frame]) -> None:
    s = SolverSettings.from_frame(frames["pile_4_iterations"])
    assert s.iterations == 4 and s.erp2 == 0.08 and s.slop == 1e-5 and s.split_threshold == -0.04
    assert SolverSettings.from_frame(frames["stack"]).iterations == 10
    wrong = SolverSettings.from_frame(frames["pile_4_iterations"])
    wrong.iterations = 10
    err = compare_with_pybullet(frames["pile_4_iterations"], solve_frame(frames["pile_4_iterations"], wrong))
    assert err["linear_velocity"] > 1e-6  # the iteration count matters, so the check above is meaningful


def test_helpers() -> None:
    rng = np.random.default_rng(0)
    q = rng.normal(size=(20, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    r = quat_to_matrix(q)
    assert np.allclose(np.einsum("nij,nkj->nik", r, r), np.eye(3)[None], atol=1e-14)
    assert np.allclose(np.linalg.det(r), 1.0)
    n = rng.normal(size=(20, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[0] = (0, 1, 0)
    n[1] = (0, 0, -1)
    a, b = plane_space(n)
    for u, v in ((a, b), (a, n), (b, n)):
        assert np.abs(np.einsum("ij,ij->i", u, v)).max() < 1e-14
    assert np.allclose(np.linalg.norm(a, axis=1), 1) and np.allclose(np.linalg.norm(b, axis=1), 1)


def test_parity_spinning_anisotropic_box_needs_the_gyroscopic_term() -> None:
    """A thin box spinning on a slope: the implicit gyroscopic impulse must be modelled (0.4 rad/s without)."""
    with scenes.build_world("incline", angle_deg=10.0, box_half_extents=(0.8, 0.1, 0.3)) as w:
        st = w.body_state()
        ang = st["angular_velocity"].copy()
        ang[2] = (3.0, 7.0, -2.0)
        w.set_body_state(st["position"], st["orientation"], st["linear_velocity"], ang)
        frames = [w.capture_step() for _ in range(3)]
    assert sum(f.num_manifolds for f in frames) > 0
    for f in frames:
        err = compare_with_pybullet(f)
        print(f"\nspinning box step {f.meta['step']}: {f.summary()}; max errors: "
              + ", ".join(f"{k} {v:.2e}" for k, v in err.items()))
        assert max(err["linear_velocity"], err["angular_velocity"]) <= VEL_TOL, err
        assert max(err["normal_force"], err["lateral_friction1"], err["lateral_friction2"]) <= FORCE_TOL, err
    s = SolverSettings.from_frame(frames[0])
    s.gyroscopic = False
    assert compare_with_pybullet(frames[0], solve_frame(frames[0], s))["angular_velocity"] > 1e-3


def _mixed_boxes_spec(seed: int) -> SceneSpec:
    """Two layers of 3x3 boxes of random extents, masses (0.2..20 kg) and orientations, dropped on a ground box."""
    rng = np.random.default_rng(seed)
    bodies = [BoxSpec((20.0, 0.5, 20.0), 0.0, (0.0, -0.5, 0.0))]
    for layer in range(2):
        for i in range(3):
            for k in range(3):
                q = rng.normal(size=4)
                q /= np.linalg.norm(q)
                half = tuple(float(h) for h in rng.uniform(0.12, 0.45, 3))
                pos = (0.7 * (i - 1) + 0.2 * layer, 0.5 + 0.75 * layer, 0.7 * (k - 1) - 0.15 * layer)
                bodies.append(BoxSpec(half, float(10 ** rng.uniform(np.log10(0.2), np.log10(20.0))), pos,
                                      tuple(float(x) for x in q)))
    return SceneSpec(bodies, 1.0, {"seed": seed})


@pytest.fixture(scope="module")
def mixed_frames() -> list[Frame]:
    """Rotated non-cube boxes of mixed masses and per-body friction (0.2..1.2), built with createMultiBody:
    frames of the steps in which they land on the ground and on each other."""
    world = scenes.SceneWorld(SpecSource(_mixed_boxes_spec(5)), "mixed_boxes", 5, 1.0 / 60.0, 10)
    with world:
        rng = np.random.default_rng(6)
        for i, bid in enumerate(world.body_ids.tolist()):
            p.changeDynamics(bid, -1, lateralFriction=float(rng.uniform(0.2, 1.2)), physicsClientId=world.client)
            world.friction[i] = p.getDynamicsInfo(bid, -1, physicsClientId=world.client)[1]
        out = []
        for step in range(1, 61):
            if step % 6:
                world.step()
            else:
                out.append(world.capture_step(extra_meta={"bullet_convention": "bullet2"}))
    return out


def test_parity_rotated_boxes_mixed_masses_and_friction(mixed_frames: list[Frame]) -> None:
    busy = [f for f in mixed_frames if f.num_manifolds >= 5]
    assert len(busy) >= 3
    worst: dict[str, float] = {}
    for f in busy:
        err = compare_with_pybullet(f)
        worst = {k: max(worst.get(k, 0.0), v) for k, v in err.items()}
        assert err["linear_velocity"] <= VEL_TOL and err["angular_velocity"] <= VEL_TOL, err
        assert err["normal_force"] <= FORCE_TOL, err
        assert err["lateral_friction1"] <= FORCE_TOL and err["lateral_friction2"] <= FORCE_TOL, err
    print("\nmixed boxes, %d frames (up to %d manifolds); max errors: " % (len(busy), max(f.num_manifolds for f in busy))
          + ", ".join(f"{k} {v:.2e}" for k, v in worst.items()))
    f = max(busy, key=lambda fr: fr.num_manifolds)
    # the frame exercises what it claims: box-box contacts, rotated anisotropic bodies, mixed masses and friction
    dyn = f.inv_mass > 0
    assert np.any(dyn[f.body_a] & dyn[f.body_b])
    assert np.ptp(f.inv_mass[dyn]) > 1.0 and np.unique(f.friction).size == f.num_bodies
    assert np.all(np.ptp(f.inertia_local[dyn], axis=1) > 0)
    # and the golden model takes it in the full mode with a friction coefficient per manifold
    bodies = body_table(f)
    assert bodies.inertia_mode is InertiaMode.FULL
    assert setup_constraints(f, bodies).friction_words == 1
    # the inertia and the friction matter: dropping the rotation or the per-pair friction breaks the parity
    unrotated = dataclasses.replace(f, orientation=np.tile([0.0, 0.0, 0.0, 1.0], (f.num_bodies, 1)))
    bad = solve_frame(unrotated)
    assert max(np.abs(bad.angular_velocity - f.post_angular_velocity)[dyn].max(), 0.0) > 1e-3
    uniform = dataclasses.replace(f, friction=np.full(f.num_bodies, float(np.sqrt(np.mean(f.friction ** 2)))))
    assert compare_with_pybullet(uniform)["lateral_friction1"] > 1e-3


MIXED_SHAPES_WORLD = Path(__file__).resolve().parents[2] / "docs" / "mixed_shapes_world.py"


@pytest.fixture(scope="module")
def shape_frames() -> tuple[list[Frame], list[str]]:
    """Frames of the steps 4, 8, ..., 60 of spheres, capsules, cylinders, turned boxes, duck_vhacd compounds and
    lego bricks of mixed masses and friction landing on a slab and on each other, and each body's shape."""
    spec = importlib.util.spec_from_file_location("mixed_shapes_world", MIXED_SHAPES_WORLD)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = []
    with scenes.build_world(str(MIXED_SHAPES_WORLD)) as world:
        kinds = module.body_kinds()
        assert len(kinds) == world.num_bodies
        for step in range(1, 61):
            if step % 4:
                world.step()
            else:
                out.append(world.capture_step(extra_meta=world.source.frame_meta))
    return out, kinds


def test_parity_spheres_capsules_cylinders_meshes_mixed_masses_and_friction(
        shape_frames: tuple[list[Frame], list[str]]) -> None:
    frames, kinds = shape_frames
    busy = [f for f in frames if f.num_manifolds >= 5]
    assert len(busy) >= 10
    worst: dict[str, float] = {}
    flips = 0
    for f in busy:
        pairs = set(zip(f.body_a.tolist(), f.body_b.tolist()))
        assert len(pairs) == f.num_manifolds, "a pair with several manifolds: Bullet's order among them is unknown"
        err = compare_with_pybullet(f)
        worst = {k: max(worst.get(k, 0.0), v) for k, v in err.items()}
        assert err["linear_velocity"] <= VEL_TOL and err["angular_velocity"] <= VEL_TOL, (f.meta["step"], err)
        assert max(err["normal_force"], err["lateral_friction1"], err["lateral_friction2"]) <= FORCE_TOL, err
        assert err["lateral_dir1"] <= 1e-12 and err["lateral_dir2"] <= 1e-12, err
        flips += int(solver_order(f)[0].sum())
    print(f"\nmixed shapes, {len(busy)} frames (up to {max(f.num_manifolds for f in busy)} manifolds, {flips} taken "
          "from b's side); max errors: " + ", ".join(f"{k} {v:.2e}" for k, v in worst.items()))
    f = busy[-1]
    touching = {kinds[i] for i in np.concatenate([f.body_a, f.body_b]).tolist()}
    assert touching == {"slab", "sphere", "capsule", "cylinder", "box", "duck", "lego"}, touching
    dyn = f.inv_mass > 0
    assert np.any(dyn[f.body_a] & dyn[f.body_b])
    assert np.ptp(np.log10(f.inv_mass[dyn])) > 1.0 and np.unique(f.friction).size == f.num_bodies
    bodies = body_table(f)
    assert bodies.inertia_mode is InertiaMode.FULL
    assert setup_constraints(f, bodies).friction_words == 1


def test_the_solver_order_matters(shape_frames: tuple[list[Frame], list[str]]) -> None:
    """The compounds' manifolds taken from a's side or in frame order instead of Bullet's break the parity."""
    frames, _ = shape_frames
    f = max(frames, key=lambda fr: int(solver_order(fr)[0].sum()) * fr.num_manifolds)
    flipped, order = solver_order(f)
    assert flipped.any() and np.any(order != np.arange(f.num_manifolds))
    valid = np.arange(4)[None, :] < f.num_points[:, None]
    r = solve_frame(f)
    reported = np.einsum("mpk,mpk->mp", r.lateral_dir1, f.lateral_dir1)[valid]
    assert np.allclose(reported, 1.0)  # every direction as pybullet reports it
    # without the reported directions every manifold is taken from a's side, in frame order
    blind = dataclasses.replace(f, lateral_dir1=np.zeros_like(f.lateral_dir1))
    assert not solver_order(blind)[0].any()
    wrong = solve_frame(blind)
    assert np.abs(wrong.angular_velocity - f.post_angular_velocity)[f.inv_mass > 0].max() > 1e-6
