"""``make band``: band width D of every schedule on every scene, and the on-chip budget it implies.

For every scene (``models.scenes.SCENES``, the frame ``make sim`` uses: cached in ``build/frames/`` or captured)
prints the manifold count and D (``models.order.manifold_schedule.band_width``: the longest run of slots over which one
dynamic body's manifolds spread) for pybullet's order, the hazard order, and every banded order
(``models.order.manifold_schedule.BANDED_ORDERS``) before and after the hazard reordering with the kernel's hazard
window W of each format on the ZCU102 preset (``sim.compile.kernel_build.default_window``). Then, for the budget scene
(the thesis frame unless ``--budget-scene``), the on-chip bytes (``models.sizing.onchip_budget``) of body state,
accumulated impulses and the record window of the best banded schedule after hazard reordering, per platform, format,
number of passes trailing the streaming pass (fetch once per 1, 2 or ITERS iterations) and impulse placement, whether
the bytes are within the blocks' data bytes, and whether the whole window kernel fits (``sim.fit.resource_model``: its
logic, and its memories as block RAM with the copies their ports need, which bytes alone do not count; the verdict
with the estimate's band against a vendor flow and its margin, ``sim.fit.estimate_band``). Last, the DDR
and compute floors per manifold-pass of the budget scene (``models.sizing.onchip_budget.floors``): records streamed
every pass as today, or fetched once per 1, 2 or ITERS iterations, with 1, 2 or 4 lanes; which floor binds, and whether
that fetch period's whole kernel with that many lanes fits. Writes the figures to ``build/band/band-s<seed>.json``.

    python -m sim.band --seed 1 --iters 4
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from models.sizing import onchip_budget as ob
from models import scenes
from models.setup.constraints import body_table, setup_constraints
from models.formats.frame import FrameError
from models.formats.number_format import BF16, FP16, FP32, NumberFormat
from models.order.manifold_schedule import BANDED_ORDERS, band_width, hazard_order, pybullet_order
from sim.fit import estimate_band as eb
from sim.fit import resource_model as rm
from sim.compile.kernel_build import default_window
from models.timing.platforms import PLATFORMS, Platform

FORMATS: tuple[NumberFormat, ...] = (FP32, FP16, BF16)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.band", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default=",".join(scenes.SCENES), help="comma-separated scene names")
    ap.add_argument("--seed", type=int, default=1, help="scene seed (the frames make sim uses)")
    ap.add_argument("--iters", type=int, default=4, help="PGS iterations (the longest fetch period of the budget)")
    ap.add_argument("--budget-scene", default="thesis", help="the scene whose on-chip budget is tabled")
    ap.add_argument("--out", default="build/band", help="directory of the JSON figures")
    return ap.parse_args(argv)


def hazard_windows(platforms: Sequence[Platform]) -> dict[tuple[str, str], int]:
    """The kernel's hazard window W per (platform, format): its DMA preset's stream width sets the beats."""
    return {(p.name, f.name): default_window(f, p.preset.stream_bits) for p in platforms for f in FORMATS}


def scene_bands(scene: str, seed: int, windows: Sequence[int]) -> dict[str, Any]:
    """D of every order of one scene's frame, and after the hazard reordering with each window W."""
    frame = scenes.load_or_capture(scene, seed=seed)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    dyn = bodies.dynamic
    orders = {"pybullet": pybullet_order(cons)} | {name: order(cons, dyn) for name, order in BANDED_ORDERS.items()}
    bands: dict[str, dict[str, int]] = {}
    for name, order in orders.items():
        bands[name] = {"D": band_width(order, cons, dyn)}
        for w in windows:
            bands[name][f"W={w}"] = band_width(hazard_order(cons, dyn, w, order), cons, dyn)
    best = min(BANDED_ORDERS, key=lambda name: bands[name]["D"])
    return {"scene": scene, "bodies": frame.num_bodies, "dynamic bodies": int(dyn.sum()),
            "manifolds": frame.num_manifolds, "bands": bands, "best": best}


def band_table(rows: Sequence[dict[str, Any]], windows: Sequence[int]) -> list[str]:
    """One line per scene and order: D, then D after hazard reordering with each W; the best banded order
    (smallest D) of a scene is starred."""
    head = f"{'scene':<11}{'manifolds':>10}  {'order':<9}{'D':>9}" + "".join(f"{'W=' + str(w):>9}" for w in windows)
    lines = [head, "-" * len(head)]
    for r in rows:
        for name, band in r["bands"].items():
            star = "*" if name == r["best"] else ""
            lines.append(f"{r['scene']:<11}{r['manifolds']:>10}  {name + star:<9}{band['D']:>9,}"
                         + "".join(f"{band[f'W={w}']:>9,}" for w in windows))
    return lines


def best_band(row: dict[str, Any], window: int) -> int:
    """D of the scene's best banded order after the hazard reordering with window ``window``."""
    return row["bands"][row["best"]][f"W={window}"]


def budget_rows(row: dict[str, Any], platforms: Sequence[Platform], windows: dict[tuple[str, str], int],
                iters: int) -> list[ob.Budget]:
    """Budgets of the best banded schedule (after hazard reordering with the platform's W) of one scene."""
    periods = sorted({1, min(2, iters), iters})
    out = []
    for p in platforms:
        for f in FORMATS:
            band = best_band(row, windows[p.name, f.name])
            for period in periods:
                for resident in (True, False):
                    out.append(ob.budget(p, f, row["bodies"], row["manifolds"], band, trailing=2 * period - 1,
                                         impulses_resident=resident))
    return out


def budget_table(budgets: Sequence[ob.Budget]) -> list[str]:
    mib = 1 << 20
    head = (f"{'platform':<9}{'format':<7}{'D':>7}{'trailing':>9}  {'impulses':<9}{'bodies MiB':>11}"
            f"{'impulses MiB':>13}{'window MiB':>11}{'total MiB':>10}{'capacity MiB':>13}  {'bytes':<7}"
            "whole kernel (resource model, 1 lane; band and margin at its pessimistic end)")
    lines = [head, "-" * len(head)]
    for b in budgets:
        lines.append(f"{b.platform.name:<9}{b.fmt.name:<7}{b.band:>7,}{b.trailing:>9}  "
                     f"{'resident' if b.impulses_resident else 'in window':<9}{b.body_bytes / mib:>11.3f}"
                     f"{b.impulse_bytes / mib:>13.3f}{b.window_bytes / mib:>11.3f}{b.total_bytes / mib:>10.3f}"
                     f"{b.platform.data_bytes / mib:>13.3f}  {'within' if b.fits else 'beyond':<7}"
                     f"{eb.short_band(budget_fit(b))}")
    return lines


def budget_fit(b: ob.Budget, lanes: int = 1) -> eb.BandVerdict | rm.NoEstimate:
    """The verdict with band of the window kernel a budget row describes (its ring and impulse placement)."""
    cfg = rm.window_config(b.fmt, b.num_bodies, b.num_manifolds, b.trailing * b.band + 2, lanes,
                           b.impulses_resident)
    return eb.band_or_reason(cfg, b.platform, choose_adders=True)  # a study: the adders the fit picks


def floor_rows(row: dict[str, Any], platforms: Sequence[Platform], windows: dict[tuple[str, str], int],
               iters: int) -> list[tuple[ob.Floors, ob.Budget | None, Platform, NumberFormat]]:
    """DDR and compute floors of the scene per platform, format, fetch period (0: every pass, today's kernel)
    and lanes, each with the on-chip budget of its window (impulses travelling with the records)."""
    out = []
    for p in platforms:
        for f in FORMATS:
            band = best_band(row, windows[p.name, f.name])
            for period in sorted({0, 1, min(2, iters), iters}):
                bud = None if period == 0 else ob.budget(p, f, row["bodies"], row["manifolds"], band,
                                                         trailing=2 * period - 1, impulses_resident=False)
                for lanes in (1, 2, 4):
                    fl = ob.floors(p, f, row["bodies"], row["manifolds"], iters, period, lanes,
                                   impulses_resident=period == 0)  # today's streaming kernel keeps them
                    out.append((fl, bud, p, f))
    return out


def floor_fit(fl: ob.Floors, bud: ob.Budget | None, p: Platform, f: NumberFormat, bodies: int,
              manifolds: int) -> str:
    """The on-chip bytes of a floor row's window, and the resource model's verdict of its whole kernel."""
    if bud is None:  # every pass streams its records: today's one-lane streaming kernel
        if fl.lanes > 1:
            return "- (lanes need the window kernel)"
        return "streaming kernel: " + eb.short_band(eb.band_or_reason(rm.KernelConfig(f, bodies, manifolds), p,
                                                                     choose_adders=True))
    return (f"{bud.total_bytes / (1 << 20):.2f} MiB {'within' if bud.fits else 'beyond'} the data bytes; kernel: "
            + eb.short_band(budget_fit(bud, fl.lanes)))


def floor_table(rows: Sequence[tuple[ob.Floors, ob.Budget | None, Platform, NumberFormat]], bodies: int,
                manifolds: int) -> list[str]:
    head = (f"{'platform':<9}{'format':<7}{'fetch':>14}{'lanes':>6}{'MB/step':>9}{'DDR c/mp':>9}{'compute c/mp':>13}"
            f"{'floor c/mp':>11}  {'bound':<8}window bytes and whole-kernel fit (resource model)")
    lines = [head, "-" * len(head)]
    for fl, bud, p, f in rows:
        fetch = "every pass" if fl.fetch_every == 0 else f"per {fl.fetch_every} iter"
        lines.append(f"{p.name:<9}{f.name:<7}{fetch:>14}{fl.lanes:>6}{fl.bytes_per_step / 1e6:>9.1f}"
                     f"{fl.ddr_cycles / fl.manifold_passes:>9.3f}{fl.compute_cycles / fl.manifold_passes:>13.3f}"
                     f"{fl.cycles_per_manifold_pass:>11.3f}  {fl.bound:<8}"
                     f"{floor_fit(fl, bud, p, f, bodies, manifolds)}")
    return lines


def run(args: argparse.Namespace) -> dict[str, Any]:
    names = [s.strip() for s in args.scenes.split(",") if s.strip()]
    unknown = [s for s in names + [args.budget_scene] if s not in scenes.SCENES]
    if unknown or args.iters < 1:
        raise ValueError(f"unknown scene {unknown[0]!r}" if unknown else f"ITERS must be >= 1, got {args.iters}")
    if args.budget_scene not in names:
        names.append(args.budget_scene)
    platforms = list(PLATFORMS.values())
    windows = hazard_windows(platforms)
    distinct = sorted(set(windows.values()))
    t0 = time.perf_counter()
    rows = []
    for scene in names:
        t = time.perf_counter()
        rows.append(scene_bands(scene, args.seed, distinct))
        rows[-1]["seconds"] = round(time.perf_counter() - t, 2)
        print(f"{scene}: {rows[-1]['manifolds']} manifolds ({rows[-1]['seconds']} s)", file=sys.stderr, flush=True)
    budget_row = next(r for r in rows if r["scene"] == args.budget_scene)
    budgets = budget_rows(budget_row, platforms, windows, args.iters)
    print("band width D (slots) per order, and after the hazard reordering with window W (the kernel's: "
          + ", ".join(f"{p} {f} {w}" for (p, f), w in windows.items()) + "); * = the best banded order")
    print("\n".join(band_table(rows, distinct)))
    print(f"\non-chip budget of {args.budget_scene} ({budget_row['bodies']} bodies, {budget_row['manifolds']} "
          f"manifolds), best banded order '{budget_row['best']}' after hazard reordering; trailing = passes over "
          f"the window (fetch once per {', '.join(str((t + 1) // 2) for t in sorted({b.trailing for b in budgets}))}"
          f" iterations); capacity = data bits of BRAM (+ UltraRAM)")
    print("\n".join(budget_table(budgets)))
    fl_rows = floor_rows(budget_row, platforms, windows, args.iters)
    print(f"\nfloors of {args.budget_scene} per manifold-pass (c/mp; {args.iters} iterations): records fetched every "
          "pass as streamed today, or a manifold's contact + friction record once per k iterations (packed, the "
          "impulses read and written with them), 1-4 manifold-passes issued per cycle; window = the budget of that "
          "fetch period's trailing window")
    print("\n".join(floor_table(fl_rows, budget_row["bodies"], budget_row["manifolds"])))
    seconds = time.perf_counter() - t0
    print(f"\nband of the resource estimate: {eb.band_basis()}")
    print(f"measured in {seconds:.1f} s")
    return {"seed": args.seed, "windows": {f"{p}/{f}": w for (p, f), w in windows.items()}, "scenes": rows,
            "budget": [{"platform": b.platform.name, "format": b.fmt.name, "D": b.band, "trailing": b.trailing,
                        "impulses_resident": b.impulses_resident, "body_bytes": b.body_bytes,
                        "impulse_bytes": b.impulse_bytes, "window_bytes": b.window_bytes,
                        "capacity_bytes": b.platform.data_bytes, "fits": b.fits,
                        "kernel_fit": eb.short_band(budget_fit(b))} for b in budgets],
            "floors": [{"platform": p.name, "format": f.name, "fetch_every": fl.fetch_every, "lanes": fl.lanes,
                        "bytes_per_step": fl.bytes_per_step, "ddr_cycles": fl.ddr_cycles,
                        "compute_cycles": fl.compute_cycles, "bound": fl.bound,
                        "cycles_per_manifold_pass": fl.cycles_per_manifold_pass,
                        "window_fits": None if bud is None else bud.fits} for fl, bud, p, f in fl_rows],
            "seconds": round(seconds, 1)}


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        figures = run(args)
    except (ValueError, FrameError, scenes.SceneError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"band-s{args.seed}.json"
    path.write_text(json.dumps(figures, indent=1, default=lambda v: v.item() if isinstance(v, np.generic) else v)
                    + "\n")
    print(f"figures: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
