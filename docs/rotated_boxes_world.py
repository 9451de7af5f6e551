"""A world file of rotated non-cube boxes in Bullet 2's convention (``make sim SCENE=docs/rotated_boxes_world.py``).

On a static slab, boxes of different extents and masses turned about the vertical and about a tilted axis, and one
lying across two others: their world inverse inertia ``R diag(1/I) R^T`` is a full symmetric 3x3, so the kernel is
built with the 6-word body record (``IINV_W = 6``). Every body keeps pybullet's default friction (0.5), so every pair's
is 0.25, not the kernel's constant 0.7: each friction record carries it (``MU_W = 1``). ``SCENE_ARGS="yaw=0.3
mass=2"`` turns and weighs the boxes."""

from typing import Any

CAPTURE_STEP = 12
BULLET_CONVENTION = "bullet2"


def build(pb: Any, data_path: str, yaw: float = 0.5, mass: float = 1.0) -> None:
    slab = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[3.0, 0.25, 3.0])
    pb.createMultiBody(0.0, slab, basePosition=[0.0, -0.25, 0.0])
    boxes = [  # half extents, mass factor, position, Euler angles (x, y, z)
        ([0.4, 0.1, 0.2], 1.0, [-1.2, 0.1, -0.8], [0.0, yaw, 0.0]),
        ([0.15, 0.3, 0.1], 0.5, [-0.3, 0.3, -0.9], [0.0, 2.0 * yaw, 0.0]),
        ([0.5, 0.05, 0.15], 2.5, [0.8, 0.05, -0.7], [0.0, -yaw, 0.0]),
        ([0.3, 0.1, 0.1], 1.0, [-1.0, 0.1, 0.6], [0.0, 0.2, 0.0]),
        ([0.3, 0.1, 0.1], 1.0, [-1.0, 0.1, 1.2], [0.0, -0.2, 0.0]),
        ([0.1, 0.08, 0.6], 0.8, [-1.0, 0.29, 0.9], [0.0, 0.3 * yaw, 0.0]),
        ([0.25, 0.12, 0.18], 4.0, [1.0, 0.3, 0.8], [0.35, yaw, 0.2]),
    ]
    for half, factor, pos, euler in boxes:
        shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half)
        uid = pb.createMultiBody(mass * factor, shape, basePosition=pos, baseOrientation=pb.getQuaternionFromEuler(euler))
        pb.changeDynamics(uid, -1, restitution=0.0, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING)
