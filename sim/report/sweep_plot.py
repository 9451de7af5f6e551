"""The sweep's pictures: kernel time against error (``sweep.png``) and the Pareto front (``pareto.png``,
``pareto.txt``, from ``sim/report/pareto_front.py``), drawn from the rows ``sim/sweep.py`` writes to ``sweep.csv``.

Each curve is one format and design; a point that does not fit its platform is hollow; a star marks where the
format's rounding error first reaches float64's iteration error; the thesis's designs are vertical marks.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from models.published import thesis as baselines
from sim.report import pareto_front


def write_plots(rows: list[dict[str, Any]], out: Path, name: str) -> str:
    """``sweep.png``, ``pareto.png`` and ``pareto.txt`` of ``rows`` into ``out``; returns the front's text."""
    plot(rows, out / "sweep.png", f"{name}: kernel time against error (iterations annotated)")
    front_text = pareto_front.report(rows)
    (out / "pareto.txt").write_text(front_text + "\n")
    pareto_front.plot(rows, out / "pareto.png", f"{name}: cycles per manifold-pass against the error from the exact "
                                                "reference")
    return front_text


# the plot's two panels: (the csv's error columns against the exact limit, rounding alone, iteration error alone;
# the axis label)
PANELS = (
    (("max_dv_vs_exact", "max_dv_rounding", "max_dv_iteration"),
     "max over dynamic bodies of |v - v_exact| (m/s, absolute, not normalised)"),
    (("max_dw_vs_exact", "max_dw_rounding", "max_dw_iteration"),
     "max over dynamic bodies of |w - w_exact| (rad/s, absolute, not normalised)"),
)
ERROR_FLOOR = 1e-12  # where an error of exactly 0 is drawn on the log axis


def series(row: dict[str, Any]) -> str:
    """A row's curve: its format, and its design where that is not the on-chip one (rows of an older csv have none)."""
    design = str(row.get("design") or "onchip")
    return row["format"] if design == "onchip" else f"{row['format']} impulses in {design}"


def floor_meets_iteration(pts: list[dict[str, Any]], rounding: str, iteration: str) -> dict[str, Any] | None:
    """The first row (fewest iterations) where the format's rounding error reaches float64's iteration error."""
    for r in sorted(pts, key=lambda r: r["iterations"]):
        if isinstance(r[iteration], float) and r[rounding] >= r[iteration]:
            return r
    return None


def _plot_panel(ax: Any, rows: list[dict[str, Any]], columns: tuple[str, str, str], ylabel: str,
                against_time: bool) -> None:
    """One panel: against kernel time (each format's error against the exact limit, a star where its rounding
    reaches the iteration error) or against iterations (also each format's rounding alone and float64's
    iteration error alone, on the shared axis)."""
    exact_col, rounding_col, iteration_col = columns
    iteration_drawn = False
    on_chip = {r["format"] for r in rows if (r.get("design") or "onchip") == "onchip"}
    for c, fmt in enumerate(dict.fromkeys(series(r) for r in rows)):
        if not against_time and any(series(r) == fmt and r["format"] in on_chip and series(r) != r["format"]
                                    for r in rows):
            continue  # against iterations another design of a format has the on-chip design's errors, bit for bit
        pts = sorted((r for r in rows if series(r) == fmt and isinstance(r[exact_col], float)),
                     key=lambda r: r["iterations"])
        if not pts:
            continue
        colour = f"C{c % 10}"
        x = [r["ns_per_manifold_pass"] if against_time else r["iterations"] for r in pts]
        y = [max(r[exact_col], ERROR_FLOOR) for r in pts]
        ax.plot(x, y, "-", color=colour, label=f"{fmt}: against exact")
        for r, xi, yi in zip(pts, x, y):  # a design that does not fit its platform (or has no estimate): hollow
            ax.plot(xi, yi, "o", color=colour, markerfacecolor=colour if r.get("fits") in (True, "True") else "none")
        meet = floor_meets_iteration(pts, rounding_col, iteration_col)
        if meet is not None:
            ax.plot(meet["ns_per_manifold_pass"] if against_time else meet["iterations"],
                    max(meet[exact_col], ERROR_FLOOR), "*", color=colour, markersize=16, markerfacecolor="none")
        if against_time:
            for r, xi in zip(pts, x):
                ax.annotate(str(r["iterations"]), (xi, max(r[exact_col], ERROR_FLOOR)), textcoords="offset points",
                            xytext=(4, 4), fontsize=7)
            continue
        ax.plot(x, [max(r[rounding_col], ERROR_FLOOR) for r in pts], "x--", color=colour, alpha=0.8,
                label=f"{fmt}: rounding alone (vs float64, same passes)")
        if not iteration_drawn:
            ax.plot(x, [max(r[iteration_col], ERROR_FLOOR) for r in pts], "k:", linewidth=2,
                    label="float64 against exact: iteration error alone")
            iteration_drawn = True
    ax.set_xscale("log", base=10 if against_time else 2)
    if not against_time:
        ticks = sorted({r["iterations"] for r in rows})
        ax.set_xticks(ticks, [str(t) for t in ticks])
    ax.set_yscale("log")
    ax.set_xlabel("kernel time per manifold-pass (ns at the preset's clock; iterations annotated)" if against_time
                  else "iterations (contact passes, then as many friction passes)")
    ax.set_ylabel(ylabel, fontsize=8)
    ax.grid(True, which="both", alpha=0.3)


def _thesis_marks(ax: Any) -> None:
    per_mp = baselines.THESIS_MANIFOLDS * baselines.THESIS_PASSES
    marks = [(f"{f.label} ({f.cycles_per_manifold_pass:.2f} cyc/mp)", f.ms * 1e6 / per_mp)
             for f in baselines.THESIS_FPGA.values()]
    marks += [("thesis GTX 980", baselines.THESIS_GPU_MS * 1e6 / per_mp),
              ("thesis i7-3770", baselines.THESIS_CPU_MS * 1e6 / per_mp)]
    for (label, x), style in zip(marks, ("--", "-.", ":", ":")):
        ax.axvline(x, linestyle=style, color="grey")
        ax.text(x, 0.03, label, rotation=90, transform=ax.get_xaxis_transform(), fontsize=7, va="bottom",
                ha="right")


def plot(rows: list[dict[str, Any]], path: Path, title: str) -> None:
    """Kernel time against error: |dv| and |dw| against the exact limit, with each format's rounding alone and
    float64's iteration error alone; a star where a format's rounding first reaches the iteration error. Without
    an exact reference the panels say why and have no points."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(14, 10))
    missing = [r["max_dv_vs_exact"] for r in rows if not isinstance(r["max_dv_vs_exact"], float)]
    for row_axes, against_time in zip(axes, (True, False)):
        for ax, (columns, ylabel) in zip(row_axes, PANELS):
            if len(missing) < len(rows):
                _plot_panel(ax, rows, columns, ylabel, against_time)
            else:
                ax.set_ylabel(ylabel, fontsize=8)
            if missing:
                ax.text(0.5, 0.5, missing[0], transform=ax.transAxes, ha="center", wrap=True)
            if against_time:
                _thesis_marks(ax)
    for ax in axes[:, 0]:
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="lower left")
    modes = sorted({r["mode"] for r in rows})
    how = {"model": "MODE=model: cycle model's cycles, golden model's numbers (bit-exact with the RTL kernel)",
           "rtl": "MODE=rtl: the RTL kernel in Verilator"}
    fig.suptitle(f"{title}\n{'; '.join(str(how.get(m, m)) for m in modes)}; thesis marks: 4 iterations of their "
                 f"127,000-manifold frame;\nstar: rounding alone reaches the iteration error; hollow: does not fit the "
                 f"platform, or no resource estimate (sim/fit/resource_model.py)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
