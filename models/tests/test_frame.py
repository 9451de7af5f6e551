"""Frame files that are not good frames and frame files that carry pickles.

``models.formats.frame.load`` must refuse each with a ``FrameError`` of one line naming the problem; a crafted ``.npz``
holding a pickled object whose unpickling would run code is refused without running it (a positive control
shows that numpy's pickle loading would have run it). The frame cache (``models.scenes.load_or_capture``)
replaces an unusable cached frame by a new capture, atomically (``save`` writes a temporary file and renames
it: no partial file is left, even when the write fails).
"""

from __future__ import annotations

import json
import pathlib
import zipfile
from dataclasses import fields
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from models.formats import frame as frame_mod
from models import scenes
from models.formats.frame import Frame, FrameError, load, save


def tiny_frame() -> Frame:
    """A valid frame of two bodies (the ground and a box) and one manifold, made without pybullet."""
    n, m = 2, 1
    arrays = {f.name: np.zeros(getattr_shape(f.name, n, m)) for f in fields(Frame) if f.name != "meta"}
    arrays["orientation"][:, 3] = 1.0
    arrays["inv_mass"][1] = 1.0
    arrays["half_extents"][:] = 0.5
    arrays["body_b"][:] = 1
    arrays["num_points"][:] = 4
    arrays["normal_on_b"][:, :, 1] = 1.0
    for name in ("shape_index", "body_a", "body_b", "num_points"):
        arrays[name] = arrays[name].astype(np.int32)
    return Frame(**arrays, meta={"scene": "tiny", "dt": 1 / 60})


def getattr_shape(name: str, n: int, m: int) -> tuple[int, ...]:
    per_body = {"position": 3, "orientation": 4, "linear_velocity": 3, "angular_velocity": 3, "inv_mass": 0,
                "inertia_local": 3, "half_extents": 3, "shape_index": 0, "friction": 0, "post_linear_velocity": 3,
                "post_angular_velocity": 3}
    if name in per_body:
        return (n, per_body[name]) if per_body[name] else (n,)
    per_point = {"point_on_a": 3, "point_on_b": 3, "normal_on_b": 3, "lateral_dir1": 3, "lateral_dir2": 3,
                 "distance": 0, "normal_force": 0, "lateral_friction1": 0, "lateral_friction2": 0}
    if name in per_point:
        return (m, 4, per_point[name]) if per_point[name] else (m, 4)
    return (m,)


def _contents(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def _rewrite(path: Path, **changes: np.ndarray | None) -> None:
    """Rewrite a frame file with some arrays replaced (None: removed)."""
    arrays = _contents(path)
    for k, v in changes.items():
        if v is None:
            arrays.pop(k)
        else:
            arrays[k] = v
    np.savez(path, **arrays)


def _meta(version: object) -> np.ndarray:
    return np.array(json.dumps({"scene": "tiny", "frame_version": version}))


BAD_FILES: dict[str, tuple[Callable[[Path], None], str]] = {
    "missing": (lambda p: p.unlink(), "does not exist"),
    "not a zip": (lambda p: p.write_bytes(b"this is not a frame\n" * 20), "corrupt or not an .npz file"),
    "truncated": (lambda p: p.write_bytes(p.read_bytes()[:len(p.read_bytes()) // 2]), "corrupt or truncated"),
    "empty": (lambda p: p.write_bytes(b""), "corrupt or truncated"),
    "older version": (lambda p: _rewrite(p, meta_json=_meta(0)), "has version 0, this tool reads version"),
    "no version": (lambda p: _rewrite(p, meta_json=np.array(json.dumps({"scene": "tiny"}))), "has version None"),
    "no metadata": (lambda p: _rewrite(p, meta_json=None), "has no metadata"),
    "bad metadata": (lambda p: _rewrite(p, meta_json=np.array("{not json")), "unreadable metadata"),
    "missing field": (lambda p: _rewrite(p, distance=None), "lacks fields: distance"),
    "wrong shape": (lambda p: _rewrite(p, position=np.zeros((3, 3))), "field position has shape (3, 3)"),
    "NaN value": (lambda p: _rewrite(p, linear_velocity=np.full((2, 3), np.nan)), "linear_velocity holds NaN"),
    "body index": (lambda p: _rewrite(p, body_b=np.array([7], np.int32)), "body index out of range"),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_load_refuses_bad_frame_files(tmp_path: Path, case: str) -> None:
    path = save(tiny_frame(), tmp_path / "f.npz")
    assert load(path).num_bodies == 2  # the file is good before the damage
    damage, words = BAD_FILES[case]
    damage(path)
    with pytest.raises(FrameError) as info:
        load(path)
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg and words in msg, msg


class _RunsCode:
    """An object whose unpickling creates ``marker`` (as any code could run)."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self) -> tuple[Callable[..., None], tuple[Path]]:
        return pathlib.Path.touch, (self.marker,)


@pytest.mark.parametrize("where", ["field", "metadata", "extra array"])
def test_load_never_unpickles(tmp_path: Path, where: str) -> None:
    """A frame file with a pickled object (in a field, as the metadata, or as an extra array) is refused, and
    the object's code never runs; allow_pickle=True would have run it (the crafted file is a real exploit)."""
    path = save(tiny_frame(), tmp_path / "f.npz")
    marker = tmp_path / "pwned"
    evil = np.array([_RunsCode(marker)], dtype=object)
    key = {"field": "position", "metadata": "meta_json", "extra array": "zz_extra"}[where]
    arrays = _contents(path)
    arrays[key] = evil
    np.savez(path, **arrays)  # numpy pickles the object array into the .npy member
    with zipfile.ZipFile(path) as z:
        assert f"{key}.npy" in z.namelist()
    with pytest.raises(FrameError, match="pickled Python object") as info:
        load(path)
    assert "\n" not in str(info.value)
    assert not marker.exists(), "loading the frame ran code from a pickle"
    with np.load(path, allow_pickle=True) as data:  # positive control: unpickling does run it
        data[key]
    assert marker.exists()


def test_save_leaves_no_partial_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A save that fails half-way (here: the compressed write raises) leaves neither the target nor a temporary
    file; an existing frame at the target stays intact."""
    target = save(tiny_frame(), tmp_path / "f.npz")
    before = target.read_bytes()

    def fail(file: str, **arrays: np.ndarray) -> None:
        Path(file).write_bytes(b"half a frame")
        raise OSError("disk full")

    monkeypatch.setattr(frame_mod.np, "savez_compressed", fail)
    with pytest.raises(OSError, match="disk full"):
        save(tiny_frame(), target)
    with pytest.raises(OSError):
        save(tiny_frame(), tmp_path / "new.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.npz"]
    assert target.read_bytes() == before


def test_cache_replaces_an_unusable_frame(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A corrupt cached frame is reported in one line naming the file and recaptured into the same place."""
    good = scenes.load_or_capture("stack", n=2, cache_dir=tmp_path)
    (path,) = tmp_path.glob("stack_*.npz")
    path.write_bytes(path.read_bytes()[:100])  # truncated
    again = scenes.load_or_capture("stack", n=2, cache_dir=tmp_path)
    warning = [ln for ln in capsys.readouterr().err.splitlines() if "unusable" in ln]
    assert len(warning) == 1 and str(path) in warning[0] and "corrupt or truncated" in warning[0]
    assert np.array_equal(good.position, again.position)
    assert sorted(tmp_path.iterdir()) == [path] and load(path).num_bodies == good.num_bodies
