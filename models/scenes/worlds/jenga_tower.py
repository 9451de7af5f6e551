"""A jenga tower from pybullet_data (``jenga/jenga.urdf``: boxes 0.15 x 0.05 x 0.03 m, 50 g, friction 0.5):
``levels`` levels of three blocks side by side, each level turned 90 degrees about the vertical, stacked ``gap``
m apart on the ground box (friction 1). Captured once settled: the blocks rest on each other (rotated non-cube
boxes, two frictions)."""

from __future__ import annotations

import math
from typing import Any

from models.scenes.specs import float_param, int_param
from models.scenes.world_parts import Z_UP_TO_Y_UP, about_y, ground, prepare_dynamic, quat_mul

CAPTURE_STEP = 20
LENGTH, WIDTH, HEIGHT = 0.15, 0.05, 0.03  # the URDF's collision box (x, y, z before the turn to y-up)


def build(pb: Any, data_path: str, levels: int = 6, gap: float = 0.0005, spacing: float = 0.001) -> None:
    levels = int_param("levels", levels, 1, 100)
    gap = float_param("gap", gap, 0.0, 0.01)
    spacing = float_param("spacing", spacing, 0.0, 0.02)
    ground(pb)
    for level in range(levels):
        turn = quat_mul(about_y(math.pi / 2 * (level % 2)), Z_UP_TO_Y_UP)
        y = HEIGHT / 2 + gap + level * (HEIGHT + gap)
        for k in (-1, 0, 1):
            across = k * (WIDTH + spacing)
            pos = [0.0, y, across] if level % 2 == 0 else [across, y, 0.0]
            prepare_dynamic(pb, pb.loadURDF("jenga/jenga.urdf", pos, turn))
