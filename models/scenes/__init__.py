"""Test scenes built in pybullet, and frames captured from them, in three parts:

* ``models.scenes.specs``: the catalogue of scenes (what each is made of, from its parameters);
* ``models.scenes.world``: a scene in pybullet, stepped, its contacts captured as a frame;
* ``models.scenes.frame_cache``: frames cached on disk (``build/frames/``).

``models.scenes.kernel_scenes`` names the frames the kernel is tested on (kernel tests, coverage, regression).
The names callers use are importable from ``models.scenes`` itself.
"""

from models.scenes.frame_cache import cache_key, load_or_capture
from models.scenes.specs import DEFAULT_CAPTURE_STEP, SCENES, SceneError, make_spec
from models.scenes.world import GRAVITY, Manifolds, SceneWorld, build_world, capture_frame

__all__ = ["DEFAULT_CAPTURE_STEP", "GRAVITY", "Manifolds", "SCENES", "SceneError", "SceneWorld", "build_world",
           "cache_key", "capture_frame", "load_or_capture", "make_spec"]
