"""``make sweep``: kernel time against error, over iteration counts and number formats, on one scene.

For every format and iteration count the RTL kernel runs the step in Verilator (``sim.drive.kernel_step``, DMA preset
bandwidth model, trace and body-out compared bit for bit with the golden model) and the kernel's result is
compared with the exact limit of the scheme on the same frame (``models/exact/reference.py``, cached beside the
frame; it depends on no format or schedule, so the driver computes it once and sends it with the points;
``sim/compare/exact_error.py``: per-body |dv| and |dw|, max, median and p99; without an exact reference those columns
say ``no exact reference`` and why, and the plot has no points). ``--mode model`` replaces the RTL run by the cycle
model's cycles (``models/timing/cycle_model.py``) and the golden model's numbers (bit-identical to the kernel's): no
Verilator, directory ``build/sweep/<scene>-<dma>-model/``.

Every (format, iteration count) is a point (:class:`SweepPoint`) run on ``--executor`` (``sim/parallel/executor.py``:
``local:1`` by default, ``local:N``, ``dask:local:N``, ``dask:tcp://host:port``; ``docs/cluster.md``): the workers
get the frame by its hash and return rows, not the kernel runs' files (those stay in a temporary directory). Each
finished point is appended to ``build/sweep/.points/<sweep>.jsonl``; after a failed point (reported with the command
that reruns it alone, into ``build/sweep/alone/``) the same command resumes from the finished ones. The costliest
points (the most iterations) start first, so that no large point is left to run alone at the end.

Writes ``sweep.csv`` and ``sweep.png`` into ``build/sweep/<scene>-<dma>/``: time per manifold-pass (ns at the
preset's clock, so that scenes of any size and the thesis's figures share one axis) against the maximum velocity
error, with the thesis's ZCU102 fp32/fp16 designs and its GPU and CPU figures marked as vertical lines (their error
on our frame is unknown: the thesis did not measure it).

``--record-window N`` (with ``--lanes L``, ``--fetch-passes``, ``--body-bits``) sweeps the window kernel
(``rtl/pgs_window.sv``) instead of the streaming one; its points are labelled ``<format> window xL`` and go to
``build/sweep/<scene>-<dma>-ring<N>[-lanes<L>][-body<B>]/`` (the options ``make sim`` names its runs by).

``--impulse-stores onchip,records`` (``make sweep IMPULSE_STORES=onchip,records``) sweeps several designs of the
streaming kernel in one run: the accumulated impulses in the on-chip RAM, or travelling with the records through
DDR (``IMPULSE_STORE=records`` of ``make sim``); the ``design`` column names each row's, and every row says whether
that design fits its platform at the pessimistic end of the estimate's band (``fits``; ``fit``: the verdict with the
binding resource's band and margin, ``sim/fit/estimate_band.py``; the plots draw a design that does not fit hollow),
and its timing estimate (``timing``: ``sim/fit/timing_estimate.py``; ``clock_mhz`` the clock it supports, at most the
preset's, and ``ms_at_estimated_clock`` the step's latency at that clock). Both designs solve the same step (bit for bit); their cycles and resources differ.

The golden model's steps are computed once per format for all iteration counts (``models/golden/iteration_ladder.py``:
one contact run with a snapshot at each count, a friction phase from each, bit-identical to separate runs), and the
float64 steps once per schedule; a worker keeps them for the next point of the same format, so that ``--executor
local:1`` (the default) solves each format's ladder once. The cycle model runs per (design, format, iterations): its
cycles depend on the format's record widths and the design's streams, not on the values.

The sweep also writes ``pareto.png`` and ``pareto.txt`` (``sim/report/pareto_front.py``): cycles per manifold-pass
against the error from the exact reference, the fitting designs' front drawn as a line, the thesis's two designs on the
same axes (their published cycles, our golden model's error at their format and 4 iterations), and by how much the front
dominates them; on the thesis frame (147,485 manifolds) the two frames are of the same kind.

``--frame FILE`` sweeps a saved frame (``models.formats.frame.save``) instead of the scene's. Bad input (an unknown
scene, format or DMA preset, bad iteration counts, a corrupt, truncated or other-version frame file) ends the sweep with
one line ``error: ...`` and exit status 2, and the sweep directory appears only once complete
(``sim.report.run_report.StagedDirectory``): a failed sweep leaves nothing behind.

The csv's error columns (per dynamic body, |dv| the norm of the linear velocity difference in m/s, |dw| that of the
angular one in rad/s, absolute, not normalised): ``*_vs_exact`` the kernel's step against the exact limit;
``max_dv_rounding`` / ``max_dw_rounding`` the kernel's step against float64 with the same schedule and passes (the
format's rounding alone); ``max_d*_iteration`` that float64 step against the exact limit (the iteration
error alone). The plot draws the three per format, so each format's curve shows where its rounding floor meets
the iteration error (marked with a star where the rounding error first reaches it).

    python -m sim.sweep --scene pile --formats fp32,fp16,bf16,auto --iters 1,2,4,8,16,32,64,128
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import hashlib
import json
import shlex
import sys
import tempfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from models import scenes
from models.timing import cycle_model
from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.golden.contact_solver import SolverParams
from models.timing.platforms import PRESETS, get_preset
from models.formats.frame import FrameError
from models.golden.integrator import IntegrationParams
from models.formats.number_format import FLOAT64
from models.kernel.kernel_job import KernelJob
from models.scenes.frame_cache import FRAME_CACHE_DIR
from models.order.manifold_schedule import SCHEDULE_KINDS, make_schedule
from models.exact.solution_error import SolutionError, solution_error
from sim.compare import exact_error
from models.sizing.format_analyzer import auto_format
from sim.compile.artefacts import FrameStore, KernelStore, frame_bytes, kernel_store_root, source_digest
from sim.parallel.executor import ExecutorSpec, PointsFailed, Workers, parse_executor, run_points
from sim.drive.harness_run import KernelRunError, write_inputs
from models.golden.iteration_ladder import solve_ladder
from sim.compile.kernel_build import KernelBuild, default_window, use_kernel_store
from sim.drive.kernel_step import run_kernel_step
from sim.parallel.point_results import PointLog
from sim.compare.trace_bits import kernel_bodies
from sim.report.run_report import StagedDirectory
from sim.fit.estimate_band import BandVerdict, kernel_band, short_band
from sim.fit.timing_estimate import TimingVerdict, clock_note, kernel_timing
from sim.compare.exact_error import NoExactReference
from sim.report.sweep_plot import series, write_plots
from sim.drive.run_options import (add_kernel_args, check_kernel_args, hardware_format, kernel_job, kernel_label,
                                   load_frame)
from sim.report.run_result import velocity_error
from models.kernel import record_window

ITERATIONS = (1, 2, 4, 8, 16, 32, 64, 128)  # to 128: the pile's iteration error has stopped falling by 32
IMPULSE_STORES = ("onchip", "records")  # the streaming kernel's designs (make sim's IMPULSE_STORE)
COLUMNS = ["format", "design", "iterations", "mode", "manifolds", "manifold_passes", "cycles", "cycles_per_manifold_pass",
           "ms_at_clock", "ns_per_manifold_pass", "stalls", "bubbles", "bytes_streamed", "differing_bits",
           "max_dv_vs_exact", "max_dw_vs_exact", "median_dv_vs_exact", "p99_dv_vs_exact", "median_dw_vs_exact",
           "p99_dw_vs_exact", "max_dv_vs_float64_same_iters", "max_dv_rounding", "max_dw_rounding",
           "max_dv_iteration", "max_dw_iteration", "fits", "fit", "timing", "clock_mhz", "ms_at_estimated_clock"]


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.sweep", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="pile",
                    help=f"scene name ({', '.join(sorted([*scenes.SCENES, *scenes.ASSET_SCENES]))}), a world file "
                         "(.py) or a URDF file, as for sim.run")
    ap.add_argument("--scene-args", default="", help='scene parameters, e.g. "nx=20 ny=5 nz=20 friction=0.4"')
    ap.add_argument("--frame", default="", help="a frame file (.npz, models.formats.frame.save) to sweep instead of --scene")
    ap.add_argument("--formats", default="fp32,fp16,bf16",
                    help="comma-separated number formats (fp32, fp16, bf16, eXmY, auto: the analyzer's choice)")
    ap.add_argument("--iters", default=",".join(map(str, ITERATIONS)), help="comma-separated iteration counts")
    ap.add_argument("--dma", default="zcu102", help=f"DMA preset ({', '.join(PRESETS)})")
    ap.add_argument("--seed", type=int, default=1, help="scene seed")
    exact_error.add_exact_args(ap)
    ap.add_argument("--mode", choices=("rtl", "model"), default="rtl",
                    help="rtl: every point on the RTL kernel in Verilator; model: the cycle model's cycles and the "
                         "golden model's numbers (no Verilator)")
    ap.add_argument("--executor", default="local:1",
                    help="where the points run: local:N (N processes), dask:local:N (a Dask LocalCluster), "
                         "dask:tcp://host:port (a Dask scheduler); sim/parallel/executor.py")
    add_kernel_args(ap)
    ap.add_argument("--impulse-stores", default="",
                    help="comma-separated designs of the streaming kernel to sweep, each a point of its own: onchip "
                         "(the impulse RAM), records (impulses travelling with the records); default: --impulse-store")
    ap.add_argument("--schedule", default="hazard", choices=SCHEDULE_KINDS,
                    help="the manifold order of every point (the window kernel's rows: sweep, a banded order)")
    ap.add_argument("--out", default="build/sweep", help="parent directory of the sweep directory")
    ap.add_argument("--replot", default="",
                    help="a finished sweep's directory: draw its sweep.png, pareto.png and pareto.txt again from its "
                         "sweep.csv (no point runs)")
    return ap.parse_args(argv)


def _int_list(text: str, name: str) -> list[int]:
    try:
        values = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"{name} must be comma-separated integers, got {text!r}") from None
    if not values or min(values) < 1:
        raise ValueError(f"{name} must be positive integers, got {text!r}")
    return values


# where a point's command (run alone) writes: beside the sweep's own directory and results file, never over them
ALONE_DIR = "build/sweep/alone"


# the fields a point's key leaves out at these values: the keys of sweeps made before each field existed
KEY_DEFAULTS: dict[str, Any] = {"impulse_store": "onchip", "schedule": "hazard", "add_dsp": 0, "inertia": "build"}


@dataclass(frozen=True)
class SweepPoint:
    """One point of the sweep (a format, an iteration count, rtl or the cycle model), run by ``sim.parallel.executor``:
    the frame travels by its hash (``sim.compile.artefacts.FrameStore``), the row comes back."""

    frame: str  # the frame file's sha256
    source: tuple[str, ...]  # the options that name the frame: --scene/--seed or --frame
    fmt: str
    how: str  # "auto": chosen by the analyzer
    iterations: int
    mode: str  # "rtl" or "model"
    dma: str
    seed: int
    exact_budget: float
    record_window: int
    fetch_passes: int
    lanes: int
    body_bits: int
    sources: str  # sim.compile.artefacts.source_digest() when planned
    impulse_store: str = "onchip"  # the kernel's design: "onchip" or "records"
    schedule: str = "hazard"  # the manifold order (models.order.manifold_schedule; the window kernel's rows: sweep)
    # every iteration count of the sweep: the worker solves them in one ladder (models/golden/iteration_ladder.py) and
    # keeps it for the other points of the format; the rows do not depend on it (bit-identical), so the key leaves it
    # out
    ladder: tuple[int, ...] = dataclasses.field(default=(), compare=False)
    # the format's rank in the sweep (the first format highest): its points run one format after the other
    rank: int = dataclasses.field(default=0, compare=False)
    add_dsp: int = 0  # the adders' form (--add-dsp: 1 in DSP48E2s): the same cycles and bits, the fit's figures
    inertia: str = "build"  # the body record's inverse-inertia words (--inertia: "scene" as few as the scene needs)
    # the frame's exact reference, computed once by the driver (None: the worker computes it)
    exact: exact_error.AnyExactStep | None = dataclasses.field(default=None, compare=False)

    @property
    def key(self) -> str:
        desc = {k: v for k, v in dataclasses.asdict(self).items() if k not in ("exact", "ladder", "rank")}
        for name, default in KEY_DEFAULTS.items():  # a field at its default keeps the key it had before the field
            if desc[name] == default:
                desc.pop(name)
        digest = hashlib.sha256(json.dumps(desc, sort_keys=True).encode()).hexdigest()[:12]
        design = "" if self.impulse_store == "onchip" else f"-{self.impulse_store}"
        return f"{self.fmt}{design}-it{self.iterations}-{self.mode}-{digest}"

    @property
    def cost(self) -> float:
        """Relative run time (``sim.parallel.executor`` starts the costliest first): the solver passes, plus a start;
        the format's rank first, so that a worker finishes one format's points (which share its golden ladder) before
        the next format's, and an interrupted sweep leaves whole formats done."""
        return self.rank * 1e6 + self.iterations + 1.0

    @property
    def command(self) -> str:
        return (f".venv/bin/python -m sim.sweep {shlex.join(self.source)} --formats {self.fmt} --iters {self.iterations}"
                f" --mode {self.mode} --dma {self.dma} --exact-budget {self.exact_budget:g}"
                f" --record-window {self.record_window} --fetch-passes {self.fetch_passes} --lanes {self.lanes}"
                f" --body-bits {self.body_bits} --impulse-stores {self.impulse_store} --schedule {self.schedule}"
                f" --add-dsp {self.add_dsp} --inertia {self.inertia} --out {ALONE_DIR}")

    def run(self) -> dict[str, Any]:
        use_kernel_store(KernelStore(kernel_store_root()))
        with tempfile.TemporaryDirectory(prefix="pgs-sweep-point-") as tmp:
            return sweep_row(self, Path(tmp))


@lru_cache(maxsize=4)
def _frame_setup(digest: str) -> tuple[BodyTable, ConstraintSet, IntegrationParams]:
    frame = FrameStore().get(digest)
    bodies = body_table(frame)
    return bodies, setup_constraints(frame, bodies), IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))


@lru_cache(maxsize=8)
def _schedule(digest: str, fmt_name: str, dma: str, kind: str = "hazard", window_kernel: bool = False) -> np.ndarray:
    bodies, cons, _ = _frame_setup(digest)
    return make_schedule(kind, cons, bodies.dynamic, default_window(hardware_format(fmt_name),
                                                                    get_preset(dma).stream_bits,
                                                                    window_kernel=window_kernel))


# the golden model's ladders this process holds: (frame, schedule, arithmetic, counts) -> final step per count
_LADDERS: dict[tuple[str, str, str, tuple[int, ...]], dict[int, BodyTable]] = {}
LADDERS_KEPT = 8  # each holds one body table per count (thesis frame: ~6 MB each)


def golden_finals(point: "SweepPoint", arithmetic: str) -> BodyTable:
    """The golden model's integrated step of ``point`` in ``arithmetic`` (the point's format, or "float64" on the
    unrounded frame) over the point's schedule, from the ladder of all the sweep's counts (computed once, kept)."""
    bodies, cons, ip = _frame_setup(point.frame)
    schedule = _schedule(point.frame, point.fmt, point.dma, point.schedule, point.record_window > 0)
    counts = tuple(sorted({*point.ladder, point.iterations}))
    key = (point.frame, hashlib.sha256(schedule.tobytes()).hexdigest(), arithmetic, counts)
    if key not in _LADDERS:
        if len(_LADDERS) >= LADDERS_KEPT:
            del _LADDERS[next(iter(_LADDERS))]
        fmt = FLOAT64 if arithmetic == "float64" else hardware_format(arithmetic)
        b, c = (bodies, cons) if fmt is FLOAT64 else (bodies.rounded(fmt), cons.rounded(fmt))
        _LADDERS[key] = solve_ladder(b, c, schedule, fmt, counts, ip)
    return _LADDERS[key][point.iterations]


@lru_cache(maxsize=2)
def frame_exact(digest: str, cache_dir: Path, budget: float) -> exact_error.AnyExactStep:
    """The exact reference of the frame ``digest`` (cached in ``cache_dir``), or why there is none: the driver's
    once per sweep, or a worker's that was sent none."""
    bodies, cons, ip = _frame_setup(digest)
    return exact_error.exact_step(bodies, cons, ip, cache_dir, budget)


def sweep_row(point: SweepPoint, run_dir: Path) -> dict[str, Any]:
    """The sweep's row of ``point``, the kernel run's files written into ``run_dir`` (and left there)."""
    preset = get_preset(point.dma)
    fmt = hardware_format(point.fmt)
    bodies, cons, ip = _frame_setup(point.frame)
    schedule = _schedule(point.frame, point.fmt, point.dma, point.schedule, point.record_window > 0)
    exact = point.exact if point.exact is not None else frame_exact(point.frame, FRAME_CACHE_DIR, point.exact_budget)
    dyn = bodies.dynamic
    params = SolverParams(iterations=point.iterations)
    job = kernel_job(KernelJob(fmt, bodies.rounded(fmt), cons.rounded(fmt), schedule, params, ip), point)
    kb = KernelBuild.for_job(job, preset, body_bits=point.body_bits)
    if point.mode == "model":  # the cycle model's cycles; the golden model's numbers (the kernel's, bit for bit)
        pred = cycle_model.predict_job(job, preset, body_bits=point.body_bits)
        cycles, stalls, bubbles, differing = pred.cycles, pred.stalls, pred.bubbles, ""
        streamed = model_stream_bytes(job, kb, run_dir)
        ours = golden_finals(point, point.fmt)
    else:
        res = run_kernel_step(job, preset, run_dir, point.seed, body_bits=point.body_bits)
        cycles, stalls, bubbles = res.cycles, int(res.registers["stalls"]), int(res.registers["bubbles"])
        streamed, differing = sum(res.stream_bytes.values()), res.comparison.differing_bits
        if not res.bit_exact:
            print(f"  NOT bit-exact: {res.comparison.first_mismatch}", flush=True)
        ours = kernel_bodies(run_dir, job, kb)
    ref_final = golden_finals(point, "float64")
    e_exact = exact_error.error_vs_exact(ours, exact, dyn)
    e_same = velocity_error(ours, ref_final.linear_velocity, ref_final.angular_velocity, dyn)
    e_rounding = solution_error(ours, ref_final, dyn)
    e_iteration = exact_error.error_vs_exact(ref_final, exact, dyn)
    mp = job.manifold_passes
    kernel = f" window x{point.lanes}" if point.record_window else ""
    return {"format": (f"{fmt.name} ({point.how})" if point.how else fmt.name) + kernel,
            "design": point.impulse_store, "iterations": point.iterations, "mode": point.mode, "manifolds": job.manifolds, "manifold_passes": mp,
            "cycles": cycles, "cycles_per_manifold_pass": cycles / mp, "ms_at_clock": cycles / preset.clock_hz * 1e3,
            "ns_per_manifold_pass": cycles / mp / preset.clock_hz * 1e9, "stalls": stalls, "bubbles": bubbles,
            "bytes_streamed": streamed, "differing_bits": differing,
            **exact_columns(e_exact), "max_dv_vs_float64_same_iters": e_same.max_dv,
            "max_dv_rounding": e_rounding.max_dv, "max_dw_rounding": e_rounding.max_dw,
            **float64_columns(e_iteration), **fit_columns(job, point.dma, point.body_bits),
            **timing_columns(job, point.dma, cycles, preset.clock_hz, point.body_bits)}


PER_PASS_STREAMS = ("constraints", "impulses_out")  # the streams write_inputs sizes that each pass streams again


def model_stream_bytes(job: KernelJob, kb: KernelBuild, run_dir: Path) -> int:
    """The bytes the kernel's step streams (MODE=model), from the input files of the same step with one iteration
    (``write_inputs``): each iteration streams the same contact and friction records (and impulse writes) once
    more (the window kernel: each fetch the same window records), the body streams once per step; ~1/N of writing
    the N-iteration files."""
    plan = job.record_window
    one = dataclasses.replace(job, params=dataclasses.replace(job.params, iterations=1),
                              record_window=plan and dataclasses.replace(plan, fetch_passes=1))  # a fetch per pass
    sizes = write_inputs(run_dir, one, kb)
    per, of_one = ((plan.fetches(job.params), one.record_window.fetches(one.params)) if plan and one.record_window
                   else (job.params.iterations, 1))
    return sum(v // of_one * per if k in PER_PASS_STREAMS else v for k, v in sizes.items())


def fit_columns(job: KernelJob, dma: str, body_bits: int = 128) -> dict[str, Any]:
    """Whether the point's kernel fits its DMA preset's platform at the pessimistic end of the estimate's band
    (sim.fit.estimate_band; "" without an estimate), with the shares and the band."""
    v = kernel_band(job, dma, body_bits)
    if isinstance(v, BandVerdict):
        return {"fits": v.fits, "fit": f"{v.headline()} ({v.shares_text()})"}
    return {"fits": "", "fit": short_band(v)}


def timing_columns(job: KernelJob, dma: str, cycles: int, preset_hz: float, body_bits: int = 128) -> dict[str, Any]:
    """The timing estimate of the point's kernel (sim.fit.timing_estimate) and its latency at the clock the estimate
    supports ("" without a platform)."""
    v = kernel_timing(job, dma, body_bits)
    if v is None:
        return {"timing": "", "clock_mhz": "", "ms_at_estimated_clock": ""}
    hz, _ = clock_note(v, preset_hz)
    text = v.headline() if isinstance(v, TimingVerdict) else f"no timing estimate ({v.reason})"
    return {"timing": text, "clock_mhz": round(hz / 1e6, 1), "ms_at_estimated_clock": cycles / hz * 1e3}


def exact_columns(e: SolutionError | NoExactReference) -> dict[str, Any]:
    """The csv's columns of the error against the exact reference (``no exact reference (reason)`` without one)."""
    if isinstance(e, NoExactReference):
        return {col: str(e) for col in COLUMNS if col.endswith("_vs_exact")}
    return {"max_dv_vs_exact": e.max_dv, "max_dw_vs_exact": e.max_dw, "median_dv_vs_exact": e.median_dv,
            "p99_dv_vs_exact": e.p99_dv, "median_dw_vs_exact": e.median_dw, "p99_dw_vs_exact": e.p99_dw}


def float64_columns(e: SolutionError | NoExactReference) -> dict[str, Any]:
    """The csv's columns of float64's error against the exact reference (the iteration error alone)."""
    if isinstance(e, NoExactReference):
        return {"max_dv_iteration": str(e), "max_dw_iteration": str(e)}
    return {"max_dv_iteration": e.max_dv, "max_dw_iteration": e.max_dw}


def _number(value: Any) -> str:
    return f"{value:.3e}" if isinstance(value, float) else str(value)


def plan(args: argparse.Namespace) -> tuple[list[SweepPoint], str, dict[str, bytes]]:
    """The sweep's points (formats x iteration counts), its name and the frame they need (hash -> bytes, also put
    into this process's frame store)."""
    get_preset(args.dma)
    names = [f.strip() for f in args.formats.split(",") if f.strip()]
    if not names:
        raise ValueError(f"FORMATS names no number format: {args.formats!r}")
    for name in names:  # checked before any work; auto is resolved once the frame is loaded
        if name.lower() != "auto":
            hardware_format(name)
    iter_list = _int_list(args.iters, "ITERS")
    if not args.exact_budget >= 0:
        raise ValueError(f"--exact-budget must be >= 0, got {args.exact_budget}")
    check_kernel_args(args)
    designs = impulse_stores(args)
    if args.record_window and args.fetch_passes and "records" in designs:  # fetches of one kind, every count
        for iters in iter_list:
            record_window.window_fetch_kinds(SolverParams(iters), args.fetch_passes, one_kind=True)
    frame, label = load_frame(args)
    print(frame.summary(), flush=True)
    data = frame_bytes(frame)
    digest = FrameStore().put(data)
    scene_args = ("--scene-args", args.scene_args) if args.scene_args else ()
    source = ("--frame", str(args.frame)) if args.frame else ("--scene", args.scene, *scene_args, "--seed",
                                                               str(args.seed))
    formats = [(auto_format(frame, 4), "auto") if n.lower() == "auto" else (hardware_format(n), "") for n in names]
    ladder = tuple(sorted(set(iter_list)))
    points = [SweepPoint(digest, source, fmt.name, how, iters, args.mode, args.dma, args.seed, args.exact_budget,
                         args.record_window, args.fetch_passes, args.lanes, args.body_bits, source_digest(), design,
                         args.schedule, ladder, len(formats) - rank, args.add_dsp, args.inertia)
              for rank, (fmt, how) in enumerate(formats) for design in designs for iters in iter_list]
    mode = "-model" if args.mode == "model" else ""
    kernel = kernel_label(argparse.Namespace(**{**vars(args), "impulse_store": "onchip"}))  # designs: below
    order = "" if args.schedule == "hazard" else f"-{args.schedule}"
    return points, f"{label}-{args.dma}{order}{kernel}{designs_label(designs)}{mode}", {digest: data}


def impulse_stores(args: argparse.Namespace) -> tuple[str, ...]:
    """The streaming kernel's designs the sweep runs (``--impulse-stores``, else ``--impulse-store``), checked."""
    text = args.impulse_stores or getattr(args, "impulse_store", "onchip")
    designs = tuple(dict.fromkeys(d.strip().lower() for d in text.split(",") if d.strip()))
    bad = [d for d in designs if d not in IMPULSE_STORES]
    if not designs or bad:
        raise ValueError(f"IMPULSE_STORES must be a comma-separated list of {', '.join(IMPULSE_STORES)}, got {text!r}")
    return designs


def designs_label(designs: tuple[str, ...]) -> str:
    """The designs in the sweep's name: none for the on-chip design alone (the name of a sweep before designs)."""
    if designs == ("onchip",):
        return ""
    return "-impulses-in-records" if designs == ("records",) else "-" + "-".join(designs)


def run_sweep(points: list[SweepPoint], exact: exact_error.AnyExactStep, spec: ExecutorSpec | Workers,
              log: PointLog | None, frames: dict[str, bytes], label: str) -> list[dict[str, Any]]:
    """The rows of ``points`` in order, each point sent with ``exact`` (the frame's exact reference, computed once
    by the driver); raises PointsFailed."""
    points = [dataclasses.replace(p, exact=exact) for p in points]
    if log is not None:  # a resumed sweep's ladders solve only the counts still to do
        points = remaining_ladders(points, set(log.load()))
    result = run_points(points, spec, log, frames, label=label, stream=sys.stdout)
    result.raise_on_failure()
    return result.ordered(points)


def remaining_ladders(points: list[SweepPoint], done: set[str]) -> list[SweepPoint]:
    """``points`` with each format's ladder cut to the iteration counts of its points not in ``done`` (the keys
    of finished points): a resumed sweep solves no count again that only finished points need."""
    todo: dict[str, set[int]] = {}
    for p in points:
        if p.key not in done:
            todo.setdefault(p.fmt, set()).add(p.iterations)
    return [dataclasses.replace(p, ladder=tuple(sorted(todo.get(p.fmt, {p.iterations})))) for p in points]


def sweep(args: argparse.Namespace, log_dir: Path) -> tuple[list[dict[str, Any]], str]:
    """The sweep's rows, its points run on ``args.executor`` and recorded in ``log_dir/<name>.jsonl`` (a rerun
    resumes from it); returns them and the sweep's name, or raises PointsFailed."""
    spec = parse_executor(args.executor)
    points, name, frames = plan(args)  # bad input ends the sweep here, before any worker starts
    exact = frame_exact(points[0].frame, exact_error.reference_dir(args), args.exact_budget)
    workers = Workers(spec)
    try:
        rows = run_sweep(points, exact, workers, PointLog(log_dir / f"{name}.jsonl"), frames, f"sweep {name}")
    finally:
        workers.close(wait=False)  # a LocalCluster closes while the csv and the plot are written
    for row in rows:
        print(f"{series(row):>6} {row['iterations']:>3} it ({row['mode']}): {row['cycles']:>9,} cycles "
              f"({row['cycles_per_manifold_pass']:.2f}/mp), max |dv| vs exact reference "
              f"{_number(row['max_dv_vs_exact'])} m/s, vs float64 same iterations {row['max_dv_vs_float64_same_iters']:.3e}, differing bits "
              f"{row['differing_bits'] if row['mode'] == 'rtl' else 'n/a (model)'}, {row.get('fit', '')}", flush=True)
    return rows, name


def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)


def _cell(text: str) -> Any:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def read_csv(path: Path) -> list[dict[str, Any]]:
    """The rows of a sweep's csv, numbers as numbers (an error column without an exact reference stays its text)."""
    with path.open(newline="") as f:
        return [{k: _cell(v) for k, v in row.items()} for row in csv.DictReader(f)]


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.replot:
        done = Path(args.replot)
        if not (done / "sweep.csv").is_file():
            print(f"error: --replot {done}: no sweep.csv there", file=sys.stderr)
            return 2
        print(write_plots(read_csv(done / "sweep.csv"), done, done.name))
        return 0
    log_dir = Path(args.out) / ".points"
    try:
        with StagedDirectory(Path(args.out)) as out:
            rows, name = sweep(args, log_dir)
            write_csv(rows, out.path / "sweep.csv")
            front_text = write_plots(rows, out.path, name)
            out_dir = out.commit(name)
    except PointsFailed as exc:
        first = exc.failures[0]
        more = (f" (and {len(exc.failures) - 1} more point(s); each with the command that reproduces it above)"
                if len(exc.failures) > 1 else "")
        print(f"error: {first.error.splitlines()[0] if first.error else first.key}{more}", file=sys.stderr)
        return 2
    except (ValueError, FrameError, KernelRunError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    PointLog(log_dir / f"{name}.jsonl").remove()
    if log_dir.is_dir() and not any(log_dir.iterdir()):
        log_dir.rmdir()
    print(f"\n{front_text}\n\nsweep: {out_dir / 'sweep.csv'}, {out_dir / 'sweep.png'}, {out_dir / 'pareto.png'} and "
          f"{out_dir / 'pareto.txt'}")
    return 0 if all(r["differing_bits"] == 0 for r in rows if r["mode"] == "rtl") else 1


if __name__ == "__main__":  # run the imported module: its points then pickle by reference (remote workers import it)
    from sim import sweep as sweep_module

    sys.exit(sweep_module.main())
