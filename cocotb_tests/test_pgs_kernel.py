"""Kernel-level bit-exact test of rtl/pgs_kernel.sv against the golden model (the ``make sim`` fast path).

The kernel is built once per parameter set with Verilator into the compiled C++ harness
(``sim/harness/pgs_kernel_main.cpp``, ``build/verilator/pgs_kernel_e8m23_c512/``, the same build
``make sim`` uses). Per case (scene, format, schedule) ``sim.drive.kernel_step`` packs the body table and the
constraint stream of one step, runs the harness through the zcu102 DMA model with random stream gaps and
output backpressure on top (seeded: the seed is printed, ``SEED=<int>`` overrides it), and compares bit for bit:

* every trace record, in retire order, against the golden ``solve(..., trace=...)`` PassRecords (pass
  kind, iteration, manifold slot, impulses, vA, wA, vB, wB); the first mismatch fails the test with the
  cycle, slot, manifold, pass, iteration, bodies, field and both values (hex and decimal);
* the body-out stream against ``integrate(solve(...).bodies)`` (every body, pos, q, v, w).

It prints cycles, cycles per manifold-pass, stall and bubble cycles, the build time and the simulated
cycles per second. Schedules: ``hazard`` (window = pipeline depth in records, few stalls) and ``pybullet``
(frame order: many hazards; the CAM's stalls must keep it exact).

Cycles (``models/timing/cycle_model.py``): the random runs must not beat the cycle model's deterministic prediction (a
lower bound); ``test_kernel_cycles_match_model`` runs each case with deterministic streams (no gap, no
backpressure) and requires every retire cycle, the total and the stall and bubble counters to equal the model's.

Floating-point events (``rtl/README.md``): the overflow / underflow / invalid counters the harness reads
(result.txt) must equal the golden model's count of its own operations' events (``Golden.events`` of
``sim.drive.kernel_step.golden_step``) and the fp_status flags must be set
exactly for the non-zero ones; every fp32 and bf16 scene leaves them at zero (fp16 flushes tiny velocity terms to
zero: underflows). ``test_pgs_kernel_fp16_overflow`` spins the top cube of the stack at 2000 rad/s in fp16:
its squared angular velocity overflows in the integration (and the step stays bit-exact).

Inverse inertia (``models/setup/inertia.py``): ``test_pgs_kernel_full_inverse_inertia`` runs a user world of rotated
non-cube boxes in Bullet 2's convention (``docs/rotated_boxes_world.py``): the symmetric 3x3 per body, the kernel
built with the 6-word body record (``IINV_W = 6``), bit-exact, and its cycles are the cycle model's;
``test_pgs_kernel_scalar_inverse_inertia`` runs the stack's cubes on the 1-word build (``IINV_W = 1``, ``make sim
INERTIA=scene``), bit-exact, and with deterministic streams its cycles are the cycle model's.
Friction: ``test_pgs_kernel_manifold_friction`` runs a world of mixed shapes and frictions
(``docs/mixed_shapes_world.py``) on the build whose friction records carry each manifold's coefficient
(``MU_W = 1``), bit-exact, its cycles the cycle model's.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.timing import cycle_model
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.setup.constraints import FRICTION_COEFF
from models.golden.contact_solver import SolverParams, solve
from models.timing.platforms import DmaPreset, get_preset
from models.setup.inertia import InertiaMode
from models.formats.number_format import BF16, EVENT_NAMES, FP16, FP32, NumberFormat
from models.kernel.kernel_job import KernelJob
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import KernelResult, golden_step, run_kernel_step
from models.timing import prediction
from sim.compare import retire_cycles
from sim.drive.seed import run_seed

GAP_PERMILLE, BP_PERMILLE = 100, 200
ITERATIONS = 4

SCENES = KERNEL_TEST_SCENES  # the kernel test scenes, shared with coverage and regress
# a world file of rotated non-cube boxes in Bullet 2's convention: the full inverse-inertia mode (IINV_W = 6)
ROTATED_WORLD = str(Path(__file__).resolve().parents[1] / "docs" / "rotated_boxes_world.py")
# a world file of spheres, capsules, cylinders, boxes and convex compounds of mixed friction in Bullet 2's
# convention: the full inverse-inertia mode and a friction coefficient per manifold (IINV_W = 6, MU_W = 1)
MIXED_FRICTION_WORLD = str(Path(__file__).resolve().parents[1] / "docs" / "mixed_shapes_world.py")
SCENE_PARAMS = {**SCENES, ROTATED_WORLD: {}, MIXED_FRICTION_WORLD: {}}


@dataclass
class Case:
    scene: str
    fmt: NumberFormat
    schedule_kind: str

    @property
    def label(self) -> str:
        return Path(self.scene).stem


def _seed() -> int:
    return run_seed()


def run_case(case: Case, tmp: Path, spin: tuple[int, float] | None = None) -> KernelResult:
    """Run one case; ``spin`` = (body, rad/s) sets that body's angular velocity about y."""
    frame = scenes.load_or_capture(case.scene, **SCENE_PARAMS[case.scene])
    window = default_window(case.fmt, 512)
    job = KernelJob.from_frame(frame, case.fmt, SolverParams(ITERATIONS), case.schedule_kind, window)
    if spin is not None:
        job.bodies.angular_velocity[spin[0]] = case.fmt.round(np.array([0.0, spin[1], 0.0]))
    seed = _seed()
    print(f"\n[{case.label}/{case.fmt.name}/{case.schedule_kind}] seed {seed} (SEED= overrides); "
          f"{job.bodies.num_bodies} bodies, {len(job.slots)} manifolds, {len(job.schedule) - len(job.slots)} bubbles "
          f"in the schedule (W={window})")
    golden = golden_step(job)
    res = run_kernel_step(job, get_preset("zcu102"), tmp, seed, GAP_PERMILLE, BP_PERMILLE, golden=golden)
    if res.comparison.first_mismatch is not None:
        pytest.fail(res.comparison.first_mismatch)
    assert res.bit_exact
    check_cycle_bound(job, get_preset("zcu102"), res.cycles)
    r = res.registers
    print(f"  cycles {res.cycles}, {res.cycles / job.manifold_passes:.2f} cycles per manifold-pass, stalls "
          f"{int(r['stalls'])}, bubbles {int(r['bubbles'])}; build {res.build_seconds:.1f} s; simulated "
          f"{res.sim_cycles_per_s / 1e3:.1f} kcycles/s ({r['wall_s']:.2f} s); bit-exact: "
          f"{res.comparison.records} trace records, {res.comparison.bodies} bodies")
    want = golden.events.as_dict()
    got = {name: int(r[f"fp_{name}"]) for name in EVENT_NAMES}
    print(f"  floating-point events: kernel {got}, golden model {want}, fp_status {int(r['fp_status']):#x}")
    assert got == want, "the kernel's floating-point event counters differ from the golden model's count"
    assert int(r["fp_status"]) == sum(1 << k for k, name in enumerate(EVENT_NAMES) if got[name])
    assert int(r["rejected"]) == 0
    if case.fmt.name != "fp16":
        assert got == dict.fromkeys(EVENT_NAMES, 0), "a normal fp32 / bf16 scene must raise no event"
    return res


# fp32 on every scene and schedule; fp16 (the thesis's fastest design) and bfloat16 on the pile in hazard order
# and the stack in frame order (every manifold a hazard): one more build each
CASES = [Case(s, FP32, k) for s in SCENES for k in ("hazard", "pybullet")] + [
    Case(s, f, k) for f in (FP16, BF16) for s, k in (("pile", "hazard"), ("stack", "pybullet"))]


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c.label}-{c.fmt.name}-{c.schedule_kind}")
def test_pgs_kernel(case: Case, tmp_path: Path) -> None:
    run_case(case, tmp_path)


def test_pgs_kernel_fp16_overflow(tmp_path: Path) -> None:
    """The stack's top cube spinning at 2000 rad/s in fp16: the counters (overflow and underflow non-zero) equal
    the golden model's prediction (checked in run_case), and the step is bit-exact."""
    res = run_case(Case("stack", FP16, "pybullet"), tmp_path, spin=(10, 2000.0))
    assert int(res.registers["fp_overflow"]) > 0 and int(res.registers["fp_underflow"]) > 0


def test_pgs_kernel_full_inverse_inertia(tmp_path: Path) -> None:
    """Rotated non-cube boxes in Bullet 2's convention: every dynamic body's R diag(1/I) R^T is a full symmetric
    3x3 (an off-diagonal word non-zero), the job runs on the 6-word build, and the step is bit-exact with the golden
    model's symmetric product (checked in run_case, with random stream gaps and backpressure)."""
    frame = scenes.load_or_capture(ROTATED_WORLD)
    job = KernelJob.from_frame(frame, FP32, SolverParams(ITERATIONS), "hazard", default_window(FP32, 512))
    assert frame.meta["bullet_convention"] == "bullet2" and job.bodies.inertia_mode is InertiaMode.FULL
    assert job.inertia_words == 6 and np.all(np.any(job.bodies.inv_inertia[job.bodies.dynamic, 3:] != 0.0, axis=1))
    assert np.any(job.bodies.dynamic[job.cons.body_a] & job.bodies.dynamic[job.cons.body_b])  # a box on a box
    run_case(Case(ROTATED_WORLD, FP32, "hazard"), tmp_path)


def test_pgs_kernel_manifold_friction(tmp_path: Path) -> None:
    """Spheres, capsules, cylinders, turned boxes and convex compounds whose pairs' friction differ: every friction
    record carries its manifold's coefficient (the build with MU_W = 1 and the 6-word body record), and the step is
    bit-exact with the golden model's per-manifold clamp (with random stream gaps and backpressure), which the
    kernel's one coefficient would not give."""
    frame = scenes.load_or_capture(MIXED_FRICTION_WORLD)
    job = KernelJob.from_frame(frame, FP32, SolverParams(ITERATIONS), "hazard", default_window(FP32, 512))
    assert job.friction_words == 1 and job.inertia_words == 6
    assert KernelBuild.for_job(job, get_preset("zcu102")).name == "pgs_kernel_e8m23_c512_i6_mu"
    mu = job.cons.friction[:, 0]
    assert np.unique(mu).size > 5 and np.all(mu != FRICTION_COEFF)
    one = dataclasses.replace(job.cons, friction=np.zeros((job.cons.num_manifolds, 0)))
    per, const = (solve(job.bodies, c, job.schedule, job.fmt, job.params).bodies for c in (job.cons, one))
    assert np.any(per.linear_velocity != const.linear_velocity)  # the coefficient word matters
    run_case(Case(MIXED_FRICTION_WORLD, FP32, "hazard"), tmp_path)


ASSET_WORLDS = ("jenga_tower", "duck_lego_pile")


@pytest.mark.parametrize("world", ASSET_WORLDS)
def test_asset_worlds_through_the_rtl(world: str, tmp_path: Path) -> None:
    """The shipped asset worlds as ``make sim SCENE=<world>`` runs them (seed, hazard order, zcu102; Bullet 2's
    inertia and each pair's friction: the 6-word, coefficient-carrying build the mixed-shapes test makes): 0 bits
    differ, the counters are the golden model's, every retire cycle is the cycle model's, and the kernel's cycles are
    the README's (``docs/claims.toml``, the user-worlds row)."""
    from sim.claims import load_claims
    from sim.drive.seed import DEFAULT_SEED

    frame, _ = scenes.load_scene(world, "", DEFAULT_SEED)  # make sim's frame (deterministic streams: no other seed)
    job = KernelJob.from_frame(frame, FP32, SolverParams(ITERATIONS), "hazard", default_window(FP32, 512))
    assert KernelBuild.for_job(job, get_preset("zcu102")).name == "pgs_kernel_e8m23_c512_i6_mu"
    pred = cycle_model.predict_job(job, get_preset("zcu102"))
    agree = run_deterministic(job, get_preset("zcu102"), pred, tmp_path)
    print(f"\n[{world}] {job.bodies.num_bodies} bodies, {len(job.slots)} manifolds: {agree.describe()}")
    assert agree.ok, agree.first_mismatch
    [row] = [c for c in load_claims().rows if c.claim == "user worlds"]
    stated = {f.runs[0]: f.value for f in row.figures if f.measure == "cycles"}
    assert agree.cycles_rtl == stated[{"jenga_tower": "jenga", "duck_lego_pile": "duck-lego"}[world]]


def _scalar_stack_job() -> KernelJob:
    """The stack's cubes (the scalar mode: one inverse-inertia value per body) on the build with the scene's
    inverse-inertia words (``make sim INERTIA=scene``: the 1-word build, IINV_W = 1, the 15-word body record)."""
    frame = scenes.load_or_capture("stack", **SCENES["stack"])
    job = KernelJob.from_frame(frame, FP32, SolverParams(ITERATIONS), "pybullet", default_window(FP32, 512))
    assert job.bodies.inertia_mode is InertiaMode.SCALAR and job.inertia_words == 3
    return job.with_inertia(True)


def test_pgs_kernel_scalar_inverse_inertia(tmp_path: Path) -> None:
    """The 1-word build on the stack with random stream gaps and backpressure: bit-exact with the golden model."""
    job = _scalar_stack_job()
    assert job.inertia_words == 1
    res = run_kernel_step(job, get_preset("zcu102"), tmp_path, _seed(), GAP_PERMILLE, BP_PERMILLE)
    assert res.bit_exact, res.comparison.first_mismatch
    assert res.comparison.records == job.manifold_passes and res.comparison.bodies == job.bodies.num_bodies
    print(f"\n[stack/fp32/1 word] cycles {res.cycles}, bit-exact: {res.comparison.records} trace records, "
          f"{res.comparison.bodies} bodies")


def test_pgs_kernel_scalar_inverse_inertia_cycles(tmp_path: Path) -> None:
    """The 1-word build (the same build) with deterministic streams: every retire cycle, the total and the stall and
    bubble counters are the cycle model's, whose LOAD takes the shorter body record's beats."""
    job = _scalar_stack_job()
    pred = cycle_model.predict_job(job, get_preset("zcu102"))
    assert pred.phases["SOLVE"] < cycle_model.predict_job(job.with_inertia(False), get_preset("zcu102")).phases["SOLVE"]
    agree = run_deterministic(job, get_preset("zcu102"), pred, tmp_path)
    print(f"\n[stack/fp32/1 word] {agree.describe()}")
    assert agree.ok, agree.first_mismatch


def check_cycle_bound(job: KernelJob, preset: DmaPreset, cycles: int) -> None:
    """Random stream gaps and backpressure only add cycles: the kernel never beats the cycle model's
    deterministic prediction (models/timing/cycle_model.py)."""
    bound = cycle_model.lower_bound(job, preset)
    print(f"  cycle model lower bound {bound:,} cycles (measured {cycles / bound - 1:+.1%} above it)")
    assert cycles >= bound, f"{cycles:,} kernel cycles beat the cycle model's lower bound of {bound:,}"


# Deterministic streams (gap 0, backpressure 0): every case above, both DMA models the c512 build serves (zcu102:
# DDR token bucket + start-up latency; ideal: neither) and the interleaved pass order (a pipe switch every pass).
CYCLE_CASES = [(c, "zcu102", False) for c in CASES] + [
    (Case("pile", FP32, "hazard"), "ideal", False), (Case("stack", FP32, "pybullet"), "ideal", False),
    (Case("stack", FP32, "pybullet"), "zcu102", True), (Case("pile", FP16, "hazard"), "zcu102", True),
    (Case(ROTATED_WORLD, FP32, "pybullet"), "zcu102", False),
    (Case(MIXED_FRICTION_WORLD, FP32, "hazard"), "zcu102", False)]


@pytest.mark.parametrize("case,dma,interleaved", CYCLE_CASES,
                         ids=lambda v: f"{v.label}-{v.fmt.name}-{v.schedule_kind}" if isinstance(v, Case) else
                         ({True: "interleaved", False: "sequential"}[v] if isinstance(v, bool) else v))
def test_kernel_cycles_match_model(case: Case, dma: str, interleaved: bool, tmp_path: Path) -> None:
    """Every retire cycle of the trace equals the cycle model's prediction, exactly, and so do the kernel's cycle,
    stall and bubble counters. A difference fails with the manifold, both cycles and what the model expected
    (e.g. ``manifold 812 (...) retired at cycle 10,431, model 10,430: unexpected 1-cycle stall or bubble; the
    model: ... no stall: no hazard, no pipe switch``)."""
    frame = scenes.load_or_capture(case.scene, **SCENE_PARAMS[case.scene])
    params = SolverParams(ITERATIONS, interleaved=interleaved)
    job = KernelJob.from_frame(frame, case.fmt, params, case.schedule_kind, default_window(case.fmt, 512))
    t0 = time.process_time()
    pred = cycle_model.predict_job(job, get_preset(dma))
    model_s = time.process_time() - t0
    agree = run_deterministic(job, get_preset(dma), pred, tmp_path)
    order = "interleaved" if interleaved else "sequential"
    print(f"\n[{case.label}/{case.fmt.name}/{case.schedule_kind}/{dma}/{order}] {agree.describe()}; stalls "
          f"{pred.stalls:,} ({pred.stall_cycles_by_cause()}), bubbles {pred.bubbles:,}; model {model_s * 1e3:.0f} ms")
    assert agree.ok, agree.first_mismatch


def run_deterministic(job: KernelJob, preset: DmaPreset, pred: prediction.Prediction,
                      tmp: Path) -> retire_cycles.Agreement:
    """Run ``job`` with deterministic streams (no gap, no backpressure): bit-exact, and its trace, cycles and
    counters against the cycle model's prediction ``pred``."""
    res = run_kernel_step(job, preset, tmp, seed=1, keep_trace=True)
    assert res.bit_exact, res.comparison.first_mismatch
    return retire_cycles.compare_run(pred, res, job.slots)


# Every kind of hazard-CAM match, on the stack's 10 manifolds re-pointed at these body pairs (ground = 0, static)
# and issued in this order: (slot, its bodies, the earlier slot it must wait for or None, what matches).
HAZARD_CASES = [(0, (1, 2), None, "first"), (1, (1, 3), 0, "candidate A = in-flight A"),
                (2, (4, 3), 1, "candidate B = in-flight B"), (3, (5, 4), 2, "candidate B = in-flight A"),
                (4, (6, 7), None, "independent"), (5, (7, 8), 4, "candidate A = in-flight B"),
                (6, (0, 9), None, "static A"), (7, (0, 10), None, "only the static ground shared: no hazard"),
                (8, (9, 0), 6, "candidate A = in-flight B, static B"), (9, (2, 0), None, "slot 0 has retired")]


def test_kernel_hazard_cases(tmp_path: Path) -> None:
    """The four CAM matches (candidate A or B against an in-flight A or B), static bodies never matching, and a
    hazard across the wrap from one pass to the next: the model predicts each stall (the waiting slot, the slot it
    waits for), and the kernel retires every manifold-pass in exactly the model's cycle, bit-exact."""
    frame = scenes.load_or_capture("stack", **SCENES["stack"])
    base = KernelJob.from_frame(frame, FP32, SolverParams(2), "pybullet")
    pairs = np.array([p for _, p, _, _ in HAZARD_CASES], dtype=np.int64)
    cons = dataclasses.replace(base.cons, body_a=pairs[:, 0].copy(), body_b=pairs[:, 1].copy())
    job = dataclasses.replace(base, cons=cons, schedule=np.arange(len(pairs), dtype=np.int64))
    preset = get_preset("ideal")
    pred = cycle_model.predict_job(job, preset)
    first = (pred.kind == 0) & (pred.iteration == 0)
    for slot, _, waits_for, what in HAZARD_CASES:
        k = int(np.flatnonzero(first & (pred.slot == slot))[0])
        got = (int(pred.blocker[k]) if pred.cause[k] == prediction.HAZARD else None)
        assert got == waits_for, f"slot {slot} ({what}): the model waits for {got}, expected {waits_for}"
    k = int(np.flatnonzero((pred.kind == 0) & (pred.iteration == 1) & (pred.slot == 0))[0])
    assert pred.cause[k] == prediction.HAZARD and pred.iteration[pred.blocker[k]] == 0  # across the pass wrap
    agree = run_deterministic(job, preset, pred, tmp_path)
    print(f"\n[hazard cases] {agree.describe()}; stalls {pred.stall_cycles_by_cause()}")
    assert agree.ok, agree.first_mismatch
