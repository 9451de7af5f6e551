"""Scene parameters from the command line: ``SCENE_ARGS="nx=20 ny=5 nz=20 friction=0.4"``.

Each ``key=value`` is typed by the default of the builder's keyword parameter of that name (``int``, ``float``,
``bool``: true/false/1/0/yes/no, a tuple or list of numbers: comma-separated, ``str``); the builder then checks
its range. An unknown key, a malformed pair or a value of the wrong type is a :class:`SceneError` naming it and
the scene's known parameters. Values that are not strings (from Python callers) are passed through unchanged.
"""

from __future__ import annotations

import inspect
from typing import Any, Callable

from models.scenes.scene_error import SceneError

_TRUE, _FALSE = {"true", "1", "yes", "on"}, {"false", "0", "no", "off"}


def split_scene_args(text: str) -> dict[str, str]:
    """``"a=1 b=2,3"`` -> ``{"a": "1", "b": "2,3"}`` (whitespace separated; a key given twice is an error)."""
    out: dict[str, str] = {}
    for item in text.split():
        key, sep, value = item.partition("=")
        if not sep or not key or not value:
            raise SceneError(f"SCENE_ARGS item {item!r} is not key=value")
        if key in out:
            raise SceneError(f"SCENE_ARGS gives {key} twice")
        out[key] = value
    return out


def keyword_defaults(fn: Callable[..., Any], lead: int) -> dict[str, Any]:
    """The keyword parameters of ``fn`` after its first ``lead`` positional ones, with their defaults
    (``inspect.Parameter.empty`` where none)."""
    params = list(inspect.signature(fn).parameters.values())[lead:]
    return {q.name: q.default for q in params if q.kind in (q.POSITIONAL_OR_KEYWORD, q.KEYWORD_ONLY)}


def typed_params(fn: Callable[..., Any], params: dict[str, Any], scene: str, lead: int = 2,
                 skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """``params`` with every string value converted to the type of ``fn``'s default for that key."""
    known = {k: v for k, v in keyword_defaults(fn, lead).items() if k not in skip}
    out: dict[str, Any] = {}
    for key, value in params.items():
        if key not in known:
            raise SceneError(f"unknown parameter {key!r} for scene {scene!r}; known: {', '.join(known) or 'none'}")
        out[key] = _convert(key, value, known[key], scene) if isinstance(value, str) else value
    return out


def _convert(key: str, text: str, default: Any, scene: str) -> Any:
    kind = type(default)
    try:
        if isinstance(default, bool):
            if text.lower() not in _TRUE | _FALSE:
                raise ValueError(text)
            return text.lower() in _TRUE
        if isinstance(default, int):
            return int(text)
        if isinstance(default, float):
            return float(text)
        if isinstance(default, (tuple, list)):
            return kind(float(x) for x in text.split(","))
    except ValueError:
        name = "a bool" if isinstance(default, bool) else (
            "numbers separated by commas" if isinstance(default, (tuple, list)) else
            {"int": "an integer", "float": "a number"}.get(kind.__name__, kind.__name__))
        raise SceneError(f"parameter {key} of scene {scene!r} must be {name}, got {text!r}") from None
    return text
