"""Closed loop (pybullet collision detection, our solver and integrator): resting scenes stay at rest."""

from __future__ import annotations

import numpy as np

from models.closed_loop import run_closed_loop

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
