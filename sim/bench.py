"""``make bench``: simulated kernel cycles per second of the compiled harness, compile profiles side by side.

One scene's step (the same inputs as ``make sim``: hazard schedule, the DMA preset's bandwidth model) runs on the
kernel harness built with each compile profile of ``sim.compile.kernel_build.COMPILE_PROFILES`` (the build description's
``compile_profile``, so each builds in a directory of its own; the first build of a profile takes minutes and its
time is printed). The runs alternate between the profiles, ``--runs`` times each, so a load change on a shared
machine hits all of them alike; each run's trace and body-out stream must be identical, byte for byte, to the
first profile's (the profiles change how the C++ is compiled, never what the kernel computes). Printed per
profile: the build's wall and CPU seconds (Verilator, make and the compiler; about 0 when the build was already
there) and its CPU ratio to the first profile's, simulated cycles, the median of cycles per wall second and per
CPU second of the harness process (the CPU figure holds on a loaded machine), and the ratio of the CPU figure to
the first profile's. ``--max-cycles`` stops every run at that many cycles (a prefix of a long scene's step, the
same for every profile; the outputs compared are then the prefix's). ``--baseline-exe`` adds a harness built
elsewhere (the same kernel build from another tree, for example a git worktree of the commit before an RTL
change) as the first, reference column: the same runs, the same inputs, byte-identical outputs, and each
profile's speed as a ratio against it, measured side by side. A profile-guided profile (``pgo``) builds an
instrumented harness, trains it on the first cycles of the bench's own run (``sim.drive.harness_run.TRAINING_CYCLES``)
and builds again from that profile; its build figures count both builds and the training.

    python -m sim.bench --scene pile --profiles quick,o2 --runs 3
    python -m sim.bench --scene thesis --profiles quick,os --runs 3 --max-cycles 300000
    python -m sim.bench --scene thesis --profiles quick,pgo --runs 2
    python -m sim.bench --scene pile --profiles quick --runs 5 \
        --baseline-exe ../old/build/verilator/pgs_kernel_e8m23_c512/pgs_kernel_e8m23_c512

``--cycle-model`` prints instead how fast the two cycle models (``models/timing``) predict a synthetic step of 20,000
manifolds over 5,001 bodies, 4 iterations (manifold-passes predicted per second; ``--runs`` runs, the median), and
builds nothing (``make bench CYCLE_MODEL=1``).
"""

from __future__ import annotations

import argparse
import filecmp
import resource
import shutil
import statistics
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from models import scenes
from models.formats.number_format import FP32
from models.kernel.record_window import WindowPlan, fits, lane_slots
from models.order.manifold_schedule import band_width
from models.setup.constraints import ConstraintSet
from models.timing import stream_cycle_model, window_cycle_model
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape
from models.golden.contact_solver import SolverParams
from models.timing.platforms import DmaPreset, get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import NumberFormat, parse_format
from sim.drive.harness_run import KernelRunError, harness_cycle_limit, run_harness, training_run, write_inputs
from sim.compile.kernel_build import COMPILE_PROFILES, PROFILE_GUIDED, KernelBuild, build_kernel, default_window
from sim.compile.verilator_build import REPO_ROOT

OUTPUTS = ("trace.bin", "body_out.bin", "body_out_last.bin")
BASELINE = "baseline"  # the column of --baseline-exe


@dataclass
class ProfileRuns:
    """One compile profile's build and runs."""

    profile: str
    exe: Path
    build_s: float
    build_cpu_s: float
    cycles: int = 0
    wall_s: list[float] = field(default_factory=list)
    cpu_s: list[float] = field(default_factory=list)

    def cycles_per_s(self, seconds: list[float]) -> float:
        return self.cycles / max(statistics.median(seconds), 1e-9)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="pile")
    ap.add_argument("--scene-args", default="", help='scene parameters, e.g. "nx=20 ny=5 nz=20 friction=0.4"')
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--format", default="fp32")
    ap.add_argument("--dma", default="zcu102")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--profiles", default="quick,pgo",
                    help=f"compile profiles, the first is the reference (of {', '.join(COMPILE_PROFILES)})")
    ap.add_argument("--runs", type=int, default=3, help="runs of each profile")
    ap.add_argument("--max-cycles", type=int, default=0,
                    help="stop each run after this many cycles (0: run the whole step)")
    ap.add_argument("--out", default="build/bench", help="parent directory of the run directories")
    ap.add_argument("--baseline-exe", default="",
                    help="a harness of the same kernel build from another tree: the reference column")
    ap.add_argument("--cycle-model", action="store_true",
                    help="the cycle models' speed on a synthetic step instead (no kernel build)")
    return ap.parse_args(argv)


# --- the cycle models' speed (--cycle-model) ----------------------------------------------------------------------
SYNTHETIC_MANIFOLDS, SYNTHETIC_BODIES = 20_000, 5_001


def synthetic_streaming_step() -> StepShape:
    """Manifold k joins bodies 1 + k % 5000 and 1 + (7k + 1) % 5000 (body 0 static), 4 iterations."""
    k = np.arange(SYNTHETIC_MANIFOLDS)
    inv_mass = np.ones(SYNTHETIC_BODIES)
    inv_mass[0] = 0.0
    return StepShape.of(FP32, inv_mass, 1 + k % 5000, 1 + (k * 7 + 1) % 5000, SolverParams(4))


def synthetic_window_step(seed: int = 3) -> tuple[StepShape, WindowPlan]:
    """Random bodies (a tenth of the manifolds on the static body 0), ordered by the lower body, two lanes, a ring
    of 16,384 records: the step and the window plan."""
    rng = np.random.default_rng(seed)
    m, nb = SYNTHETIC_MANIFOLDS, SYNTHETIC_BODIES
    body_a = rng.integers(1, nb, m)
    body_b = np.where(rng.random(m) < 0.1, 0, (body_a + rng.integers(1, 40, m)) % nb)
    z = np.zeros
    cons = ConstraintSet(body_a=body_a, body_b=body_b, num_points=np.ones(m, int), normal=z((m, 3)),
                         points=z((m, 4, 3)), jac_inv=z((m, 4)), bias=z((m, 4)), center=z((m, 3)),
                         tangent=z((m, 2, 3)), f_jac_inv=z((m, 2)), spin_damp=z(m, bool))
    dyn = np.ones(nb, bool)
    dyn[0] = False
    slots = lane_slots(np.argsort(np.minimum(body_a, body_b), kind="stable"), cons, dyn, 2)
    lag = band_width(slots, cons, dyn, 2)
    real = np.maximum(slots, 0)
    step = StepShape.of(FP32, dyn.astype(float), np.where(slots >= 0, body_a[real], -1),
                        np.where(slots >= 0, body_b[real], -1), SolverParams(4))
    fetch = max(f for f in range(1, 9) if fits(16384, 8, lag, f))
    return step, WindowPlan(16384, 8, lag, fetch, lag, 2, slots)


def cycle_model_speed(runs: int) -> str:
    """The streaming and the window cycle model on their synthetic steps (zcu102): predictions per second."""
    zcu102 = DmaTiming.of(get_preset("zcu102"))
    shape = KernelShape.of(FP32, 512)
    stream, (window, plan) = synthetic_streaming_step(), synthetic_window_step()
    models = (("streaming cycle model", lambda: stream_cycle_model.predict(shape, zcu102, stream)),
              ("window cycle model (2 lanes, ring 16,384)", lambda: window_cycle_model.predict_window(
                  shape, zcu102, window, plan)))
    lines = [f"cycle models, synthetic step: {SYNTHETIC_MANIFOLDS:,} manifolds, {SYNTHETIC_BODIES:,} bodies, "
             f"4 iterations, zcu102; median of {runs} runs"]
    for name, predict in models:
        seconds = []
        for _ in range(runs):
            t0 = time.perf_counter()
            p = predict()
            seconds.append(time.perf_counter() - t0)
        dt = statistics.median(seconds)
        lines.append(f"{name}: {p.manifold_passes:,} manifold-passes, {p.cycles:,} cycles in {dt:.2f} s "
                     f"({p.manifold_passes / dt / 1e3:.0f} k manifold-passes/s)")
    return "\n".join(lines)


def check_args(args: argparse.Namespace) -> list[str]:
    """The profile names, after checking every option."""
    profiles = [p.strip() for p in args.profiles.split(",") if p.strip()]
    unknown = [p for p in profiles if p not in COMPILE_PROFILES]
    if unknown or not profiles:
        raise ValueError(f"--profiles: unknown {unknown or 'none given'}; known: {', '.join(COMPILE_PROFILES)}")
    if len(set(profiles)) != len(profiles):
        raise ValueError(f"--profiles names a profile twice: {args.profiles}")
    if not 1 <= args.runs <= 100:
        raise ValueError(f"--runs must be in 1..100, got {args.runs}")
    if args.iters < 1:
        raise ValueError(f"--iters must be >= 1, got {args.iters}")
    if args.max_cycles < 0:
        raise ValueError(f"--max-cycles must be >= 0, got {args.max_cycles}")
    if not isinstance(parse_format(args.format), NumberFormat):
        raise ValueError(f"--format {args.format!r} is not a kernel format")
    get_preset(args.dma)
    if args.baseline_exe and not Path(args.baseline_exe).is_file():
        raise ValueError(f"--baseline-exe {args.baseline_exe}: no such file")
    return profiles


def scene_job(args: argparse.Namespace, preset: DmaPreset) -> tuple[KernelJob, str]:
    """The step ``make sim`` runs for these options (streaming kernel, hazard schedule), and the scene's label."""
    fmt = parse_format(args.format)
    assert isinstance(fmt, NumberFormat)
    frame, label = scenes.load_scene(args.scene, args.scene_args, args.seed)
    return KernelJob.from_frame(frame, fmt, SolverParams(iterations=args.iters), "hazard",
                                default_window(fmt, preset.stream_bits)), label


def child_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_once(pr: ProfileRuns, run_dir: Path, reference: Path | None, args: argparse.Namespace, preset: DmaPreset,
             max_cycles: int) -> None:
    """One harness run of ``pr`` in ``run_dir``; its outputs must equal those in ``reference`` (when given)."""
    cpu0, t0 = child_cpu_s(), time.perf_counter()
    try:
        pr.cycles = int(run_harness(pr.exe, run_dir, args.seed, preset, max_cycles)["harness_cycles"])
    except KernelRunError as exc:  # --max-cycles: the harness stops there with a timeout (exit status 3)
        if not (args.max_cycles and f"TIMEOUT after {max_cycles} cycles" in str(exc)):
            raise
        pr.cycles = max_cycles
    pr.wall_s.append(time.perf_counter() - t0)
    pr.cpu_s.append(child_cpu_s() - cpu0)
    if reference is not None:
        for name in OUTPUTS:
            if (reference / name).exists() and not filecmp.cmp(reference / name, run_dir / name, shallow=False):
                raise RuntimeError(f"profile {pr.profile}: {name} differs from {reference / name}")


def report(results: list[ProfileRuns], label: str) -> str:
    ref = results[0]
    lines = [f"{label}: {ref.cycles:,} simulated cycles per run, medians of {len(ref.cpu_s)} runs each",
             f"{'profile':<8} {'build s':>8} {'build CPU s':>12} {'build ratio':>12} {'kcyc/s wall':>12} "
             f"{'kcyc/s CPU':>11} {'CPU ratio':>10}  flags"]
    for pr in results:
        ratio = pr.cycles_per_s(pr.cpu_s) / ref.cycles_per_s(ref.cpu_s)
        build_ratio = f"{pr.build_cpu_s / ref.build_cpu_s:11.2f}x" if ref.build_cpu_s >= 1.0 else f"{'-':>12}"
        flags = (f"built elsewhere: {pr.exe}" if pr.profile == BASELINE else
                 " ".join(a for a in COMPILE_PROFILES[pr.profile] if a != "-MAKEFLAGS")
                 + (" + profile-guided (trained on the first cycles of the run that built it; build: both stages and the training)"
                    if pr.profile in PROFILE_GUIDED else ""))
        lines.append(f"{pr.profile:<8} {pr.build_s:8.1f} {pr.build_cpu_s:12.1f} {build_ratio} "
                     f"{pr.cycles_per_s(pr.wall_s) / 1e3:12.1f} {pr.cycles_per_s(pr.cpu_s) / 1e3:11.1f} "
                     f"{ratio:9.2f}x  {flags}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.cycle_model:
        if not 1 <= args.runs <= 100:
            print(f"error: --runs must be in 1..100, got {args.runs}", file=sys.stderr)
            return 2
        print(cycle_model_speed(args.runs))
        return 0
    try:
        profiles = check_args(args)
        preset = get_preset(args.dma)
        job, scene = scene_job(args, preset)
    except ValueError as exc:  # a SceneError too (a bad scene or SCENE_ARGS)
        print(f"error: {exc}", file=sys.stderr)
        return 2
    kb = KernelBuild.for_job(job, preset)
    label = f"{scene}-{job.fmt.name}-it{args.iters}-s{args.seed}-{args.dma}"
    base = REPO_ROOT / args.out / label
    results = []
    if args.baseline_exe:
        run_dir = base / BASELINE
        shutil.rmtree(run_dir, ignore_errors=True)
        write_inputs(run_dir, job, replace(kb, compile_profile=profiles[0]))
        results.append(ProfileRuns(BASELINE, Path(args.baseline_exe).resolve(), 0.0, 0.0))
    for profile in profiles:
        profile_kb = replace(kb, compile_profile=profile)
        run_dir = base / profile
        shutil.rmtree(run_dir, ignore_errors=True)
        write_inputs(run_dir, job, profile_kb)
        cpu0 = child_cpu_s()
        exe, build_s = build_kernel(profile_kb, training_run(run_dir, job, preset, profile_kb, args.seed))
        build_cpu_s = child_cpu_s() - cpu0
        results.append(ProfileRuns(profile, exe, build_s, build_cpu_s))
    max_cycles = args.max_cycles or harness_cycle_limit(job)
    for _ in range(args.runs):
        for pr in results:
            run_once(pr, base / pr.profile, None if pr is results[0] else base / results[0].profile, args, preset,
                     max_cycles)
    print(report(results, label))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
