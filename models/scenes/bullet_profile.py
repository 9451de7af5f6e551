"""pybullet's own timings of one ``stepSimulation``, from its built-in profiler (Chrome trace JSON).

``p.startStateLogging(p.STATE_LOGGING_PROFILE_TIMINGS, file)`` records begin/end events of Bullet's
internal timers (``CProfileSample``) into ``<file>_<thread>.json``. :func:`profiled_step` wraps one step in
it and returns seconds per timer, named without the sequence number pybullet appends (``solveConstraints15``
becomes ``solveConstraints``), summed over repeated calls. The timers we report:

* ``internalSingleStepSimulation``: the whole step;
* ``performDiscreteCollisionDetection``: broad and narrow phase;
* ``solveGroup``: the sequential-impulse constraint solver (setup, iterations, write-back);
* ``solveGroupCacheFriendlyIterations``: its iterations alone.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

import pybullet as p

_EVENT = re.compile(r'"ts"\s*:\s*([0-9.]+)\s*,\s*"ph"\s*:\s*"([BE])"\s*,\s*"name"\s*:\s*"([^"]*)"')
REPORTED = ("internalSingleStepSimulation", "performDiscreteCollisionDetection", "solveGroup",
            "solveGroupCacheFriendlyIterations")


def parse_chrome_trace(text: str) -> dict[str, float]:
    """Seconds per timer name (sequence suffix stripped) from pybullet's profile JSON."""
    open_: dict[str, list[float]] = {}
    total: dict[str, float] = {}
    for ts, ph, raw in _EVENT.findall(text):
        if ph == "B":
            open_.setdefault(raw, []).append(float(ts))
        elif open_.get(raw):
            name = re.sub(r"\d+$", "", raw)
            total[name] = total.get(name, 0.0) + (float(ts) - open_[raw].pop()) * 1e-6
    return total


@contextmanager
def _stdout_silenced() -> Iterator[None]:
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def profiled_step(client: int, step: Callable[[], None]) -> dict[str, float]:
    """Run ``step()`` under pybullet's profiler; return the :data:`REPORTED` timers in seconds."""
    with tempfile.TemporaryDirectory(prefix="pgs_pbprof_") as tmp:
        base = Path(tmp) / "timings"
        log = p.startStateLogging(p.STATE_LOGGING_PROFILE_TIMINGS, str(base), physicsClientId=client)
        try:
            step()
        finally:
            with _stdout_silenced():  # pybullet prints "Writing N timings for thread 0"
                p.stopStateLogging(log, physicsClientId=client)
        times: dict[str, float] = {}
        for f in sorted(Path(tmp).glob("timings*.json")):
            for name, sec in parse_chrome_trace(f.read_text(errors="replace")).items():
                times[name] = times.get(name, 0.0) + sec
    return {k: times[k] for k in REPORTED if k in times}
