"""What builds a world in a pybullet client (``models.scenes.world.SceneWorld`` runs it): a built-in box scene
(``models.scenes.world.SpecSource``) or a world file (``models.scenes.user_world.WorldFileSource``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from models.scenes.contact_capture import FrameBodies


@dataclass
class Population:
    """What a source created in the client: the frame's bodies in creation order, and, where the source knows
    them exactly (the built-in box scenes), their box half extents and shape indices."""

    bodies: FrameBodies
    half_extents: np.ndarray | None = None  # (N,3); None: measured from pybullet's AABBs
    shape_index: np.ndarray | None = None  # (N,); None: one index per distinct (half extents, mass, inertia)


class WorldSource(Protocol):
    """Something that builds a world in a pybullet client."""

    params: dict[str, Any]
    friction_pair: float | None  # one pair coefficient for the whole scene, or None (per-body friction)
    capture_step: int | None  # the step captured by default (None: the built-in scene's DEFAULT_CAPTURE_STEP)
    frame_meta: dict[str, Any]  # what the source adds to its frames' metadata (a world file's Bullet convention)

    def populate(self, client: int) -> Population: ...
