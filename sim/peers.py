"""``make peers``: the FPGA designs and the peers a user would pick instead, on one frame: time per step and error.

One table, each row a design, every figure on the same frame (the scene's busiest, as ``make sim`` captures it):

* **FPGA designs.** The thesis's two ZCU102 designs (``models/published/thesis.py``: their published cycles per
  manifold-pass times this frame's manifold-passes, at their clocks) and our fitting headline designs, the window
  kernel (``SCHEDULE=sweep RECORD_WINDOW=8192 IMPULSE_STORE=records BODY_BITS=256 ADD_DSP=1 INERTIA=scene``; fp32 one
  lane, fp16 two lanes): the cycle model's cycles (``models/timing/cycle_model.py``, exact against the RTL) at the ZCU102 preset's 275 MHz, the
  resource model's fit verdict (``sim/fit/resource_model.py``). Their error is the golden model's of their format and
  order (bit for bit the kernel's); the thesis designs' is ours in the hazard order (their error is not published).
* **CPU peers, measured here.** Bullet's batched GPU scheme written in Warp, on Warp's serial CPU path (1 thread:
  ``models/peers/warp_pgs.py``), its step checked word for word against the golden model run in the same order; and
  MuJoCo's PGS on the frame's boxes (``models/peers/mujoco_peer.py``; the constraint solver timed alone), run in a
  child process under a time and memory budget. On a frame of more than 1,000 bodies, MuJoCo also runs on growing
  blocks of it (100, 300, 1,000, 3,000, 10,000 bodies), to show how far it goes.
* **GPU peers**, where Warp sees a CUDA device: the same Warp kernels, kernel time and launch overhead apart.
* **Anchors**: published figures of other engines on their own scenes (``models/published/peers.py``), not measured
  here, scaled linearly to this frame's size where the scene is of the same kind (an extrapolation, marked as such).

Each row's error is against the exact limit of the scheme (``sim/compare/exact_error.py``: max |dv|, |dw| over dynamic
bodies), and its time is compared with the thesis fp32 design's and with the best measured peer's (ratios > 1:
faster). It writes ``peers.md``, ``peers.json`` and ``peers.png`` (time per step against error, FPGA designs and
peers on the same axes) into ``build/peers/<scene>/``.

    python -m sim.peers --scene thesis
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from models import scenes
from models.timing import cycle_model
from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.formats.frame import Frame, FrameError, load, save
from models.golden.integrator import IntegrationParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32, NumberFormat
from models.order.manifold_schedule import make_schedule
from models.exact.solution_error import SolutionError
from models.published.peers import PEER_ANCHORS
from models.published.thesis import THESIS_FPGA
from sim.compare import exact_error
from sim.compile.kernel_build import default_window
from sim.drive.kernel_step import golden_step
from sim.report.run_report import StagedDirectory
from sim.fit.resource_model import FitVerdict, kernel_fit, short_verdict
from sim.drive.run_options import load_frame
from sim.compare.exact_error import NoExactReference

REPO = Path(__file__).resolve().parents[1]
DMA = "zcu102"
RING = 8192
BODY_BITS = 256
MUJOCO_BLOCKS = (100, 300, 1000, 3000, 10000)  # the scaling study's block sizes (below the frame's own)
MUJOCO_BLOCKS_FROM = 1000  # frames with more dynamic bodies than this get the scaling study
CHILD_BASE_BYTES = 3 << 30  # the MuJoCo child's address space besides the arena (Python, numpy, the frame, the model)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.peers", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="pile", help="scene name, world file or URDF, as for sim.run")
    ap.add_argument("--scene-args", default="", help='scene parameters, e.g. "nx=20 ny=5 nz=20"')
    ap.add_argument("--frame", default="", help="a frame file (.npz) to run instead of --scene")
    ap.add_argument("--seed", type=int, default=1, help="scene seed")
    ap.add_argument("--iters", type=int, default=4, help="iterations of every design (Bullet GPU: 4)")
    ap.add_argument("--runs", type=int, default=7, help="timed runs of each measured peer (the median is reported)")
    exact_error.add_exact_args(ap)
    ap.add_argument("--mujoco-budget", type=float, default=600.0,
                    help="seconds allowed for each MuJoCo model (compile and steps, in a child process)")
    ap.add_argument("--mujoco-memory-gb", type=float, default=12.0, help="address-space cap of the MuJoCo child (GB)")
    ap.add_argument("--no-mujoco", action="store_true", help="leave MuJoCo out")
    ap.add_argument("--no-scaling", action="store_true", help="no MuJoCo scaling study on large frames")
    ap.add_argument("--out", default="build/peers", help="parent directory of the output directory")
    ap.add_argument("--mujoco-child", default="", help=argparse.SUPPRESS)  # internal: one MuJoCo point
    return ap.parse_args(argv)


def check_args(args: argparse.Namespace) -> None:
    for name, value, lo in (("--iters", args.iters, 1), ("--runs", args.runs, 1), ("--mujoco-budget",
                            args.mujoco_budget, 1), ("--mujoco-memory-gb", args.mujoco_memory_gb, 0.5),
                            ("--exact-budget", args.exact_budget, 0)):
        if not (math.isfinite(value) and value >= lo):
            raise ValueError(f"{name} must be >= {lo}, got {value}")


def machine() -> str:
    """This machine in words: CPU model, cores, OS, and its load as the figures are taken."""
    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load1, load5, _ = os.getloadavg()
    return (f"{model}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, Python "
            f"{platform.python_version()} (load average {load1:.1f} / {load5:.1f} at the start)")


# --- rows ------------------------------------------------------------------------------------------------------------
@dataclass
class Row:
    """One design of the table."""

    group: str  # "FPGA", "CPU peer", "GPU peer", "anchor"
    design: str
    where: str  # clock / machine / card
    ms: Optional[float]  # time per step on this frame (None: not available)
    how: str  # how the time was obtained
    error: Optional[SolutionError | NoExactReference] = None  # against the exact reference (None: not comparable)
    fit: str = ""
    notes: str = ""
    measured: bool = False  # a peer measured here (candidates for "the best peer")
    extra: dict[str, Any] = field(default_factory=dict)
    vs_thesis: Optional[float] = None  # thesis fp32 time / this time
    vs_best_peer: Optional[float] = None  # best measured peer's time / this time
    short: str = ""  # the plot's label


@dataclass(frozen=True)
class Step:
    """The frame's step as every design sees it (float64 setup)."""

    frame: Frame
    label: str
    bodies: BodyTable
    cons: ConstraintSet
    params: SolverParams
    ip: IntegrationParams
    exact: exact_error.AnyExactStep

    @property
    def manifold_passes(self) -> int:
        return self.cons.num_manifolds * 2 * self.params.iterations

    def error(self, final: BodyTable) -> SolutionError | NoExactReference:
        return exact_error.error_vs_exact(final, self.exact, self.bodies.dynamic)


def thesis_rows(step: Step) -> list[Row]:
    """The thesis's designs: published cycles per manifold-pass on this frame's manifold-passes, at their clocks;
    the error is our golden model's of the same format in the hazard order."""
    rows = []
    for name, fig in THESIS_FPGA.items():
        fmt = FP32 if name == "fp32" else FP16
        job = _job(step, fmt, "hazard")
        cycles = fig.cycles_per_manifold_pass * step.manifold_passes
        error, note = golden_error(step, job)
        rows.append(Row("FPGA", fig.label, f"ZCU102, {fig.clock_hz / 1e6:g} MHz", cycles / fig.clock_hz * 1e3,
                        f"published {fig.cycles_per_manifold_pass:.3f} cycles per manifold-pass x "
                        f"{step.manifold_passes:,} (published: {fig.ms} ms for 127,000 manifolds; on another frame "
                        f"this spreads no fixed cost, such as the body load and the integration, over its passes: "
                        f"an optimistic figure for small frames)", error, fig.fit,
                        "error: our golden model, same format, hazard order (the thesis did not publish one)" + note,
                        short=f"thesis {name}"))
    return rows


def golden_error(step: Step, job: KernelJob) -> tuple[SolutionError | NoExactReference, str]:
    """The golden model's step of ``job`` against the exact reference, and a note where it is not finite."""
    final = golden_step(job).final
    dyn = step.bodies.dynamic
    bad = int(np.count_nonzero(~np.isfinite(np.concatenate([final.linear_velocity[dyn], final.angular_velocity[dyn]],
                                                           axis=1)).any(axis=1)))
    note = (f"; NOT FINITE in {job.fmt.name}: {bad} of {int(dyn.sum())} bodies' velocities (values of this world lie "
            f"outside the format's range, e.g. an inverse inertia above its largest number)") if bad else ""
    return step.error(final), note


def _job(step: Step, fmt: NumberFormat, schedule: str) -> KernelJob:
    preset = get_preset(DMA)
    order = make_schedule(schedule, step.cons, step.bodies.dynamic, default_window(fmt, preset.stream_bits))
    return KernelJob(fmt, step.bodies.rounded(fmt), step.cons.rounded(fmt), order, step.params, step.ip)


HEADLINE_DESIGNS = (("fp32", FP32, 1), ("fp16", FP16, 2))


def headline_rows(step: Step) -> list[Row]:
    """Our fitting headline designs: the window kernel, impulses in the records, ring 8,192, 256-bit body beats, the
    adders in DSP48E2s, the inverse-inertia words the scene needs."""
    preset = get_preset(DMA)
    rows = []
    for name, fmt, lanes in HEADLINE_DESIGNS:
        job = (_job(step, fmt, "sweep").impulses_travelling().windowed(RING, lanes=lanes).with_adders(True)
               .with_inertia(True))
        cycles = cycle_model.predict_job(job, preset, body_bits=BODY_BITS).cycles
        verdict = kernel_fit(job, DMA, BODY_BITS)
        error, note = golden_error(step, job)
        fit = f"{verdict.headline()} ({verdict.shares_text()})" if isinstance(verdict, FitVerdict) else \
            short_verdict(verdict)
        command = (f"make sim SCENE=... SCHEDULE=sweep{'' if name == 'fp32' else ' FORMAT=fp16'} RECORD_WINDOW={RING}"
                   f"{'' if lanes == 1 else f' LANES={lanes}'} IMPULSE_STORE=records BODY_BITS={BODY_BITS} ADD_DSP=1 "
                   "INERTIA=scene")
        rows.append(Row("FPGA", f"ours: window kernel {name}, {lanes} lane{'s' if lanes > 1 else ''}, impulses in "
                                f"the records", f"ZCU102 preset, {preset.clock_hz / 1e6:g} MHz (timing not closed)",
                        cycles / preset.clock_hz * 1e3,
                        f"cycle model: {cycles:,} cycles ({cycles / job.manifold_passes:.3f} per manifold-pass)",
                        error, fit, f"the golden model's error (the RTL's, bit for bit); {command}{note}",
                        extra={"cycles": cycles}, short=f"ours: window {name} x{lanes}"))
    return rows


def warp_rows(step: Step, runs: int) -> list[Row]:
    """Bullet's batched scheme in Warp: the CPU (1 thread) and, where Warp sees one, the CUDA device."""
    import warp as wp

    from models.peers import warp_pgs
    from models.peers.batching import greedy_batches

    t0 = time.perf_counter()
    batches = greedy_batches(step.cons.body_a, step.cons.body_b, step.bodies.dynamic)
    batching_ms = (time.perf_counter() - t0) * 1e3
    b32, c32 = step.bodies.rounded(FP32), step.cons.rounded(FP32)
    golden = warp_pgs.golden_same_order(b32, c32, batches, step.params, step.ip)
    devices = ["cpu"] + (["cuda"] if wp.get_cuda_device_count() > 0 else [])
    rows = []
    for device in devices:
        peer = warp_pgs.WarpPgs(b32, c32, batches, step.params, step.ip, device)
        ours = peer.run()
        agreement = warp_pgs.compare_with_golden(ours, golden[:2], golden[2])
        timing = peer.time_step(runs)
        on_cpu = device == "cpu"
        overhead = (f"kernels {timing.kernel_ms:.3f} ms + launch overhead {timing.launch_ms:.3f} ms "
                    f"({timing.launches} launches)" + ("" if on_cpu else f"; eager from Python {timing.eager_ms:.3f} ms"))
        rows.append(Row("CPU peer" if on_cpu else "GPU peer",
                        f"Bullet's batched PGS in Warp, float32 ({batches.num_batches} batches)",
                        timing.device + (f"; {machine_name()}" if on_cpu else ""), timing.step_ms,
                        f"measured, median of {timing.runs}: {overhead}; {timing.how}",
                        step.error(ours[0]), "", f"vs the golden model in the batch order: {agreement.describe()}; "
                                                 f"batching (host, Python) {batching_ms:.1f} ms, not in the step",
                        measured=True, extra={"kernel_ms": timing.kernel_ms, "launch_ms": timing.launch_ms,
                                              "eager_ms": timing.eager_ms, "launches": timing.launches,
                                              "batches": batches.num_batches, "bit_exact": agreement.bit_exact,
                                              "differing_words": agreement.differing_words},
                        short="Warp, CPU 1 thread" if on_cpu else "Warp, CUDA"))
    return rows


def machine_name() -> str:
    return machine().split(" (load")[0]


# --- MuJoCo, in a child process
# ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class MujocoPoint:
    """One MuJoCo model: the frame file, how many dynamic bodies of it (0: all), the solver settings."""

    frame_path: str
    count: int
    iterations: int
    tolerance: float
    runs: int


def _child_main(spec_path: str) -> int:
    """Run one MuJoCo point (``--mujoco-child``): write its timings and final velocities beside the spec."""
    from models.peers import mujoco_peer as mj

    spec = json.loads(Path(spec_path).read_text())
    point = MujocoPoint(**spec["point"])
    frame = load(point.frame_path)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    keep = None if point.count == 0 else mj.nearest_bodies(frame, bodies.dynamic, point.count)
    settings = mj.MujocoSettings(point.iterations, point.tolerance)
    res = mj.step_frame(frame, bodies, cons, settings, SolverParams().friction_coeff, ip, point.runs, keep)
    out = Path(spec["out"])
    np.savez(out.with_suffix(".npz"), lin=res.final.linear_velocity, ang=res.final.angular_velocity)
    facts = {k: v for k, v in dataclasses.asdict(res).items() if k not in ("final", "settings")}
    out.write_text(json.dumps({**facts, "label": settings.label()}))
    return 0


@dataclass(frozen=True)
class MujocoOutcome:
    point: MujocoPoint
    facts: Optional[dict[str, Any]]  # None: it did not finish
    final: Optional[BodyTable]
    seconds: float
    failure: str = ""


def run_mujoco_point(point: MujocoPoint, step: Step, budget_s: float, memory_gb: float) -> MujocoOutcome:
    """One MuJoCo model in a child process under ``budget_s`` seconds and ``memory_gb`` of address space."""
    limit = int(memory_gb * (1 << 30))
    from models.peers.mujoco_peer import arena_bytes

    bodies = point.count or int(step.bodies.dynamic.sum())
    arena = arena_bytes(bodies, bodies + int(np.count_nonzero(~step.bodies.dynamic)))
    if arena + CHILD_BASE_BYTES > limit:
        return MujocoOutcome(point, None, None, 0.0, f"not run: its arena needs {arena / (1 << 30):.1f} GB of address "
                                                     f"space (the broadphase's share quadratic in the bodies), above the "
                                                     f"{memory_gb:g} GB cap (--mujoco-memory-gb)")

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    with tempfile.TemporaryDirectory(prefix="pgs-peers-mujoco-") as tmp:
        spec, out = Path(tmp) / "spec.json", Path(tmp) / "out.json"
        spec.write_text(json.dumps({"point": dataclasses.asdict(point), "out": str(out)}))
        t0 = time.perf_counter()
        try:
            # in the temporary directory: MuJoCo writes its warnings to MUJOCO_LOG.TXT in the working directory
            env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))}
            proc = subprocess.run([sys.executable, "-m", "sim.peers", "--mujoco-child", str(spec)], cwd=tmp, env=env,
                                  capture_output=True, text=True, timeout=budget_s, preexec_fn=cap)
        except subprocess.TimeoutExpired:
            return MujocoOutcome(point, None, None, budget_s, f"did not finish within {budget_s:.0f} s")
        seconds = time.perf_counter() - t0
        if proc.returncode != 0 or not out.is_file():
            tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
            return MujocoOutcome(point, None, None, seconds, f"failed (exit {proc.returncode}, {memory_gb:g} GB "
                                                             f"address-space cap): {tail}")
        facts = json.loads(out.read_text())
        vel = np.load(out.with_suffix(".npz"))
    final = step.bodies.copy()
    final.linear_velocity, final.angular_velocity = vel["lin"], vel["ang"]
    return MujocoOutcome(point, facts, final, seconds)


def mujoco_rows(step: Step, frame_path: str, args: argparse.Namespace) -> tuple[list[Row], list[dict[str, Any]]]:
    """MuJoCo's PGS on the whole frame (fixed sweeps, then its defaults), and on large frames the scaling study."""
    from models.peers.mujoco_peer import DEFAULT_ITERATIONS, DEFAULT_TOLERANCE

    n_dyn = int(step.bodies.dynamic.sum())
    scaling: list[dict[str, Any]] = []
    counts = ([c for c in MUJOCO_BLOCKS if c < n_dyn] if n_dyn > MUJOCO_BLOCKS_FROM and not args.no_scaling
              else [])
    failed = ""
    for count in counts:
        if failed:
            scaling.append({"bodies": count, "result": f"not run ({failed})"})
            continue
        runs = args.runs if count <= 1000 else 1
        res = run_mujoco_point(MujocoPoint(frame_path, count, args.iters, 0.0, runs), step, args.mujoco_budget,
                               args.mujoco_memory_gb)
        scaling.append(_scaling_entry(count, res))
        print(f"MuJoCo block of {count:,} bodies: {scaling[-1]['result']}", flush=True)
        if res.facts is None:
            failed = f"the block of {count:,} bodies {res.failure}"
    rows = []
    full_runs = args.runs if n_dyn <= 1000 else 1
    for iterations, tolerance in ((args.iters, 0.0), (DEFAULT_ITERATIONS, DEFAULT_TOLERANCE)):
        point = MujocoPoint(frame_path, 0, iterations, tolerance, full_runs)
        stop = "fixed sweeps" if tolerance == 0 else f"its defaults: up to {iterations} sweeps, tolerance {tolerance:g}"
        design = f"MuJoCo PGS, {iterations} sweeps ({stop}), float64"
        if failed:
            rows.append(Row("CPU peer", design, f"CPU, 1 thread; {machine_name()}", None, f"not run ({failed})"))
            continue
        res = run_mujoco_point(point, step, args.mujoco_budget, args.mujoco_memory_gb)
        if counts:
            scaling.append(_scaling_entry(n_dyn, res) | {"sweeps": iterations})
        if res.facts is None:
            failed = f"the whole frame {res.failure}"
            rows.append(Row("CPU peer", design, f"CPU, 1 thread; {machine_name()}", None, failed))
            continue
        f = res.facts
        rows.append(Row("CPU peer", design, f"CPU, 1 thread; {machine_name()}", f["constraint_ms"],
                        f"measured, median of {f['runs']}: the constraint solver alone (mjTIMER_CONSTRAINT); whole step "
                        f"{f['step_ms']:.3f} ms (collision {f['collision_ms']:.3f}, constraint set-up "
                        f"{f['make_ms']:.3f}); model compiled in {f['compile_s']:.2f} s",
                        step.error(res.final), "",
                        f"its own model: {f['contacts']:,} contacts of its collision detection ({f['rows']:,} pyramid "
                        f"rows; the frame: {step.frame.num_points_total:,} points in {step.cons.num_manifolds:,} "
                        f"manifolds), soft constraints, pyramidal cone; {f['friction_mismatches']} manifolds with "
                        f"another friction", measured=True, extra=f,
                        short=f"MuJoCo PGS {iterations} sweeps" + ("" if tolerance == 0 else " (defaults)")))
    return rows, scaling


def _scaling_entry(count: int, res: MujocoOutcome) -> dict[str, Any]:
    if res.facts is None:
        return {"bodies": count, "result": res.failure}
    f = res.facts
    return {"bodies": count, "contacts": f["contacts"], "rows": f["rows"], "constraint_ms": f["constraint_ms"],
            "step_ms": f["step_ms"], "compile_s": f["compile_s"], "wall_s": res.seconds,
            "result": (f"{f['contacts']:,} contacts, {f['rows']:,} rows: constraint solver {f['constraint_ms']:.1f} ms, "
                       f"step {f['step_ms']:.1f} ms, compile {f['compile_s']:.1f} s ({res.seconds:.0f} s in all)")}


def anchor_rows(step: Step) -> list[Row]:
    """Published figures, not measured here: scaled linearly to this frame where its size is of the same order."""
    rows = []
    n_dyn = int(step.bodies.dynamic.sum())
    for a in PEER_ANCHORS:
        comparable = n_dyn >= 1000
        ms = a.scaled(n_dyn, step.cons.num_manifolds) if comparable else None
        how = (f"NOT MEASURED HERE: published {a.ms} ms per step on {a.scene} ({a.size:,} {a.unit}), "
               + (f"scaled linearly to this frame's {n_dyn if a.unit == 'bodies' else step.cons.num_manifolds:,} "
                  f"{a.unit} (an extrapolation)" if comparable else "no scaling to a frame this small"))
        rows.append(Row("anchor", a.label, a.hardware, ms, how, None, "",
                        ("whole step, collision included" if a.whole_step else "contact solve and integration")
                        + f"; {a.source}"))
    return rows


def add_ratios(rows: list[Row]) -> None:
    """Each row's time against the thesis fp32 design's and the best measured peer's (> 1: faster)."""
    thesis = next(r.ms for r in rows if r.design == THESIS_FPGA["fp32"].label)
    peers = [r.ms for r in rows if r.measured and r.ms is not None]
    best = min(peers) if peers else None
    for r in rows:
        if r.ms is None or r.ms <= 0:
            continue
        r.vs_thesis = thesis / r.ms
        r.vs_best_peer = None if best is None else best / r.ms


# --- the table
# ---------------------------------------------------------------------------------------------------------
def _error_cells(e: Optional[SolutionError | NoExactReference]) -> tuple[str, str]:
    if e is None:
        return "not comparable", ""
    if isinstance(e, NoExactReference):
        return str(e), ""
    return f"{e.max_dv:.3e}", f"{e.max_dw:.3e}"


def _ratio(x: Optional[float]) -> str:
    return "-" if x is None else f"{x:.3g}x"


def table_lines(rows: Sequence[Row]) -> list[str]:
    lines = ["| group | design | where | time per step (ms) | max \\|dv\\| vs exact (m/s) | max \\|dw\\| (rad/s) | "
             "speed vs thesis fp32 | speed vs best peer | fit | how |", "|---" * 10 + "|"]
    for r in rows:
        dv, dw = _error_cells(r.error)
        ms = "-" if r.ms is None else f"{r.ms:.4g}"
        how = r.how + (f"; {r.notes}" if r.notes else "")
        lines.append(f"| {r.group} | {r.design} | {r.where} | {ms} | {dv} | {dw} | {_ratio(r.vs_thesis)} | "
                     f"{_ratio(r.vs_best_peer)} | {r.fit or '-'} | {how} |")
    return lines


def scaling_lines(scaling: Sequence[dict[str, Any]]) -> list[str]:
    if not scaling:
        return []
    lines = ["", "MuJoCo PGS on growing blocks of the frame (the dynamic bodies nearest the pile's lowest corner, the "
                 "static ones; fixed sweeps unless noted; one child process each):", "",
             "| dynamic bodies | result |", "|---|---|"]
    lines += [f"| {s['bodies']:,}{' (' + str(s['sweeps']) + ' sweeps)' if 'sweeps' in s else ''} | {s['result']} |"
              for s in scaling]
    return lines


def plot(rows: Sequence[Row], path: Path, title: str) -> None:
    """Time per step against max |dv| from the exact reference: FPGA designs and measured peers as points (filled:
    fits its platform, or a peer), anchors (no error on this frame) as vertical lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(12, 7))
    markers = {"FPGA": "s", "CPU peer": "o", "GPU peer": "^"}
    pts = [r for r in rows if r.ms is not None and isinstance(r.error, SolutionError)]
    floor = min((r.error.max_dv for r in pts if r.error.max_dv > 0), default=1e-6) / 2  # type: ignore[union-attr]
    for k, r in enumerate(pts):
        colour = f"C{k % 10}"
        y = max(r.error.max_dv, floor)  # type: ignore[union-attr]
        filled = r.group != "FPGA" or "FITS" in r.fit or r.fit.startswith("fits")
        ax.plot(r.ms, y, markers.get(r.group, "x"), color=colour, markersize=10,
                markerfacecolor=colour if filled else "none", linestyle="none",
                label=f"{r.short or r.design}: {r.ms:.3g} ms, {y:.3g} m/s")
        ax.annotate(r.short or r.design, (r.ms, y), textcoords="offset points", xytext=(7, 6 - 14 * (k % 2)),
                    fontsize=7, color=colour)
    for k, r in enumerate(r for r in rows if r.group == "anchor" and r.ms is not None):
        ax.axvline(r.ms, color="grey", linestyle=":", linewidth=1)
        ax.text(r.ms, 0.03 + 0.09 * (k % 5), f" {r.design}: {r.ms:.3g} ms\n (published, scaled; NOT measured here)",
                fontsize=6, color="grey", transform=ax.get_xaxis_transform())
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time per step (ms, log): FPGA = cycle model at its clock; peers = measured here, median")
    ax.set_ylabel("max |v - v_exact| over dynamic bodies (m/s, log)")
    ax.margins(x=0.2, y=0.1)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), title="square: FPGA (hollow: does not fit)\n"
              "circle: CPU peer, triangle: GPU peer", title_fontsize=7)
    ax.set_title(title, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def build_step(args: argparse.Namespace) -> tuple[Step, str]:
    """The frame, its constraints and exact reference, and a frame file for the MuJoCo child."""
    frame, label = load_frame(args)
    print(frame.summary(), flush=True)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    params = SolverParams(iterations=args.iters)
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    exact = exact_error.exact_step(bodies, cons, ip, exact_error.reference_dir(args), args.exact_budget, params)
    return Step(frame, label, bodies, cons, params, ip, exact), label


def peers(args: argparse.Namespace, out_dir: Path) -> tuple[list[Row], list[dict[str, Any]], str]:
    """Every row of the table (ratios added) and the MuJoCo scaling study; writes the frame file the MuJoCo child
    reads into ``out_dir``."""
    check_args(args)
    where = machine()
    step, label = build_step(args)
    rows = thesis_rows(step) + headline_rows(step)
    print("FPGA rows done", flush=True)
    rows += warp_rows(step, args.runs)
    print("Warp rows done", flush=True)
    scaling: list[dict[str, Any]] = []
    if not args.no_mujoco:
        frame_path = (out_dir / "frame.npz").resolve()  # the child runs in a directory of its own
        save(step.frame, frame_path)
        mj_rows, scaling = mujoco_rows(step, str(frame_path), args)
        frame_path.unlink()
        rows += mj_rows
    rows += anchor_rows(step)
    add_ratios(rows)
    return rows, scaling, f"{label}: {step.frame.num_bodies:,} bodies, {step.cons.num_manifolds:,} manifolds, " \
                          f"{args.iters} iterations; machine: {where}"


def write_outputs(rows: Sequence[Row], scaling: Sequence[dict[str, Any]], heading: str, out_dir: Path,
                  title: str) -> list[str]:
    lines = [f"# {title}", "", heading, "", *table_lines(rows), *scaling_lines(scaling)]
    (out_dir / "peers.md").write_text("\n".join(lines) + "\n")
    (out_dir / "peers.json").write_text(json.dumps({"heading": heading, "rows": [_row_json(r) for r in rows],
                                                    "mujoco_scaling": list(scaling)}, indent=1, default=str))
    plot(rows, out_dir / "peers.png", f"{title}\n{heading.replace('; machine: ', chr(10) + 'machine: ')}")
    return lines


def _row_json(r: Row) -> dict[str, Any]:
    d = dataclasses.asdict(r)
    if isinstance(r.error, SolutionError):
        d["error"] = dataclasses.asdict(r.error)
    elif r.error is not None:
        d["error"] = str(r.error)
    return d


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.mujoco_child:
        return _child_main(args.mujoco_child)
    try:
        with StagedDirectory(Path(args.out)) as out:
            rows, scaling, heading = peers(args, out.path)
            label = heading.split(":")[0]
            title = f"make peers SCENE={args.scene}: FPGA designs and peers on one frame ({time.strftime('%Y-%m-%d')})"
            lines = write_outputs(rows, scaling, heading, out.path, title)
            out_dir = out.commit(label)
    except (ValueError, FrameError, scenes.SceneError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print("\n".join(lines))
    print(f"\npeers: {out_dir / 'peers.md'}, {out_dir / 'peers.json'} and {out_dir / 'peers.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
