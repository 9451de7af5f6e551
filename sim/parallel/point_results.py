"""A results file keyed by point: one JSON line per finished point, so that a rerun resumes from them.

The driver (``sim.parallel.executor.run_points``) appends a line ``{"key": ..., "row": ...}`` as each point finishes, in
one ``write`` on a file opened for appending and flushed to disk: an interrupted run leaves whole lines and at most one
torn last line, which :meth:`PointLog.load` skips (that point runs again). A point's key names everything its row
depends on (``sim.compile.artefacts.source_digest`` included), so a rerun after a change of sources runs every point
again.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

Row = dict[str, Any]


@dataclass(frozen=True)
class PointLog:
    path: Path

    def load(self) -> dict[str, Row]:
        """The rows of the points finished so far, by key (none when the file does not exist)."""
        rows: dict[str, Row] = {}
        if not Path(self.path).is_file():
            return rows
        for line in Path(self.path).read_text().splitlines():
            try:
                entry = json.loads(line)
                rows[str(entry["key"])] = entry["row"]
            except (ValueError, KeyError, TypeError):
                continue  # a torn last line of an interrupted run
        return rows

    def append(self, key: str, row: Row) -> None:
        """Record one finished point (one whole line, on disk before this returns)."""
        Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        line = (json.dumps({"key": key, "row": row}, sort_keys=True) + "\n").encode()
        fd = os.open(self.path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            size = os.fstat(fd).st_size
            if size and os.pread(fd, 1, size - 1) != b"\n":  # end a torn line first: it stays unreadable alone
                line = b"\n" + line
            os.write(fd, line)
            os.fsync(fd)
        finally:
            os.close(fd)

    def remove(self) -> None:
        """Drop the file once its run is complete (its results live on in the run's outputs)."""
        Path(self.path).unlink(missing_ok=True)
