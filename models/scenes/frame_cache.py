"""The on-disk frame cache (``build/frames/``): a frame is captured once per set of inputs and loaded after."""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import sys
from pathlib import Path
from typing import Any

from models.frame import FRAME_VERSION, Frame, FrameError, load, save
from models.scenes.specs import DEFAULT_CAPTURE_STEP, make_spec
from models.scenes.world import DEFAULT_DT, capture_frame

FRAME_CACHE_DIR = Path("build/frames")  # where frames (and their exact references) are cached


def cache_key(scene: str, step: int | None, busiest_within: int | None, seed: int, pybullet_iterations: int,
              dt: float, params: dict[str, Any]) -> str:
    resolved = make_spec(scene, seed, **params).params  # defaults filled in, validated
    if step is None and busiest_within is None:
        step = DEFAULT_CAPTURE_STEP.get(scene, 1)
    blob = json.dumps({"scene": scene, "params": resolved, "seed": seed, "step": step, "busiest_within": busiest_within,
                       "pybullet_iterations": pybullet_iterations, "dt": dt, "frame_version": FRAME_VERSION,
                       "pybullet": importlib.metadata.version("pybullet")}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def load_or_capture(scene: str, step: int | None = None, busiest_within: int | None = None, seed: int = 0,
                    pybullet_iterations: int = 10, dt: float = DEFAULT_DT, cache_dir: str | Path = FRAME_CACHE_DIR,
                    progress: bool | None = None, **params: Any) -> Frame:
    """capture_frame with an on-disk cache keyed by a hash of all the inputs (and FRAME_VERSION)."""
    key = cache_key(scene, step, busiest_within, seed, pybullet_iterations, dt, params)
    path = Path(cache_dir) / f"{scene}_{key}.npz"
    if path.is_file():
        try:
            return load(path)
        except FrameError as exc:
            print(f"frame cache {path} unusable ({exc}); recapturing", file=sys.stderr)
    frame = capture_frame(scene, step=step, busiest_within=busiest_within, seed=seed,
                          pybullet_iterations=pybullet_iterations, dt=dt, progress=progress, **params)
    frame.meta["cache_key"] = key
    save(frame, path)
    return load(path)
