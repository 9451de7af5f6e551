"""The coverage summary of ``make coverage``, per kernel configuration: per source file under ``rtl/`` the covered
share of line, branch and toggle points and the uncovered points (:func:`summarize`), the waived line points
(``sim.coverage.waivers``), written as ``coverage.md`` / ``coverage.json`` and printed (:func:`write_report`)."""

from __future__ import annotations

import json
import sys
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from sim.coverage.data import BRANCH_COMMENTS, PointKey
from sim.coverage.waivers import TOGGLE_WAIVERS, WAIVERS, ToggleWaiver, Waiver, waiver_for
from sim.compile.verilator_build import REPO_ROOT

if TYPE_CHECKING:
    from sim.coverage.configurations import Configuration
    from sim.coverage.runs import CaseResult

TOP_TOGGLES = 25  # signals listed per configuration, those with the most uncovered toggle points
LINE_GOAL, TOGGLE_GOAL = 95.0, 90.0  # percent, per configuration


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
    waived: dict[tuple[str, int, str], Waiver] = field(default_factory=dict)  # uncovered points with a waiver
    toggle_waived: dict[tuple[str, str], ToggleWaiver] = field(default_factory=dict)  # signals of waived toggles

    @property
    def line_with_waivers(self) -> list[int]:
        """(covered + waived, total) line points."""
        return [self.total.line[0] + len(self.waived), self.total.line[1]]

    @property
    def toggle_with_waivers(self) -> list[int]:
        """(covered + waived, total) toggle points."""
        return [self.total.toggle[0] + sum(self.toggles[k] for k in self.toggle_waived), self.total.toggle[1]]

    def meets_goals(self) -> bool:
        return Row.pct(self.line_with_waivers) >= LINE_GOAL and Row.pct(self.toggle_with_waivers) >= TOGGLE_GOAL

    def to_json(self) -> dict:
        cell = lambda c: {"covered": c[0], "total": c[1], "percent": Row.pct(c)}  # noqa: E731
        return {"files": {r.file: {m: cell(getattr(r, m)) for m in ("line", "branch", "toggle")} for r in self.rows},
                "total": {m: cell(getattr(self.total, m)) for m in ("line", "branch", "toggle")},
                "line_with_waivers": cell(self.line_with_waivers),
                "toggle_with_waivers": cell(self.toggle_with_waivers),
                "waived_toggles": {f"{f}: {sig}": w.reason for (f, sig), w in self.toggle_waived.items()},
                "uncovered_lines": [f"{f}:{ln}: {what}" for f, ln, what in self.uncovered],
                "waived_lines": {f"{f}:{ln}: {what}": w.reason for (f, ln, what), w in self.waived.items()},
                "uncovered_toggles": {f"{f}: {sig}": n for (f, sig), n in self.toggles.items()}}


def summarize(merged: dict[PointKey, int], root: Path = REPO_ROOT, under: str = "rtl/",
              waivers: Sequence[Waiver] = WAIVERS, toggle_waivers: Sequence[ToggleWaiver] = TOGGLE_WAIVERS) -> Summary:
    """Per source file under ``under`` (paths relative to ``root``): line, branch and toggle coverage, and the
    uncovered line points and toggle signals (those ``waivers`` / ``toggle_waivers`` waive apart)."""
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
    src = Sources(root)
    waived = {u: w for u in sorted(uncovered) if (w := waiver_for(u[0], src.line(u[0], u[1]), waivers)) is not None}
    by_signal = {(w.file, w.signal): w for w in toggle_waivers}
    toggle_waived = {k: by_signal[k] for k in toggles if k in by_signal}
    return Summary(sorted(rows.values(), key=lambda r: r.file), total, sorted(uncovered),
                   dict(sorted(toggles.items(), key=lambda kv: -kv[1])), waived, toggle_waived)


class Sources:
    """The lines of the source files under ``root``, each file read once."""

    def __init__(self, root: Path):
        self.root, self.files = root, {}  # type: ignore[var-annotated]

    def line(self, file: str, line: int) -> str:
        """Line ``line`` (from 1) of ``file``, stripped; empty where there is none."""
        if file not in self.files:
            path = self.root / file
            self.files[file] = path.read_text().splitlines() if path.is_file() else []
        text = self.files[file]
        return text[line - 1].strip() if 0 < line <= len(text) else ""


def _relative(file: str, root: Path) -> str:
    path = Path(file)
    return path.relative_to(root).as_posix() if path.is_absolute() and path.is_relative_to(root) else file


def _cell(c: Sequence[int]) -> str:
    return f"{Row.pct(list(c)):.1f}% ({c[0]:,}/{c[1]:,})"


def configuration_markdown(title: str, summary: Summary, root: Path = REPO_ROOT) -> list[str]:
    """One configuration's section: the table per file, the uncovered line points (source, waiver), the signals
    with the most uncovered toggle points."""
    lines = [f"## {title}", "", "| file | line | branch | toggle |", "|---|---|---|---|"]
    lines += [f"| {r.file} | {_cell(r.line)} | {_cell(r.branch)} | {_cell(r.toggle)} |"
              for r in [*summary.rows, summary.total]]
    lines += ["", f"Line with waivers: {_cell(summary.line_with_waivers)}. Uncovered line points "
              f"({len(summary.uncovered)}, {len(summary.waived)} waived):", ""]
    src = Sources(root)
    for file, ln, what in summary.uncovered:
        waiver = summary.waived.get((file, ln, what))
        lines.append(f"- `{file}:{ln}` ({what}): `{src.line(file, ln)}`: "
                     + (f"waived: {waiver.reason}" if waiver else "NOT covered, not waived"))
    lines += ["", f"Toggle with waivers: {_cell(summary.toggle_with_waivers)}. Uncovered toggle points by signal (the "
              f"{TOP_TOGGLES} with the most):", "",
              "| file | signal | uncovered toggle points | waiver |", "|---|---|---|---|"]
    lines += [f"| {f} | {sig} | {n:,} | {w.reason if (w := summary.toggle_waived.get((f, sig))) else ''} |"
              for (f, sig), n in list(summary.toggles.items())[:TOP_TOGGLES]]
    return lines + [""]


def verdict(summary: Summary, config: Configuration, results: Sequence[CaseResult]) -> str:
    """``met`` / ``MISSED``, or ``INCOMPLETE`` where a run of the configuration's own failed or is missing (the
    figures are then those of the runs that did run, the shared ones included)."""
    own = [r for r in results if r.counts_for(config)]
    failed = [r for r in own if r.error]
    if failed or all(r.shared for r in own):
        return f"INCOMPLETE ({len(own) - len(failed)} of {len(own)} runs)"
    return "met" if summary.meets_goals() else "MISSED"


def overview_markdown(summaries: dict[Configuration, Summary], results: Sequence[CaseResult]) -> list[str]:
    """The table of every configuration: its build, its totals, whether it meets the goals."""
    lines = [f"| configuration | build | line | line with waivers | branch | toggle | toggle with waivers | goals "
             f"(line {LINE_GOAL:.0f}%, toggle {TOGGLE_GOAL:.0f}%, with waivers) |", "|---|---|---|---|---|---|---|---|"]
    for config, s in summaries.items():
        t = s.total
        lines.append(f"| {config.name}: {config.readme} | {config.build().name} | {_cell(t.line)} | "
                     f"{_cell(s.line_with_waivers)} | {_cell(t.branch)} | {_cell(t.toggle)} | "
                     f"{_cell(s.toggle_with_waivers)} | {verdict(s, config, results)} |")
    return lines


def report_markdown(summaries: dict[Configuration, Summary], results: Sequence[CaseResult],
                    root: Path = REPO_ROOT) -> str:
    """The overview, each configuration's section and the runs."""
    lines = ["# Coverage of rtl/ per kernel configuration (make coverage)", "",
             "A configuration's figures merge its own runs and the shared ones (the fp-operator vectors of its "
             "format, the register file's test); a point is covered when any instance or run hit it.", "",
             *overview_markdown(summaries, results), ""]
    for config, summary in summaries.items():
        lines += configuration_markdown(f"{config.name}: {config.readme}", summary, root)
    stale = [w for w in WAIVERS if not any(w in s.waived.values() for s in summaries.values())]
    lines += ["## Waivers that waived nothing", ""] + [f"- `{w.file}`: `{w.source}`" for w in stale] + [""]
    lines += ["## Runs", "", "| case | seconds | cycles | status | result |", "|---|---|---|---|---|"]
    for res in results:
        r = res.registers
        lines.append(f"| {res.case.label} | {res.seconds:.1f} | {int(r.get('cycles', 0)):,} | "
                     f"{int(r.get('status', 0)):#x} | {res.error or 'ok'} |")
    return "\n".join(lines) + "\n"


def write_report(summaries: dict[Configuration, Summary], results: Sequence[CaseResult], out: Path) -> int:
    """Write coverage.json / coverage.md into ``out``, print the overview; 1 when a run failed."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "coverage.json").write_text(json.dumps({c.name: s.to_json() for c, s in summaries.items()},
                                                  indent=1) + "\n")
    (out / "coverage.md").write_text(report_markdown(summaries, results))
    print("\n".join(overview_markdown(summaries, results)))
    for config, s in summaries.items():
        open_points = [u for u in s.uncovered if u not in s.waived]
        print(f"{config.name} ({verdict(s, config, results)}): line {Row.pct(s.total.line):.1f}% "
              f"({Row.pct(s.line_with_waivers):.1f}% with "
              f"{len(s.waived)} waived; goal {LINE_GOAL:.0f}%), branch {Row.pct(s.total.branch):.1f}%, toggle "
              f"{Row.pct(s.total.toggle):.1f}% ({Row.pct(s.toggle_with_waivers):.1f}% with the waived signals; goal "
              f"{TOGGLE_GOAL:.0f}%); {len(open_points)} line points open")
    print(f"details: {out / 'coverage.md'}")
    failed = [r for r in results if r.error]
    for r in failed:
        print(f"FAILED {r.case.label}: {r.error}", file=sys.stderr)
    return 1 if failed else 0
