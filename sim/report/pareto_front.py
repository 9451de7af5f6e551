"""The fitting designs' Pareto front of a sweep: cycles per manifold-pass against the error from the exact reference.

Each sweep row is a design point (format, design, iterations): x its cycles per manifold-pass (the cycle model's or
the RTL kernel's), y its error against the exact limit of the scheme (max over dynamic bodies of |dv|, and of
|dw|: ``sim/compare/exact_error.py``). The front is the fitting points (``fits`` true: at the pessimistic end of the
estimate's band, ``sim/fit/estimate_band.py``)
that no other fitting point beats on both axes. The thesis's two ZCU102 designs (``models/published/thesis.py``: fp32
and fp16, 4 iterations) go on the same axes at their published cycles per manifold-pass (their 127,000-manifold frame);
their error is not published, so theirs is our golden model's of the same format and iteration count on the swept frame
(the thesis's scheme: contact passes, then friction passes), labelled as such.

:func:`dominance` says by how much the front beats each thesis design: the front's fewest cycles per manifold-pass
at an error no larger than the thesis design's, and its smallest error at no more cycles per manifold-pass.

Cycles per manifold-pass divide the step's cycles by its passes, so they fall with the iterations (the body load
and the pipe's fill are spread over more passes): on that axis the design with the most iterations is both the
fastest and the most accurate point. The second axis, cycles per manifold of the whole step (iterations
included; the thesis's: its cycles over its 127,000 manifolds), is the time a step costs, on which more
iterations cost more: the front there is the trade-off a user chooses from. Both are drawn and reported.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from models.published import thesis as baselines

@dataclass(frozen=True)
class Axis:
    name: str  # short, for the report
    label: str  # the plot's

    def of_row(self, row: dict[str, Any]) -> float:
        if self.name == "cycles/mp":
            return float(row["cycles_per_manifold_pass"])
        return float(row["cycles"]) / float(row["manifolds"])

    def of_thesis(self, fig: baselines.FpgaFigure) -> float:
        if self.name == "cycles/mp":
            return fig.cycles_per_manifold_pass
        return fig.cycles / baselines.THESIS_MANIFOLDS


AXES = (Axis("cycles/mp", "cycles per manifold-pass (iterations annotated)"),
        Axis("cycles/manifold", "cycles per manifold of the whole step: the step's time (iterations annotated)"))
ERRORS = (("max_dv_vs_exact", "max |v - v_exact| over dynamic bodies (m/s)", "m/s"),
          ("max_dw_vs_exact", "max |w - w_exact| over dynamic bodies (rad/s)", "rad/s"))


@dataclass(frozen=True)
class DesignPoint:
    label: str  # format, design
    iterations: int
    x: float  # cycles per manifold-pass
    y: float  # error against the exact reference
    fits: bool


@dataclass(frozen=True)
class ThesisPoint:
    label: str
    x: float  # the thesis's published cycles per manifold-pass
    y: float  # our golden model's error of the same format at the thesis's iteration count


def _fits(row: dict[str, Any]) -> bool:
    return row.get("fits") in (True, "True")


def _label(row: dict[str, Any]) -> str:
    design = str(row.get("design") or "onchip")
    return f"{row['format']}, impulses {'on chip' if design == 'onchip' else 'in ' + design}"


def design_points(rows: Sequence[dict[str, Any]], error: str, axis: Axis = AXES[0]) -> list[DesignPoint]:
    """The rows with an error against the exact reference (a row without one says why, and is left out)."""
    return [DesignPoint(_label(r), int(r["iterations"]), axis.of_row(r), float(r[error]), _fits(r))
            for r in rows if isinstance(r[error], float)]


def front(points: Sequence[DesignPoint]) -> list[DesignPoint]:
    """The fitting points no other fitting point beats on both axes (fewer or as many cycles and a smaller
    error, or fewer cycles and no larger error), by increasing cycles per manifold-pass."""
    fitting = sorted((p for p in points if p.fits), key=lambda p: (p.x, p.y))
    out: list[DesignPoint] = []
    for p in fitting:
        if not out or p.y < out[-1].y:
            out.append(p)
    return out


def thesis_points(rows: Sequence[dict[str, Any]], error: str, axis: Axis = AXES[0]) -> list[ThesisPoint]:
    """The thesis's ZCU102 designs: their cycles per manifold-pass, our golden model's error of the same format at
    the thesis's iterations (a row of that format, the streaming or the window kernel: every design of a format
    solves the same step, bit for bit)."""
    out = []
    for name, fig in baselines.THESIS_FPGA.items():
        same = [r for r in rows if str(r["format"]).split()[0] == name
                and int(r["iterations"]) == baselines.THESIS_ITERATIONS
                and isinstance(r[error], float)]
        if same:
            out.append(ThesisPoint(fig.label, axis.of_thesis(fig), float(same[0][error])))
    return out


@dataclass(frozen=True)
class Dominance:
    thesis: ThesisPoint
    at_error: DesignPoint | None  # the front's fastest point with an error no larger than the thesis design's
    at_cycles: DesignPoint | None  # the front's most accurate point with no more cycles per manifold-pass
    axis: str = "cycles/mp"

    def describe(self, unit: str) -> str:
        t, x = self.thesis, self.axis
        head = f"{t.label} ({t.x:.3f} {x}, our golden error at {baselines.THESIS_ITERATIONS} iterations " \
               f"{t.y:.3e} {unit}):"
        if self.at_error is None:
            speed = "no fitting design reaches its error"
        else:
            p = self.at_error
            speed = (f"at its error or less the front needs {p.x:.3f} {x} ({t.x / p.x:.2f}x as fast; {p.label}, "
                     f"{p.iterations} it, {p.y:.3e} {unit})")
        if self.at_cycles is None:
            accuracy = "no fitting design is as fast"
        else:
            p = self.at_cycles
            ratio = f"{p.y / t.y:.3g}x the thesis design's" if t.y > 0 else "the thesis design's is 0"
            accuracy = (f"at its cycles or fewer the front's error is {p.y:.3e} {unit} ({ratio}; {p.label}, "
                        f"{p.iterations} it, {p.x:.3f} {x})")
        return f"{head} {speed}; {accuracy}"


def dominance(points: Sequence[DesignPoint], thesis: Sequence[ThesisPoint], axis: str = "cycles/mp") -> list[Dominance]:
    """By how much the fitting designs' front beats each thesis design (on the front's own points)."""
    line = front(points)
    out = []
    for t in thesis:
        within_error = [p for p in line if p.y <= t.y]
        within_cycles = [p for p in line if p.x <= t.x]
        out.append(Dominance(t, min(within_error, key=lambda p: p.x, default=None),
                             min(within_cycles, key=lambda p: p.y, default=None), axis))
    return out


def report(rows: Sequence[dict[str, Any]]) -> str:
    """The front (per speed axis and error axis) and its dominance over the thesis's designs, as text."""
    lines = []
    for x in AXES:
        for error, axis, unit in ERRORS:
            pts = design_points(rows, error, x)
            if not pts:
                lines.append(f"{axis}: no exact reference, no front")
                continue
            line = front(pts)
            lines.append(f"{x.name} against {axis}: fitting designs' front ({len(line)} of "
                         f"{sum(p.fits for p in pts)} fitting points, {len(pts)} in all):")
            lines += [f"  {p.x:9.3f} {x.name}  {p.y:.3e} {unit}  {p.label}, {p.iterations} it" for p in line]
            lines += [f"  {d.describe(unit)}" for d in dominance(pts, thesis_points(rows, error, x), x.name)]
    return "\n".join(lines)


def _panel(ax: Any, rows: Sequence[dict[str, Any]], error: str, ylabel: str, x: Axis) -> None:
    pts = design_points(rows, error, x)
    if not pts:
        ax.text(0.5, 0.5, "no exact reference", transform=ax.transAxes, ha="center")
        return
    floor = min((p.y for p in pts if p.y > 0), default=1e-12) / 2
    for c, label in enumerate(dict.fromkeys(p.label for p in pts)):
        mine = sorted((p for p in pts if p.label == label), key=lambda p: p.iterations)
        colour = f"C{c % 10}"
        ax.plot([p.x for p in mine], [max(p.y, floor) for p in mine], "-", color=colour, alpha=0.35)
        for p in mine:
            ax.plot(p.x, max(p.y, floor), "o", color=colour, markerfacecolor=colour if p.fits else "none")
            ax.annotate(str(p.iterations), (p.x, max(p.y, floor)), textcoords="offset points", xytext=(3, 3),
                        fontsize=6, color=colour)
        ax.plot([], [], "o", color=colour, label=label)
    line = front(pts)
    if line:
        ax.step([p.x for p in line], [max(p.y, floor) for p in line], "k-", where="post", linewidth=1.8,
                label="fitting designs' Pareto front")
    for t, marker in zip(thesis_points(rows, error, x), ("s", "D")):
        ax.plot(t.x, max(t.y, floor), marker, color="k", markersize=9,
                label=f"{t.label}: published cycles; error: our golden model, same format, "
                      f"{baselines.THESIS_ITERATIONS} it")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(x.label)
    ax.set_ylabel(ylabel, fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, loc="best")


def plot(rows: Sequence[dict[str, Any]], path: Path, title: str) -> None:
    """Per speed axis (a row) two panels (|dv|, |dw| against the exact reference) of every design point, fitting
    solid, not fitting hollow, the fitting front as a line, the thesis's designs in black."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(AXES), len(ERRORS), figsize=(15, 12))
    for row_axes, x in zip(axes, AXES):
        for ax, (error, ylabel, _unit) in zip(row_axes, ERRORS):
            _panel(ax, rows, error, ylabel, x)
    fig.suptitle(f"{title}\nsolid: fits the platform at the band's pessimistic end, hollow: does not, or no resource "
                 f"estimate (sim/fit/estimate_band.py; "
                 f"not on the front); thesis designs: black (they fit; their 127,000-manifold frame)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
