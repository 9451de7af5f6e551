"""An example world file for ``make sim SCENE=docs/example_world.py`` (the format: ``models/scenes/user_world.py``).

A static slab, and on it a teddy (``teddy_vhacd.urdf``: a compound of convex hulls), a capsule lying down, a
cylinder standing, a sphere and a long box turned about the vertical, each of its own mass and friction.
``SCENE_ARGS="teddy_scale=2 friction=0.3"`` changes the teddy's size and the others' friction."""

from typing import Any

CAPTURE_STEP = 15


def build(pb: Any, data_path: str, teddy_scale: float = 1.0, friction: float = 0.6) -> None:
    slab = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[3.0, 0.25, 3.0])
    ground = pb.createMultiBody(0.0, slab, basePosition=[0.0, -0.25, 0.0])
    pb.changeDynamics(ground, -1, lateralFriction=0.9)
    standing = pb.getQuaternionFromEuler([1.5707963, 0.0, 0.0])  # a cylinder's z axis onto the world's y
    shapes = [
        (pb.createCollisionShape(pb.GEOM_CAPSULE, radius=0.08, height=0.5), 0.8, [-1.0, 0.081, 0.0],
         pb.getQuaternionFromEuler([1.5707963, 0.0, 0.4]), friction),
        (pb.createCollisionShape(pb.GEOM_CYLINDER, radius=0.2, height=0.1), 2.5, [0.0, 0.051, -1.0], standing, 0.4),
        (pb.createCollisionShape(pb.GEOM_SPHERE, radius=0.12), 0.3, [1.0, 0.121, 0.5], [0, 0, 0, 1], friction),
        (pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.6, 0.05, 0.1]), 4.0, [0.0, 0.051, 1.0],
         pb.getQuaternionFromEuler([0.0, 0.5, 0.0]), friction),
    ]
    for shape, mass, pos, orn, mu in shapes:
        uid = pb.createMultiBody(mass, shape, basePosition=pos, baseOrientation=orn)
        pb.changeDynamics(uid, -1, lateralFriction=mu, restitution=0.0,
                          activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING)
    teddy = pb.loadURDF("teddy_vhacd.urdf", [0.0, 0.3, 0.0], pb.getQuaternionFromEuler([-1.5707963, 0.0, 0.0]),
                        globalScaling=teddy_scale)
    pos, orn = pb.getBasePositionAndOrientation(teddy)
    bottom = pb.getAABB(teddy)[0][1]
    pb.resetBasePositionAndOrientation(teddy, [pos[0], pos[1] - bottom + 0.002, pos[2]], orn)  # 2 mm above the slab
    pb.changeDynamics(teddy, -1, restitution=0.0, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING)
