"""The catalogue of bad world input, defined once: each case's name, what it makes bad and a phrase of the one-line
error it ends in (``make sim SCENE=world.py|obj.urdf``; ``models/scenes/user_world.py`` raises them, before any
frame or run directory is written). ``models/tests/test_user_world.py`` makes every case and checks its message;
the kernel's own catalogue of bad input is ``models/kernel/bad_input.py``.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class WorldBadInputCase:
    """One kind of bad world input (``make sim SCENE=world.py|obj.urdf``): what is bad and a phrase of the one-line
    :class:`models.scenes.SceneError` it ends in, before any frame or run directory is written
    (``models.scenes.user_world``)."""

    name: str
    makes: str  # what is bad
    message: str  # a phrase of the error


WORLD_CATALOGUE: tuple[WorldBadInputCase, ...] = (
    WorldBadInputCase("missing_file", "a world file or URDF that does not exist", "does not exist"),
    WorldBadInputCase("no_function", "a world file without build(pb, data_path, **params)", "defines no function build"),
    WorldBadInputCase("import_error", "a world file that raises when imported", "failed to import"),
    WorldBadInputCase("unknown_parameter", "a SCENE_ARGS key build does not take", "unknown parameter"),
    WorldBadInputCase("jointed_body", "a body with a revolute joint", "the kernel solves contacts only"),
    WorldBadInputCase("fixed_links", "a body of links joined by fixed joints", "URDF_MERGE_FIXED_LINKS"),
    WorldBadInputCase("negative_mass", "a body of mass -1", "mass -1.0"),
    WorldBadInputCase("moving_static", "a zero-mass (static) body given a velocity", "zero mass (static) but moving"),
    WorldBadInputCase("zero_inertia", "a dynamic body with a zero inertia diagonal", "needs a positive inertia"),
    WorldBadInputCase("nan_pose", "NaN in a body's position", "NaN or Inf in its pose"),
    WorldBadInputCase("bad_mesh", "a URDF whose collision mesh pybullet cannot load", "pybullet refused a call"),
    WorldBadInputCase("no_collision_shape", "a dynamic body without a collision shape", "no collision shape"),
    WorldBadInputCase("nan_mesh", "a URDF whose mesh has nan vertices (pybullet_data's random_urdfs/168)",
                      "non-finite vertex"),
    WorldBadInputCase("no_dynamic_body", "a world of static bodies only", "no dynamic body"),
    WorldBadInputCase("no_contact", "a world whose captured step has no contact", "has no contact"),
)
WORLD_CASES: dict[str, WorldBadInputCase] = {c.name: c for c in WORLD_CATALOGUE}
