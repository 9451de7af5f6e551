"""The on-disk frame cache (``build/frames/``): a frame is captured once per set of inputs and loaded after.

A built-in box scene's key is a hash of its resolved parameters and the capture settings. A file world's
(``models.scenes.user_world``: a world file, a URDF, an asset scene) also covers the *content* of the world file
and of every file its ``build`` loaded (URDF/SDF/MJCF and the meshes they name), so an edited file is
recaptured; the world is built once to learn which files those are (and, on a miss, captured in that build)."""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import sys
from pathlib import Path
from typing import Any

from models.formats.frame import FRAME_VERSION, Frame, FrameError, load, save
from models.scenes.scene_args import split_scene_args
from models.scenes.specs import DEFAULT_CAPTURE_STEP, make_spec
from models.scenes.user_world import WORLD_SEED, WorldFileSource, is_world_scene, scene_label
from models.scenes.world import DEFAULT_DT, SceneWorld, build_world, capture_frame, capture_in

FRAME_CACHE_DIR = Path("build/frames")  # where frames (and their exact references) are cached


def _digest(blob: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()[:16]


def cache_key(scene: str, step: int | None, busiest_within: int | None, seed: int, pybullet_iterations: int,
              dt: float, params: dict[str, Any]) -> str:
    """The key of a built-in box scene's frame."""
    resolved = make_spec(scene, seed, **params).params  # defaults filled in, validated
    if step is None and busiest_within is None:
        step = DEFAULT_CAPTURE_STEP.get(scene, 1)
    return _digest({"scene": scene, "params": resolved, "seed": seed, "step": step, "busiest_within": busiest_within,
                    "pybullet_iterations": pybullet_iterations, "dt": dt, "frame_version": FRAME_VERSION,
                    "pybullet": importlib.metadata.version("pybullet")})


def world_cache_key(world: SceneWorld, step: int | None, busiest_within: int | None, pybullet_iterations: int,
                    dt: float) -> str:
    """The key of a file world's frame, from a built (not yet stepped) world."""
    source = world.source
    assert isinstance(source, WorldFileSource)
    if step is None and busiest_within is None:
        step = source.capture_step
    return _digest({"world": source.path.name, "content": source.content_digest(), "params": source.params,
                    "meta": source.frame_meta,
                    "step": step, "busiest_within": busiest_within, "pybullet_iterations": pybullet_iterations,
                    "dt": dt, "frame_version": FRAME_VERSION, "pybullet": importlib.metadata.version("pybullet")})


def _cached(path: Path) -> Frame | None:
    if path.is_file():
        try:
            return load(path)
        except FrameError as exc:
            print(f"frame cache {path} unusable ({exc}); recapturing", file=sys.stderr)
    return None


def _store(frame: Frame, key: str, path: Path) -> Frame:
    frame.meta["cache_key"] = key
    save(frame, path)
    return load(path)


def load_or_capture(scene: str, step: int | None = None, busiest_within: int | None = None, seed: int = 0,
                    pybullet_iterations: int = 10, dt: float = DEFAULT_DT, cache_dir: str | Path = FRAME_CACHE_DIR,
                    progress: bool | None = None, workers: int | None = None, **params: Any) -> Frame:
    """capture_frame with an on-disk cache keyed by a hash of all the inputs (and FRAME_VERSION); nothing is
    written when the capture fails."""
    if is_world_scene(scene):
        with build_world(scene, seed=seed, pybullet_iterations=pybullet_iterations, dt=dt, workers=workers,
                         **params) as world:
            key = world_cache_key(world, step, busiest_within, pybullet_iterations, dt)
            path = Path(cache_dir) / f"{scene_label(scene)}_{key}.npz"
            frame = _cached(path)
            if frame is not None:
                return frame
            return _store(capture_in(world, step, busiest_within, progress), key, path)
    key = cache_key(scene, step, busiest_within, seed, pybullet_iterations, dt, params)
    path = Path(cache_dir) / f"{scene}_{key}.npz"
    frame = _cached(path)
    if frame is not None:
        return frame
    frame = capture_frame(scene, step=step, busiest_within=busiest_within, seed=seed,
                          pybullet_iterations=pybullet_iterations, dt=dt, progress=progress, workers=workers, **params)
    return _store(frame, key, path)


def load_scene(scene: str, scene_args: str = "", seed: int = 0) -> tuple[Frame, str]:
    """The frame of a scene and its command-line parameters (``SCENE_ARGS``, :func:`split_scene_args`), captured
    or cached (:func:`load_or_capture`), and the name of the runs made of it: the scene's label, then each
    parameter as ``<key><value>``."""
    params = split_scene_args(scene_args)
    label = "-".join([scene_label(scene), *(f"{k}{v}".replace("/", "_") for k, v in params.items())])
    if is_world_scene(scene) and "seed" in params:  # the world's own seed parameter (random_world, duck_lego_pile)
        params[WORLD_SEED] = params.pop("seed")
    return load_or_capture(scene, seed=seed, **params), label
