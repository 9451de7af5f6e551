"""The world of ``SCENE=object.urdf``: ``count`` copies of the object in a row along x, ``pitch`` times its size
apart, its link turned z-up -> y-up and dropped from ``drop`` m onto the ground box (``models.scenes.user_world``)."""

from __future__ import annotations

from typing import Any

from models.scenes.specs import float_param, int_param
from models.scenes.world_parts import Z_UP_TO_Y_UP, bottom_offset, ground, prepare_dynamic


def build(pb: Any, data_path: str, urdf: str = "", count: int = 4, pitch: float = 1.5, drop: float = 0.02) -> None:
    count = int_param("count", count, 1, 1000)
    pitch = float_param("pitch", pitch, 1.0, 100.0)
    drop = float_param("drop", drop, 0.0, 10.0)
    ground(pb)
    first = pb.loadURDF(urdf, [0.0, 0.0, 0.0], Z_UP_TO_Y_UP)
    lo, hi = pb.getAABB(first)
    size = max(hi[0] - lo[0], hi[2] - lo[2])
    y = drop + bottom_offset(pb, first)
    for k in range(count):
        uid = first if k == 0 else pb.loadURDF(urdf, [0.0, 0.0, 0.0], Z_UP_TO_Y_UP)
        turn = pb.getBasePositionAndOrientation(uid)[1]  # the principal frame's (the link's, with the URDF's rpy)
        pb.resetBasePositionAndOrientation(uid, [(k - (count - 1) / 2) * pitch * size, y, 0.0], turn)
        prepare_dynamic(pb, uid)
