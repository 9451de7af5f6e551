"""A world file as a user brings one (``make sim SCENE=docs/jenga_heap_world.py``; the format:
``models/scenes/user_world.py``): z-up with its own gravity, pybullet's ``plane.urdf`` as the ground, a jenga tower
of ``levels`` levels of three ``jenga/jenga.urdf`` blocks side by side (each level turned a quarter about the
vertical), and beside it a heap of ``heap`` pybullet_data objects (ducks, lego bricks, small cubes and spheres,
teddies, random_urdfs) dropped in jittered, turned layers. Its blocks touch side by side within a level: horizontal
normals on turned, non-isotropic boxes, damped directions that are no eigenvectors of the blocks' inverse inertia."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

CAPTURE_STEP = 40
LENGTH, WIDTH, HEIGHT = 0.15, 0.05, 0.03  # jenga.urdf's collision box (z-up)
HEAP = (("duck_vhacd.urdf", 1.0), ("lego/lego.urdf", 1.5), ("cube_small.urdf", 1.0), ("sphere_small.urdf", 1.0),
        ("teddy_vhacd.urdf", 1.0), ("random_urdfs/{:03d}/{:03d}.urdf", 1.0))


def build(pb: Any, data_path: str, levels: int = 16, heap: int = 48, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    pb.setGravity(0.0, 0.0, -9.81)
    pb.loadURDF("plane.urdf", [0.0, 0.0, 0.0])
    for level in range(levels):
        turn = pb.getQuaternionFromEuler([0.0, 0.0, math.pi / 2 * (level % 2)])
        z = HEIGHT / 2 + 0.0005 + level * (HEIGHT + 0.0005)
        for k in (-1, 0, 1):
            across = k * (WIDTH + 0.001)
            pos = [0.0, across, z] if level % 2 == 0 else [across, 0.0, z]
            uid = pb.loadURDF("jenga/jenga.urdf", pos, turn)
            pb.changeDynamics(uid, -1, restitution=0.0, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING)
    side = 4
    for n in range(heap):
        name, scale = HEAP[n % len(HEAP)]
        if "{" in name:
            k = int(rng.integers(0, 1000))
            name = name.format(k, k)
        layer, cell = divmod(n, side * side)
        i, j = divmod(cell, side)
        pos = [0.3 + 0.1 * i + float(rng.uniform(-0.01, 0.01)), -0.15 + 0.1 * j + float(rng.uniform(-0.01, 0.01)),
               0.08 + 0.12 * layer]
        q = rng.normal(size=4)
        uid = pb.loadURDF(name, pos, [float(x) for x in q / np.linalg.norm(q)], globalScaling=scale)
        pb.changeDynamics(uid, -1, restitution=0.0, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING)
