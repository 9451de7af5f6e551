"""Parts the shipped world files share (``models/scenes/worlds/``): the ground, the turn of a z-up asset into the
y-up world, and quaternion products. ``pb`` is the client-bound pybullet of ``models.scenes.user_world``."""

from __future__ import annotations

import math
from typing import Any

GROUND_HALF_EXTENT = 50.0
GROUND_FRICTION = 1.0
Z_UP_TO_Y_UP = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))  # (x, y, z, w): -90 degrees about x, asset z -> world y


def ground(pb: Any, friction: float = GROUND_FRICTION) -> int:
    """A static box whose top face is the plane y = 0 (as in the built-in scenes); returns its body id."""
    h = GROUND_HALF_EXTENT
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[h, h, h])
    uid = pb.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, basePosition=[0.0, -h, 0.0])
    pb.changeDynamics(uid, -1, lateralFriction=friction, restitution=0.0)
    return uid


def about_y(angle: float) -> tuple[float, float, float, float]:
    return (0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2))


def quat_mul(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    """The rotation b then a (Hamilton product a * b), quaternions (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def prepare_dynamic(pb: Any, uid: int) -> None:
    """No sleeping (the capture reads every step) and no restitution, as in the built-in scenes."""
    pb.changeDynamics(uid, -1, restitution=0.0, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING)


def bottom_offset(pb: Any, uid: int) -> float:
    """How far below the body's centre of mass its AABB reaches (m, along y)."""
    lo, _ = pb.getAABB(uid)
    return pb.getBasePositionAndOrientation(uid)[0][1] - lo[1]
