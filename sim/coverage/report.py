"""The coverage summary of ``make coverage``: per source file under ``rtl/`` the covered share of line, branch and
toggle points and the uncovered points (:func:`summarize`), written as ``coverage.md`` / ``coverage.json`` and
printed (:func:`write_report`)."""

from __future__ import annotations

import json
import sys
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from sim.coverage.data import BRANCH_COMMENTS, PointKey
from sim.verilator_build import REPO_ROOT

if TYPE_CHECKING:
    from sim.coverage.runs import CaseResult

TOP_TOGGLES = 60


@dataclass
class Row:
    """Coverage of one source file: (covered, total) points per measure."""

    file: str
    line: list[int] = field(default_factory=lambda: [0, 0])
    branch: list[int] = field(default_factory=lambda: [0, 0])
    toggle: list[int] = field(default_factory=lambda: [0, 0])

    def add(self, measure: str, covered: bool) -> None:
        cell = getattr(self, measure)
        cell[0] += int(covered)
        cell[1] += 1

    @staticmethod
    def pct(cell: list[int]) -> float:
        return 100.0 * cell[0] / cell[1] if cell[1] else 100.0


@dataclass
class Summary:
    rows: list[Row]  # one per rtl/ file, sorted
    total: Row
    uncovered: list[tuple[str, int, str]]  # (file, line, what) of every uncovered line point
    toggles: dict[tuple[str, str], int] = field(default_factory=dict)  # (file, signal) -> uncovered toggle points

    def to_json(self) -> dict:
        cell = lambda c: {"covered": c[0], "total": c[1], "percent": Row.pct(c)}  # noqa: E731
        return {"files": {r.file: {m: cell(getattr(r, m)) for m in ("line", "branch", "toggle")} for r in self.rows},
                "total": {m: cell(getattr(self.total, m)) for m in ("line", "branch", "toggle")},
                "uncovered_lines": [f"{f}:{ln}: {what}" for f, ln, what in self.uncovered],
                "uncovered_toggles": {f"{f}: {sig}": n for (f, sig), n in self.toggles.items()}}


def summarize(merged: dict[PointKey, int], root: Path = REPO_ROOT, under: str = "rtl/") -> Summary:
    """Per source file under ``under`` (paths relative to ``root``): line, branch and toggle coverage, and the
    uncovered line points."""
    rows: dict[str, Row] = {}
    total = Row("total")
    uncovered: set[tuple[str, int, str]] = set()
    toggles: dict[tuple[str, str], int] = defaultdict(int)
    for (file, line, _col, kind, comment), count in merged.items():
        rel = _relative(file, root)
        if not rel.startswith(under) or kind not in ("line", "toggle"):
            continue
        row = rows.setdefault(rel, Row(rel))
        for r in (row, total):
            r.add(kind, count > 0)
            if kind == "line" and comment in BRANCH_COMMENTS:
                r.add("branch", count > 0)
        if kind == "line" and count == 0:
            uncovered.add((rel, line, comment))
        if kind == "toggle" and count == 0:
            toggles[(rel, comment.split("[")[0].split(":")[0])] += 1
    return Summary(sorted(rows.values(), key=lambda r: r.file), total, sorted(uncovered),
                   dict(sorted(toggles.items(), key=lambda kv: -kv[1])))


def _relative(file: str, root: Path) -> str:
    path = Path(file)
    return path.relative_to(root).as_posix() if path.is_absolute() and path.is_relative_to(root) else file


def report_markdown(summary: Summary, results: Sequence[CaseResult], root: Path = REPO_ROOT) -> str:
    """The coverage table, the uncovered lines (with their source) and the runs."""
    cell = lambda c: f"{Row.pct(c):.1f}% ({c[0]:,}/{c[1]:,})"  # noqa: E731
    lines = ["# Coverage of rtl/ (make coverage)", "",
             "| file | line | branch | toggle |", "|---|---|---|---|"]
    lines += [f"| {r.file} | {cell(r.line)} | {cell(r.branch)} | {cell(r.toggle)} |"
              for r in [*summary.rows, summary.total]]
    lines += ["", f"## Uncovered line points ({len(summary.uncovered)})", ""]
    sources: dict[str, list[str]] = {}
    for file, ln, what in summary.uncovered:
        text = sources.setdefault(file, (root / file).read_text().splitlines() if (root / file).is_file() else [])
        src = text[ln - 1].strip() if 0 < ln <= len(text) else ""
        lines.append(f"- `{file}:{ln}` ({what}): `{src}`")
    lines += ["", f"## Uncovered toggle points by signal (the {TOP_TOGGLES} with the most)", "",
              "| file | signal | uncovered toggle points |", "|---|---|---|"]
    lines += [f"| {f} | {sig} | {n:,} |" for (f, sig), n in list(summary.toggles.items())[:TOP_TOGGLES]]
    lines += ["", "## Runs", "", "| case | seconds | cycles | status | result |", "|---|---|---|---|---|"]
    for res in results:
        r = res.registers
        lines.append(f"| {res.case.label} | {res.seconds:.1f} | {int(r.get('cycles', 0)):,} | "
                     f"{int(r.get('status', 0)):#x} | {res.error or 'ok'} |")
    return "\n".join(lines) + "\n"


def write_report(merged: dict[PointKey, int], results: Sequence[CaseResult], out: Path) -> int:
    """Write coverage.json / coverage.md into ``out``, print the table; 1 when a run failed."""
    summary = summarize(merged)
    out.mkdir(parents=True, exist_ok=True)
    (out / "coverage.json").write_text(json.dumps(summary.to_json(), indent=1) + "\n")
    md = report_markdown(summary, results)
    (out / "coverage.md").write_text(md)
    print(md[:md.index("## Uncovered")] + f"uncovered line points: {len(summary.uncovered)} (list in "
          f"{out / 'coverage.md'})")
    t = summary.total
    print(f"rtl/ total: line {Row.pct(t.line):.1f}% (goal 95%), branch {Row.pct(t.branch):.1f}%, toggle "
          f"{Row.pct(t.toggle):.1f}% (goal 90%)")
    failed = [r for r in results if r.error]
    for r in failed:
        print(f"FAILED {r.case.label}: {r.error}", file=sys.stderr)
    return 1 if failed else 0
