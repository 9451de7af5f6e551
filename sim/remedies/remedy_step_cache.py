"""The closed-loop step that ``sim.remedies.remedy_price`` prices, cached in ``build/frames/`` beside the frames.

Capturing a warm-started step of the thesis scene costs its pybullet settle and our loop's steps before it; the
priced step (bodies before the warm start, constraints as set up, schedule, initial impulses) and the loop's
warm-start report are stored once per set of capture settings, ``remedy_step_<key>.npz``, written under a
temporary name and renamed into place (a reader never sees half a file). A file that cannot be read is captured
again.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import os
import tempfile
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np

from models.closed_loop.loop import StepInput
from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses

STEP_CACHE_VERSION = 1


def step_key(settings: dict[str, Any]) -> str:
    """SHA-256 (16 hex digits) of the capture settings and the pybullet version."""
    blob = {**settings, "version": STEP_CACHE_VERSION, "pybullet": importlib.metadata.version("pybullet")}
    return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()[:16]


def step_path(cache_dir: str | os.PathLike[str], settings: dict[str, Any]) -> Path:
    return Path(cache_dir) / f"remedy_step_{step_key(settings)}.npz"


def save_step(step: StepInput, report: dict[str, int], path: Path) -> None:
    """Write the step and its warm-start report atomically."""
    if step.initial is None:
        raise ValueError("only a warm-started step is cached (it carries the initial impulses)")
    arrays = {f"b_{f.name}": getattr(step.bodies, f.name) for f in fields(step.bodies)}
    arrays.update({f"c_{f.name}": getattr(step.cons, f.name) for f in fields(step.cons)})
    arrays.update(order=step.order, initial_normal=step.initial.normal, initial_friction=step.initial.friction,
                  meta_json=np.array(json.dumps({"version": STEP_CACHE_VERSION, "report": report})))
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp.npz", dir=path.parent)
    os.close(fd)
    try:
        np.savez(tmp, **arrays)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def load_step(path: Path) -> tuple[StepInput, dict[str, int]] | None:
    """The cached step and report, or None when the file is missing or unusable."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        meta = json.loads(str(arrays["meta_json"]))
        if meta.get("version") != STEP_CACHE_VERSION:
            return None
        bodies = BodyTable(**{f.name: arrays[f"b_{f.name}"] for f in fields(BodyTable)})
        cons = ConstraintSet(**{f.name: arrays[f"c_{f.name}"] for f in fields(ConstraintSet)})
        initial = Impulses(arrays["initial_normal"], arrays["initial_friction"])
        return StepInput(bodies, cons, arrays["order"], initial), {k: int(v) for k, v in meta["report"].items()}
    except (OSError, KeyError, ValueError, TypeError):  # corrupt, truncated or another layout: capture again
        return None
