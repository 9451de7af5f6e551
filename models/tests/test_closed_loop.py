"""Closed loop (pybullet collision detection, our solver and integrator): resting scenes stay at rest."""

from __future__ import annotations

import numpy as np

from models.closed_loop.loop import run_closed_loop

G_DT = 9.8 / 60.0


def test_short_stack_rests() -> None:
    """A 3-cube stack at Bullet GPU's 4 iterations: after settling to the 5 mm resting penetration it stays put."""
    r = run_closed_loop("stack", 300, n=3, iterations=4, warmup_steps=60)
    s = r.summary()
    print("stack n=3:", s)
    assert s["NaN/Inf values"] == 0
    assert s["max drift (m)"] < 0.01
    assert s["max penetration (m)"] < 0.01
    # at rest the GPU convention stores v = -g*dt (gravity is added after the position update)
    assert abs(s["final median speed (m/s)"] - G_DT) < 0.005


def test_thesis_geometry_interior_rests() -> None:
    """GpuBoxPlaneScene at 6x6x6: the interior stays at rest, edge cubes topple (their centre of mass overhangs)."""
    nx = ny = nz = 6
    r = run_closed_loop("thesis", 100, nx=nx, ny=ny, nz=nz, iterations=4)
    s = r.summary()
    speed = np.linalg.norm(r.final.linear_velocity[r.final.dynamic], axis=1)
    print("thesis 6x6x6:", s, "median speed at step 100:", float(np.median(speed)))
    assert s["NaN/Inf values"] == 0
    assert abs(float(np.median(speed)) - G_DT) < 0.01
    # interior cubes: not on the outer faces of the grid (the frame's dynamic bodies are in i, j, k order)
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    interior = ((i > 0) & (i < nx - 1) & (k > 0) & (k < nz - 1) & (j < ny - 1)).ravel()
    assert np.all(np.abs(speed[interior] - G_DT) < 0.02)
    # the fastest body is a cube of the top layer
    top = (j == ny - 1).ravel()
    assert top[int(np.argmax(speed))]


def _recording_stepper(seen: list[tuple[np.ndarray, np.ndarray]]):  # noqa: ANN202 (a StepperFactory)
    from models.closed_loop.loop import golden_stepper

    def factory(ar, solver, ip):  # noqa: ANN001, ANN202
        step = golden_stepper(ar, solver, ip)

        def advance(bodies, cons, order, initial=None):  # noqa: ANN001, ANN202
            seen.append((bodies.orientation.copy(), bodies.inv_inertia.copy()))
            return step(bodies, cons, order, initial)
        return advance
    return factory


def test_bullet2_convention_recomputes_the_inertia_every_step_and_bullet_gpu_freezes_it() -> None:
    """A thin box spinning on a slope: in the bullet2 convention each step's inverse inertia is R diag R^T of that
    step's orientation (the full 3x3); in the bullet_gpu convention it stays the one of the first state."""
    from models.formats.frame import BulletConvention
    from models.setup.inertia import convention_inverse_inertia
    from models.formats.number_format import FP32
    from models.scenes import build_world

    kw = dict(angle_deg=10.0, box_half_extents=(0.8, 0.1, 0.3))
    with build_world("incline", **kw) as w:
        st = w.body_state()
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    r = run_closed_loop("incline", 6, FP32, 4, stepper=_recording_stepper(seen), convention=BulletConvention.BULLET2,
                        **kw)
    assert r.summary()["NaN/Inf values"] == 0 and len(seen) == 6
    for q, inv in seen:
        assert inv.shape == (3, 6)
        want = FP32.round(convention_inverse_inertia(BulletConvention.BULLET2, q, st["inv_mass"], st["inertia_local"],
                                                     st["half_extents"]))
        assert np.array_equal(inv, want)
    assert any(not np.array_equal(seen[0][0], q) for q, _ in seen[1:])  # the box turned, the inertia followed
    frozen: list[tuple[np.ndarray, np.ndarray]] = []
    run_closed_loop("incline", 3, FP32, 4, stepper=_recording_stepper(frozen), convention=BulletConvention.BULLET_GPU,
                    **kw)
    assert frozen[0][1].shape == (3, 6) and all(np.array_equal(frozen[0][1], inv) for _, inv in frozen)
