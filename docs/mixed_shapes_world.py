"""A world file (``make sim SCENE=docs/mixed_shapes_world.py``; the format: ``models/scenes/user_world.py``):
spheres, capsules, cylinders, turned non-cube boxes and pybullet_data's ``duck_vhacd.urdf`` (a compound of convex
hulls) and ``lego/lego.urdf`` (a turned box child), each of its own mass (0.1 to 5 kg) and friction (0.3 to 1.1),
in ``layers`` jittered, turned layers of ``nx`` x ``nz`` (``layout``: the random draw) dropped onto a static slab
of friction 0.9, so that they land on the slab and on each other. In Bullet 2's convention: every dynamic body a
full symmetric 3x3 inverse inertia, every manifold its pair's friction (the kernel's 6-word body record and
friction word). The Bullet 2 parity test and the kernel's per-manifold friction test run it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from models.scenes.specs import int_param
from models.scenes.world_parts import prepare_dynamic

BULLET_CONVENTION = "bullet2"
CAPTURE_STEP = 30
SHAPES = ("sphere", "capsule", "cylinder", "box", "duck", "lego")


def _shape(pb: Any, kind: str, rng: np.random.Generator) -> int:
    if kind == "sphere":
        return pb.createCollisionShape(pb.GEOM_SPHERE, radius=float(rng.uniform(0.06, 0.12)))
    if kind == "capsule":
        return pb.createCollisionShape(pb.GEOM_CAPSULE, radius=float(rng.uniform(0.04, 0.08)),
                                       height=float(rng.uniform(0.1, 0.25)))
    if kind == "cylinder":
        return pb.createCollisionShape(pb.GEOM_CYLINDER, radius=float(rng.uniform(0.06, 0.12)),
                                       height=float(rng.uniform(0.05, 0.15)))
    return pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[float(h) for h in rng.uniform(0.03, 0.12, 3)])


def body_kinds(nx: int = 3, nz: int = 3, layers: int = 2) -> list[str]:
    """The shape of each body in creation order (frame order): the slab, then layer by layer, x, then z."""
    return ["slab"] + [SHAPES[(i + 2 * k + 3 * j) % len(SHAPES)]
                       for j in range(layers) for i in range(nx) for k in range(nz)]


def build(pb: Any, data_path: str, nx: int = 3, nz: int = 3, layers: int = 2, layout: int = 0) -> None:
    nx, nz, layers = (int_param(k, v, 1, 10) for k, v in (("nx", nx), ("nz", nz), ("layers", layers)))
    rng = np.random.default_rng(int_param("layout", layout, 0, 2**31 - 1))
    slab = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[3.0, 0.25, 3.0])
    ground = pb.createMultiBody(0.0, slab, basePosition=[0.0, -0.25, 0.0])
    pb.changeDynamics(ground, -1, lateralFriction=0.9, restitution=0.0)
    pitch = 0.3
    kinds = iter(body_kinds(nx, nz, layers)[1:])
    for j in range(layers):
        for i in range(nx):
            for k in range(nz):
                kind = next(kinds)
                pos = [(i - (nx - 1) / 2) * pitch + 0.08 * j + float(rng.uniform(-0.02, 0.02)), 0.15 + 0.25 * j,
                       (k - (nz - 1) / 2) * pitch - 0.06 * j + float(rng.uniform(-0.02, 0.02))]
                q = rng.normal(size=4)
                q = [float(x) for x in q / np.linalg.norm(q)]
                mass = float(10 ** rng.uniform(-1.0, math.log10(5.0)))
                if kind == "duck":
                    uid = pb.loadURDF("duck_vhacd.urdf", pos, q, globalScaling=2.0)
                elif kind == "lego":
                    uid = pb.loadURDF("lego/lego.urdf", pos, q, globalScaling=3.0)
                else:
                    uid = pb.createMultiBody(mass, _shape(pb, kind, rng), basePosition=pos, baseOrientation=q)
                pb.changeDynamics(uid, -1, mass=mass, lateralFriction=float(rng.uniform(0.3, 1.1)))
                prepare_dynamic(pb, uid)
