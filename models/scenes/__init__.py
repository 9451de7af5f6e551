"""Test scenes built in pybullet, and frames captured from them, in three parts:

* ``models.scenes.specs``: the catalogue of scenes (what each is made of, from its parameters);
* ``models.scenes.world``: a scene in pybullet, stepped, its contacts captured as a frame;
* ``models.scenes.frame_cache``: frames cached on disk (``build/frames/``);
* ``models.scenes.user_world``: worlds from files (a Python world file, a URDF) and the asset scenes;
* ``models.scenes.contact_capture``: the contact manifolds read from a stepped world (few queries, in parallel);
* ``models.scenes.scene_args``: scene parameters from the command line (``SCENE_ARGS``).

``models.scenes.kernel_scenes`` names the frames the kernel is tested on (kernel tests, coverage, regression).
The names callers use are importable from ``models.scenes`` itself.
"""

from models.scenes.contact_capture import Manifolds
from models.scenes.frame_cache import cache_key, load_or_capture, load_scene
from models.scenes.scene_args import split_scene_args
from models.scenes.specs import DEFAULT_CAPTURE_STEP, SCENES, make_spec
from models.scenes.scene_error import SceneError
from models.scenes.user_world import ASSET_SCENES, is_world_scene, scene_label
from models.scenes.world import GRAVITY, SceneWorld, build_world, capture_frame

__all__ = ["ASSET_SCENES", "DEFAULT_CAPTURE_STEP", "GRAVITY", "Manifolds", "SCENES", "SceneError", "SceneWorld",
           "build_world", "cache_key", "capture_frame", "is_world_scene", "load_or_capture", "load_scene", "make_spec",
           "scene_label", "split_scene_args"]
