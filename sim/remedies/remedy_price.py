"""The price of warm starting on one step: error against the exact reference after 1, 2, 4, 8 iterations, cold (the
thesis scheme) and warm, and the kernel cycles of each on the fitting design (``models/timing/cycle_model.py``).

A warm start needs the previous step's impulses. With ``--from-frames`` the priced step is the scene's captured
frame itself (the one ``make sim`` reports on; ``--seed 1``, the default, is ``make sim``'s), warm-started from our
float64 solve of the frame captured one step earlier (``--history K``: of a chain of the K frames before it, each
solved warm from the one before), so the exact reference cached beside that frame prices it.
Otherwise the step is captured through the closed loop (``models.closed_loop.loop``, warm remedy): pybullet's own solver
settles the scene for ``--settle`` steps, then our loop runs ``--steps`` steps warm-started in float64 (the first
from zeros), and its last step is priced (cached in ``build/frames/``, ``sim/remedies/remedy_step_cache.py``; its exact
reference is computed once). Either way the step is solved again in each format from the same bodies and
constraints (rounded once) cold (zeros) and warm (the carried impulses rounded and applied on the host), each
against ``models.exact.reference`` of that step (float64 inputs, as the exact reference requires: a rounded normal
is not an eigenvector of a rounded isotropic inertia and its spin-damping rows would be refused), cached beside the
frames (``models/exact/cache.py``).

The remedies: ``cold`` (the thesis scheme), ``warm`` (``--factor``, Bullet 2's 0.85) and, per ``--more-factors``
value f, ``warm<f>`` (the same matched impulses at factor f; 1 is Box2D's full warm start), each its own curve;
with ``--shock`` each warm remedy's shock variant ``<remedy>+shocklr`` (``models/golden/shock_propagation.py``: one
call, its last contact pass a linear shock pass with the frozen rows' impulses returned, in the step's ground-up layer
order, priced by the cycle model in that order), and ``<remedy>+shocklrh``, each layer pair of that order in the hazard
order of the format's window, each its own curve too.

Each format is solved and priced in ``make sim``'s hazard schedule with the format's window
(``sim.compile.kernel_build.default_window``) on the streaming kernel whose impulses travel with the records
(``IMPULSE_STORE=records``, ``KernelJob.impulses_travelling``): its first pass reads the host-given impulses, so the
cold and the warm step stream the same records, one cycle prediction for both (the model reads no impulse value).

    python -m sim.remedies.remedy_price --scene pile --settle 200 --steps 30 --format fp32,fp16 --plot
    docs/remedy_price_pile.png
    python -m sim.remedies.remedy_price --scene thesis --from-frames --format fp32,fp16 --plot
    docs/remedy_price_thesis.png
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from models.closed_loop.loop import Remedy, StepInput, run_closed_loop
from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.golden.contact_solver import (CONTACT_PASS, FRICTION_PASS, Impulses, SolverParams, run_pass,
                                          schedule_levels, solve)
from models.timing.cycle_model import predict_job
from models.timing.platforms import get_preset
from models.exact.phases import Budget
from models.exact.reference import ExactReference
from models.exact.assembly import ExactReferenceError
from models.exact.cache import cached_exact_reference
from models.formats.frame import Frame
from models.golden.integrator import IntegrationParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FLOAT64, Arithmetic, NumberFormat, parse_format
from models.scenes.frame_cache import FRAME_CACHE_DIR, load_or_capture
from models.scenes.scene_args import split_scene_args
from models.scenes.specs import DEFAULT_CAPTURE_STEP
from models.order.manifold_schedule import make_schedule
from models.exact.solution_error import solution_error
from models.golden.warm_start import (WARMSTART_FACTOR, ContactMemory, Contacts, apply_impulses, check_impulses,
                                      warm_start)
from sim.compile.kernel_build import default_window
from sim.remedies.remedy_step_cache import load_step, save_step, step_path

ERROR_KEYS = ("max |dv|", "median |dv|", "p99 |dv|", "max |dw|", "median |dw|", "p99 |dw|")


def capture(scene: str, settle: int, steps: int, iterations: int, factor: float, schedule: str = "hazard",
            seed: int = 0, **params: object) -> tuple[StepInput, dict[str, int]]:
    """The last of ``steps`` warm-started float64 closed-loop steps after ``settle`` pybullet steps, and the
    warm-start report of the run."""
    r = run_closed_loop(scene, steps, FLOAT64, iterations, schedule=schedule, settle_steps=settle, seed=seed,
                        remedy=Remedy("warm", factor), **params)
    return r.extra["last step"], r.extra["warm start"]


def cached_capture(cache_dir: Path, scene: str, settle: int, steps: int, iterations: int, factor: float,
                   schedule: str = "hazard", seed: int = 0,
                   **params: object) -> tuple[StepInput, dict[str, int], bool]:
    """:func:`capture` once per set of settings, cached in ``cache_dir``; (step, report, whether cached)."""
    settings = {"scene": scene, "settle": settle, "steps": steps, "iterations": iterations, "factor": factor,
                "schedule": schedule, "seed": seed, "params": {k: str(v) for k, v in sorted(params.items())}}
    path = step_path(cache_dir, settings)
    hit = load_step(path)
    if hit is not None:
        return hit[0], hit[1], True
    last, report = capture(scene, settle, steps, iterations, factor, schedule, seed, **params)
    if last.initial is not None:
        save_step(last, report, path)
    return last, report, False


def _frame_step(frame: Frame) -> tuple[BodyTable, ConstraintSet, Contacts]:
    """The float64 step of a captured frame, as ``make sim`` sets it up, and its contact points' identities."""
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    return bodies, cons, Contacts.of(frame.body_a, frame.body_b, frame.num_points, frame.point_on_a, bodies)


def capture_from_frames(scene: str, step: int | None, iterations: int, factor: float,
                        cache_dir: Path = FRAME_CACHE_DIR, seed: int = 1, history: int = 1,
                        **params: object) -> tuple[StepInput, dict[str, int]]:
    """The scene's captured frame at ``step`` (None: its default capture step, the one ``make sim`` prices),
    warm-started from our float64 solves (``iterations``, hazard order) of the ``history`` frames captured before
    it, each warm-started from the one before it (the first from zeros): the last solve's accumulated impulses
    are the memory (``ContactMemory``), matched to the frame's points as Bullet matches them. Every frame comes
    from the frame cache (``load_or_capture``), so the priced step is the very frame ``make sim`` reports on, and
    its exact reference is the one cached beside it. The report is the priced frame's matching."""
    step = DEFAULT_CAPTURE_STEP.get(scene, 1) if step is None else step
    if history < 1 or step - history < 1:
        raise ValueError(f"step {step} has no {history} earlier step(s) to warm start from")
    memory: ContactMemory | None = None
    for s in range(step - history, step):
        bodies, cons, contacts = _frame_step(load_or_capture(scene, step=s, seed=seed, cache_dir=cache_dir, **params))
        order = make_schedule("hazard", cons, bodies.dynamic)
        initial = None if memory is None else warm_start(memory, contacts, cons, SolverParams().friction_coeff,
                                                         factor).impulses
        start = bodies if initial is None else apply_impulses(bodies, cons, initial, FLOAT64)
        solved = solve(start, cons, order, FLOAT64, SolverParams(iterations=iterations), initial=initial)
        memory = ContactMemory.of(contacts, cons, solved.impulses)
    bodies, cons, contacts = _frame_step(load_or_capture(scene, step=step, seed=seed, cache_dir=cache_dir, **params))
    ws = warm_start(memory, contacts, cons, SolverParams().friction_coeff, factor)
    order = make_schedule("hazard", cons, bodies.dynamic)
    return StepInput(bodies, cons, order, ws.impulses), ws.report.as_dict()


def solve_series(bodies: BodyTable, cons: ConstraintSet, schedule: np.ndarray, ar: Arithmetic,
                 iters: Sequence[int], initial: Impulses | None = None) -> dict[int, BodyTable]:
    """Per iteration count, the bodies ``models.golden.contact_solver.solve`` returns with that many iterations (the
    thesis scheme: every contact pass, then every friction pass), bit for bit, sharing the contact passes: the
    state after k contact passes is kept for each k in ``iters`` and its k friction passes run from it."""
    params = SolverParams(iterations=max(iters))
    if params.interleaved:
        raise ValueError("solve_series shares the contact passes of the thesis scheme (not interleaved)")
    levels = schedule_levels(schedule, cons, bodies.dynamic)
    out = bodies.copy()
    imp = Impulses.zeros(cons.num_manifolds) if initial is None else initial.copy()
    after: dict[int, tuple[BodyTable, Impulses]] = {}
    for it in range(max(iters)):
        run_pass(out, imp, cons, levels, ar, CONTACT_PASS, it, params, schedule)
        if it + 1 in iters:
            after[it + 1] = (out.copy(), imp.copy())
    for k, (state, state_imp) in after.items():
        for it in range(k):
            run_pass(state, state_imp, cons, levels, ar, FRICTION_PASS, it, params, schedule)
    return {k: state for k, (state, _) in after.items()}


SHOCK_SUFFIX = "+shocklr"  # a warm remedy's shock variant: one call, its last contact pass a linear shock pass
SHOCK_HAZARD_SUFFIX = "+shocklrh"  # the same, each layer pair in the hazard order of the format's window


def shock_job(fmt: NumberFormat, bodies: BodyTable, cons: ConstraintSet, order: np.ndarray,
              iterations: int, window: int = 0) -> KernelJob:
    """The step as one call of ``iterations`` whose last contact pass is a linear shock pass, its frozen rows'
    impulses returned (``models/golden/shock_propagation.py``; the ground-up layer order of the step, with ``window`` > 0
    each layer pair in the hazard order of that window), on the streaming kernel with the impulses in the records."""
    job = KernelJob(fmt, bodies, cons, order, SolverParams(iterations=iterations), IntegrationParams())
    return job.impulses_travelling(None).shocked(linear=True, impulses="return", window=window)


def price(last: StepInput, fmt: NumberFormat, iters: Sequence[int], ref: ExactReference,
          preset: str = "zcu102", warm: dict[str, float] | None = None, shock: bool = False) -> list[dict[str, Any]]:
    """Per remedy (cold, then each of ``warm``: name -> scale of the captured warm start, default ``{"warm": 1}``;
    with ``shock`` each warm remedy's :func:`shock_job` too, named with :data:`SHOCK_SUFFIX`, and with
    :data:`SHOCK_HAZARD_SUFFIX` in the hazard order of the format's window within each layer pair) and iteration count:
    max, median and p99 |dv| (m/s) and |dw| (rad/s) against the exact reference ``ref`` of the step, and the kernel
    cycles of the step on the streaming kernel with the impulses in the records (per step and per manifold-pass), in
    ``fmt``'s hazard schedule (a shock remedy: its layer order). The cycle model reads no impulse value (the records
    are the same bytes, zeros or a warm start), so one prediction prices every remedy of one order."""
    if last.initial is None:
        raise ValueError("the captured step carries no warm-start impulses (the loop ran cold)")
    check_impulses(last.initial, last.cons)  # wrong count, NaN/Inf, negative: refused before any solve
    dma = get_preset(preset)
    dyn = last.bodies.dynamic
    bodies, cons = last.bodies.rounded(fmt), last.cons.rounded(fmt)
    window = default_window(fmt, dma.stream_bits)
    order = make_schedule("hazard", cons, dyn, window)
    solved = {"cold": solve_series(bodies, cons, order, fmt, iters)}
    variants = {SHOCK_SUFFIX: 0, SHOCK_HAZARD_SUFFIX: window} if shock else {}
    shocked = {(suffix, it): shock_job(fmt, bodies, cons, order, it, w) for suffix, w in variants.items()
               for it in iters}
    for name, scale in ({"warm": 1.0} if warm is None else warm).items():
        if not 0.0 < scale or not np.isfinite(scale):
            raise ValueError(f"remedy {name}: the warm start's scale must be positive and finite, got {scale}")
        initial = Impulses(fmt.round(scale * last.initial.normal), fmt.round(scale * last.initial.friction))
        start = apply_impulses(bodies, cons, initial, fmt)
        solved[name] = solve_series(start, cons, order, fmt, iters, initial)
        for suffix in variants:
            solved[name + suffix] = {it: solve(start, j.cons, j.schedule, fmt, j.params, initial=initial).bodies
                                     for (s, it), j in shocked.items() if s == suffix}
    rows = []
    for it in sorted(set(iters)):
        job = KernelJob(fmt, bodies, cons, order, SolverParams(iterations=it), IntegrationParams())
        job.impulses_travelling(initial)  # the warm step is a valid job of this design (values of fmt, finite)
        hazard_cycles = predict_job(job.impulses_travelling(None), dma).cycles
        shock_cycles = {suffix: predict_job(shocked[suffix, it], dma).cycles for suffix in variants}
        for remedy in solved:
            cycles = next((c for suffix, c in shock_cycles.items() if remedy.endswith(suffix)), hazard_cycles)
            e = solution_error(solved[remedy][it], ref.bodies, dyn)
            rows.append({"format": fmt.name, "remedy": remedy, "iterations": it,
                         **dict(zip(ERROR_KEYS, (e.max_dv, e.median_dv, e.p99_dv, e.max_dw, e.median_dw, e.p99_dw))),
                         "cycles": cycles, "cycles per manifold-pass": cycles / (2 * it * cons.num_manifolds)})
    return rows


def verdict(rows: Sequence[dict[str, Any]], warm_iters: int = 4, cold_iters: int = 8) -> list[str]:
    """Per format and warm remedy: ``warm_iters`` iterations' errors against cold ``cold_iters``', the cycle ratios,
    and whether the target holds (a lower max |dv| at no more than 5% extra cycles over cold ``warm_iters``)."""
    out = []
    for fmt, remedy in dict.fromkeys((r["format"], r["remedy"]) for r in rows if r["remedy"] != "cold"):
        pick = {(r["remedy"], r["iterations"]): r for r in rows if r["format"] == fmt}
        w, c, c_same = (pick.get(k) for k in ((remedy, warm_iters), ("cold", cold_iters), ("cold", warm_iters)))
        if w is None or c is None or c_same is None:
            continue
        lower = [k for k in ERROR_KEYS if w[k] < c[k]]
        met = w["max |dv|"] < c["max |dv|"] and w["cycles"] <= 1.05 * c_same["cycles"]
        out.append(f"{fmt}: {remedy} {warm_iters} max |dv| {w['max |dv|']:.4g} against cold {cold_iters} "
                   f"{c['max |dv|']:.4g} m/s (median {w['median |dv|']:.3g} / {c['median |dv|']:.3g}, p99 "
                   f"{w['p99 |dv|']:.3g} / {c['p99 |dv|']:.3g}); lower in {len(lower)} of {len(ERROR_KEYS)} "
                   f"({', '.join(lower) or 'none'}); cycles {remedy} {warm_iters} / cold {warm_iters} "
                   f"{w['cycles'] / c_same['cycles']:.4f}, {remedy} {warm_iters} / cold {cold_iters} "
                   f"{w['cycles'] / c['cycles']:.4f}: target (max |dv|, <= 5% extra cycles) "
                   f"{'MET' if met else 'MISSED'}")
    return out


def plot_price(rows: Sequence[dict[str, Any]], path: Path, title: str) -> None:
    """Kernel cycles against max |dv| from the exact reference, one curve per remedy and format (points labelled
    with their iterations); written atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    for (fmt, remedy) in dict.fromkeys((r["format"], r["remedy"]) for r in rows):
        pts = sorted((r["cycles"], r["max |dv|"], r["iterations"]) for r in rows
                     if r["format"] == fmt and r["remedy"] == remedy)
        x, y = [p[0] for p in pts], [p[1] for p in pts]
        label = f"{remedy}{' (thesis scheme)' if remedy == 'cold' else ''}, {fmt}"
        ax.plot(x, y, "-o" if remedy == "cold" else "--s", label=label)
        for cx, cy, it in pts:
            ax.annotate(f"{it}", (cx, cy), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("kernel cycles per step (cycle model, impulses in the records, zcu102)")
    ax.set_ylabel("max |dv| against the exact reference (m/s)")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".tmp" + path.suffix)
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def _table(rows: Sequence[dict[str, Any]]) -> str:
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|---" * len(keys) + "|"]
    for r in rows:
        lines.append("| " + " | ".join(f"{r[k]:.4g}" if isinstance(r[k], float) else
                                       f"{r[k]:,}" if isinstance(r[k], int) else str(r[k]) for k in keys) + " |")
    return "\n".join(lines)


def _parse(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.remedies.remedy_price", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="pile")
    ap.add_argument("--scene-args", default="", help='scene parameters, "key=value ..." (as SCENE_ARGS)')
    ap.add_argument("--seed", type=int, default=1, help="scene seed (1: the frames make sim uses)")
    ap.add_argument("--settle", type=int, default=39, help="pybullet steps first (the pile's capture step is 40)")
    ap.add_argument("--steps", type=int, default=2, help="warm-started closed-loop steps; the last one is priced")
    ap.add_argument("--format", default="fp32", help="number formats, comma separated (fp32,fp16)")
    ap.add_argument("--loop-iters", type=int, default=4, help="iterations of the loop's steps before the priced one")
    ap.add_argument("--iters", default="1,2,4,8")
    ap.add_argument("--factor", type=float, default=WARMSTART_FACTOR, help="the warm start's factor (remedy warm)")
    ap.add_argument("--more-factors", default="", help="further warm-start factors priced as remedies warm<f>, "
                                                       "comma separated (e.g. 1.0: Box2D's full warm start)")
    ap.add_argument("--schedule", default="hazard", help="the loop's manifold order (models/order/manifold_schedule.py)")
    ap.add_argument("--preset", default="zcu102", help="DMA preset of the cycle model (models/timing/platforms.py)")
    ap.add_argument("--exact-budget", type=float, default=600.0, help="seconds allowed for the exact reference")
    ap.add_argument("--cache-dir", default=str(FRAME_CACHE_DIR), help="where the step and its exact reference are "
                                                                      "cached")
    ap.add_argument("--from-frames", action="store_true",
                    help="price the scene's captured frame (--step; default its capture step), warm-started from our "
                         "solve of the frame one step earlier (--settle and --steps unused)")
    ap.add_argument("--step", type=int, default=None, help="with --from-frames: the captured step priced")
    ap.add_argument("--history", type=int, default=1, help="with --from-frames: frames solved before it, each "
                                                          "warm-started from the one before")
    ap.add_argument("--shock", action="store_true",
                    help=f"price each warm remedy's shock variants too (<remedy>{SHOCK_SUFFIX}: one call, its last "
                         "contact pass a linear shock pass, in the step's ground-up layer order; "
                         f"<remedy>{SHOCK_HAZARD_SUFFIX}: each layer pair in the hazard order)")
    ap.add_argument("--plot", default="", help="write the speed-against-error plot (PNG) here")
    return ap.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = _parse(argv)
    try:
        iters = [int(x) for x in args.iters.split(",") if x.strip()]
        fmts = [parse_format(x.strip()) for x in args.format.split(",") if x.strip()]
        params = split_scene_args(args.scene_args)
        more = [float(x) for x in args.more_factors.split(",") if x.strip()]
        if not 0.0 < args.factor <= 1.0 or any(not 0.0 < f <= 1.0 for f in more):
            raise ValueError(f"warm-start factors must be in (0, 1], got {args.factor} and {more}")
        get_preset(args.preset)
        if args.steps < 2 or not iters or min(iters) < 1 or not fmts:
            raise ValueError("--steps must be >= 2 (a warm start needs a previous step), iterations >= 1, and a "
                             "format given")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    t0, c0 = time.perf_counter(), os.times()
    if args.from_frames:
        try:
            last, report = capture_from_frames(args.scene, args.step, args.loop_iters, args.factor,
                                               Path(args.cache_dir), args.seed, args.history, **params)
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        how = f"the captured frame of step {args.step or DEFAULT_CAPTURE_STEP.get(args.scene, 1)}, warm-started " \
              f"from our solves of the {args.history} step(s) before"
    else:
        last, report, cached = cached_capture(Path(args.cache_dir), args.scene, args.settle, args.steps,
                                              args.loop_iters, args.factor, args.schedule, args.seed, **params)
        how = f"closed-loop step {'from the cache' if cached else 'captured'}"
    print(f"{args.scene}: {last.bodies.num_bodies} bodies, {last.cons.num_manifolds} manifolds, warm start factor "
          f"{args.factor}; {how} ({time.perf_counter() - t0:.0f} s)", flush=True)
    print("warm-start matching (over the loop's steps in closed-loop mode): "
          + ", ".join(f"{k} {v:,}" for k, v in report.items()), flush=True)
    try:
        if last.initial is None:
            raise ValueError("the captured step carries no warm-start impulses (the loop ran cold)")
        check_impulses(last.initial, last.cons)  # before the exact reference: bad input costs no solve
        ref, ref_path, hit = cached_exact_reference(last.bodies, last.cons, args.cache_dir, SolverParams(),
                                                    Budget(time_s=args.exact_budget))
        warm = {"warm": 1.0, **{f"warm{f:g}": f / args.factor for f in more}}  # scales of the captured start
        rows = [r for fmt in fmts for r in price(last, fmt, iters, ref, args.preset, warm, args.shock)]
    except (ExactReferenceError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"exact reference {ref_path} ({'cached' if hit else 'computed'}; {ref.solver}; "
          f"{ref.seconds.get('total', 0.0):.0f} s)")
    print(_table(rows))
    for line in verdict(rows):
        print(line)
    if args.plot:
        plot_price(rows, Path(args.plot), f"{args.scene} ({last.bodies.num_bodies:,} bodies, "
                                          f"{last.cons.num_manifolds:,} manifolds): cold and warm, 1..{max(iters)} "
                                          "iterations")
        print(f"plot: {args.plot}")
    c1 = os.times()
    cpu = c1.user + c1.system + c1.children_user + c1.children_system - (c0.user + c0.system + c0.children_user
                                                                          + c0.children_system)
    print(f"({time.perf_counter() - t0:.0f} s wall, {cpu:.0f} CPU-s, load {os.getloadavg()[0]:.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
