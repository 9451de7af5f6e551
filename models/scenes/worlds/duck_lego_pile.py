"""A pile of pybullet_data's convex decompositions and bricks: ``duck_vhacd.urdf`` (a compound of convex hulls,
100 g, friction 1) and ``lego/lego.urdf`` (a brick, 100 g, friction 1, its collision box turned in its link),
alternating on an ``nx`` x ``nz`` grid in ``layers`` layers, jittered (``seed``), dropped onto the ground box."""

from __future__ import annotations

from typing import Any

import numpy as np

from models.scenes.specs import float_param, int_param
from models.scenes.world_parts import Z_UP_TO_Y_UP, about_y, ground, prepare_dynamic, quat_mul

CAPTURE_STEP = 40
ASSETS = ("duck_vhacd.urdf", "lego/lego.urdf")


def build(pb: Any, data_path: str, nx: int = 3, nz: int = 3, layers: int = 2, pitch: float = 0.12,
          layer_height: float = 0.1, seed: int = 0) -> None:
    nx, nz, layers = (int_param(k, v, 1, 20) for k, v in (("nx", nx), ("nz", nz), ("layers", layers)))
    pitch = float_param("pitch", pitch, 0.1, 1.0)
    layer_height = float_param("layer_height", layer_height, 0.08, 1.0)
    seed = int_param("seed", seed, 0, 2**31 - 1)
    rng = np.random.default_rng(seed)
    ground(pb)
    for j in range(layers):
        for i in range(nx):
            for k in range(nz):
                asset = ASSETS[(i + j + k) % 2]
                pos = [(i - (nx - 1) / 2) * pitch + rng.uniform(-0.01, 0.01), 0.06 + j * layer_height,
                       (k - (nz - 1) / 2) * pitch + rng.uniform(-0.01, 0.01)]
                turn = quat_mul(about_y(float(rng.uniform(0.0, 6.283))), Z_UP_TO_Y_UP)
                prepare_dynamic(pb, pb.loadURDF(asset, pos, turn))
