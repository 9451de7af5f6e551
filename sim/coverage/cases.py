"""The runs of ``make coverage``: per kernel configuration (``sim.coverage.configurations``) the kernel harness on
the kernel test scenes (``models/scenes/kernel_scenes.py``) in several orders, DMA models and stream timings, with
the edits of ``sim.coverage.input_edits``; then the runs every configuration of a format shares (the fp-operator
vectors) and every configuration shares (the register file's cocotb test)."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from models.golden.contact_solver import Impulses
from models.kernel.extreme_stimulus import extreme_magnitudes
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32, NumberFormat
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES, MAKE_SIM_PILE
from sim.coverage.configurations import BY_NAME, CONFIGURATIONS, Configuration
from sim.coverage.input_edits import (BAD_INPUT_EDITS, RECORDS_BAD_INPUT_EDITS, WINDOW_BAD_INPUT_EDITS,
                                      WINDOW_RECORDS_BAD_INPUT_EDITS, Edit, HarnessEdit, edit_argument_bits,
                                      edit_gravity, edit_huge_sliding, edit_huge_velocity, edit_lanes_collide,
                                      edit_mass_spread, edit_spin, edit_wide_index)
from sim.compile.verilator_build import REPO_ROOT

# world files of Bullet 2's convention (rotated non-cube boxes; boxes, spheres, capsules, cylinders and a cone):
# the full inverse-inertia mode, 6 words per body, and a friction coefficient per manifold
ROTATED_WORLD = REPO_ROOT / "docs" / "rotated_boxes_world.py"
MIXED_WORLD = REPO_ROOT / "docs" / "mixed_shapes_world.py"

# run scene -> (catalogue scene or world file, builder parameters): the kernel tests' scenes, make sim's default
# pile (217 bodies: more than the 64 body-out credits of the integration), the rotated boxes
SCENES: dict[str, tuple[str, dict[str, Any]]] = {
    **{name: (name, params) for name, params in KERNEL_TEST_SCENES.items()}, "pile217": ("pile", MAKE_SIM_PILE),
    "rotated": (str(ROTATED_WORLD), {}), "mixed": (str(MIXED_WORLD), {})}

JobEdit = Callable[[KernelJob], KernelJob]


def warm_start(job: KernelJob, seed: int = 12345) -> KernelJob:
    """``job`` (impulses in the records) warm-started: random non-negative normal impulses, friction impulses
    within a tenth of their sum (inside the friction limit), rounded to the job's format."""
    rng = np.random.default_rng(seed)
    m = job.cons.num_manifolds
    normal = job.fmt.round(rng.uniform(0.0, 0.5, (m, 4)))
    friction = job.fmt.round(rng.uniform(-0.05, 0.05, (m, 2)) * normal.sum(axis=1, keepdims=True))
    return job.impulses_travelling(Impulses(normal, friction))


def independent_manifolds(job: KernelJob) -> KernelJob:
    """The manifolds re-pointed at the ground (body 0) and one body each, in slot order: no two share a dynamic
    body, so no hazard holds a pass back and each pass waits only for its predecessor's impulse writes (impulses
    in the records: the read-after-write rule across passes)."""
    m = job.cons.num_manifolds
    if m >= job.bodies.num_bodies:
        raise ValueError(f"{m} manifolds need more than {job.bodies.num_bodies} bodies to have one each")
    cons = dataclasses.replace(job.cons, body_a=np.zeros(m, np.int64), body_b=np.arange(1, m + 1, dtype=np.int64))
    return dataclasses.replace(job, cons=cons, schedule=np.arange(m, dtype=np.int64))


EXTREMES_SEED = 20261205  # the values of the extremes cases (fixed: a coverage run is reproducible)


def extremes(seed: int) -> JobEdit:
    """The step with every real word drawn over its format's whole range (``models.kernel.extreme_stimulus``), from
    ``seed``: most operators of every pipe raise each exception flag in some record."""
    return functools.partial(extreme_magnitudes, seed=seed)


def rigid_call(job: KernelJob) -> KernelJob:
    """The soft build's rigid call (keep factors of 1 in the registers: the relax call of Box2D's soft step)."""
    return dataclasses.replace(job, params=dataclasses.replace(job.params, soft_keep=None))


@dataclass(frozen=True)
class Case:
    """One harness run of the regression on the build of configuration ``config``."""

    label: str
    config: str  # a key of configurations.BY_NAME
    scene: str  # a key of SCENES
    schedule: str = "hazard"
    dma: str = "zcu102"  # the DMA model's timing (its beat must be the configuration's)
    stalls: int = 0  # random stream gaps and backpressure, per mille
    interleaved: bool = False
    edit: Edit | None = None
    fetch_passes: int | None = None  # window kernel: passes per fetch of this run (None: the configuration's)
    job_edit: JobEdit | None = None  # the step changed before its inputs are written (a warm start, other bodies)

    @property
    def configuration(self) -> Configuration:
        return BY_NAME[self.config]

    @property
    def fmt(self) -> NumberFormat:
        return self.configuration.fmt


def bad_input_cases(config: str, scene: str, schedule: str, edits: tuple[HarnessEdit, ...]) -> list[Case]:
    """One run per bad-input edit on ``scene``."""
    return [Case(f"{config}-{scene}-bad-{e.name}", config, scene, schedule, edit=e.edit) for e in edits]


def stimulus_cases(config: str, scene: str) -> list[Case]:
    """Inputs the scenes never make, not bad input: every argument register's bits both ways before the run's
    own writes, and bodies at the format's largest finite velocity, moving and spinning or sliding along the
    contacts (the pipes' overflow and NaN events)."""
    return [Case(f"{config}-{scene}-argument-bits", config, scene, edit=edit_argument_bits),
            Case(f"{config}-{scene}-huge-velocity", config, scene, edit=edit_huge_velocity),
            Case(f"{config}-{scene}-huge-sliding", config, scene, edit=edit_huge_sliding)]


def streaming_cases(config: str) -> list[Case]:
    """The regression of a streaming configuration: the test scenes, both orders, both DMA models, stalls,
    interleaved passes, the 217-body pile, other integration registers and every bad-input edit."""
    c = config
    return [
        Case(f"{c}-pile-hazard-zcu102-stalls", c, "pile", stalls=150),
        Case(f"{c}-pile-pybullet-zcu102", c, "pile", "pybullet"),
        Case(f"{c}-stack-hazard-ideal-stalls", c, "stack", dma="ideal", stalls=300),
        Case(f"{c}-stack-pybullet-zcu102-interleaved", c, "stack", "pybullet", interleaved=True),
        Case(f"{c}-incline-hazard-zcu102", c, "incline"),
        Case(f"{c}-pile217-hazard-zcu102", c, "pile217"),
        Case(f"{c}-stack-gravity-dt-damping", c, "stack", edit=edit_gravity),
        Case(f"{c}-stack-spin", c, "stack", "pybullet", edit=edit_spin),
        *stimulus_cases(c, "stack"),
    ] + bad_input_cases(c, "stack", "hazard", BAD_INPUT_EDITS)


def window_scene_cases(config: str) -> list[Case]:
    """The window kernels' runs in the sweep order beyond the pile and the stack: the incline, the 217-body pile,
    other integration registers, spin, a spread of masses and inertias, the body indices over the whole range, the
    stimulus edits, and the pile and the 217-body pile with every real word at extreme magnitudes (:func:`extremes`:
    the exception flags of the operators the forced velocities leave quiet, and several operators of a lane's pipes
    raising one in the same cycle). A configuration of the 1-word inverse inertia runs no incline: its box is not
    isotropic, so ``INERTIA=scene`` builds it the 3-word kernel."""
    c = config
    incline = [Case(f"{c}-incline-sweep-zcu102", c, "incline", "sweep")] if BY_NAME[c].inertia_words > 1 else []
    return incline + [
        Case(f"{c}-pile217-sweep-zcu102", c, "pile217", "sweep"),
        Case(f"{c}-stack-gravity-dt-damping", c, "stack", "sweep", edit=edit_gravity),
        Case(f"{c}-stack-spin", c, "stack", "sweep", edit=edit_spin),
        Case(f"{c}-pile-mass-spread", c, "pile", "sweep", edit=edit_mass_spread),
        Case(f"{c}-stack-wide-index", c, "stack", "sweep", edit=edit_wide_index),
        *stimulus_cases(c, "stack"),
        Case(f"{c}-pile-extremes", c, "pile", "sweep", job_edit=extremes(EXTREMES_SEED)),
        Case(f"{c}-pile217-extremes", c, "pile217", "sweep", job_edit=extremes(EXTREMES_SEED + 1)),
    ]


def window_cases(config: str) -> list[Case]:
    """The regression of a window configuration: the sweep order of the README rows and the hazard order, one
    fetch per step and several (2 and 3 passes per fetch), stalls, interleaved passes, the 217-body pile, a spread
    of masses and inertias, the body indices over the whole index range, the argument and stimulus edits, and the
    bad-input edits (the stream and argument errors of the window, lanes that collide); and the stimulus edits on
    the 217-body pile, whose hundreds of records keep every lane's pipes full of overflowing operations (the event
    counts' higher bits: several operators raising an event in one cycle, in each lane)."""
    c = config
    return [
        Case(f"{c}-pile-sweep-zcu102-stalls", c, "pile", "sweep", stalls=150),
        Case(f"{c}-pile-hazard-ideal-fetch2", c, "pile", dma="ideal", fetch_passes=2),
        Case(f"{c}-stack-sweep-zcu102-fetch3-stalls", c, "stack", "sweep", stalls=300, fetch_passes=3),
        Case(f"{c}-stack-pybullet-zcu102-interleaved", c, "stack", "pybullet", interleaved=True),
        Case(f"{c}-pile217-huge-velocity", c, "pile217", "sweep", edit=edit_huge_velocity),
        Case(f"{c}-pile217-huge-sliding", c, "pile217", "sweep", edit=edit_huge_sliding),
        *window_scene_cases(c),
    ] + bad_input_cases(c, "pile", "sweep", BAD_INPUT_EDITS + WINDOW_BAD_INPUT_EDITS)


def inertia_cases(config: str, scenes: tuple[str, ...]) -> list[Case]:
    """The regression of an inverse-inertia mode: its scenes with stalls and without, and the body-stream edits."""
    c = config
    body_edits = tuple(e for e in BAD_INPUT_EDITS if e.name in ("mass", "nonfinite", "body_tlast_early"))
    return [Case(f"{c}-{s}-hazard-zcu102-stalls", c, s, stalls=200) for s in scenes] + [
        Case(f"{c}-{scenes[0]}-pybullet-zcu102", c, scenes[0], "pybullet"),
        Case(f"{c}-{scenes[0]}-gravity-dt-damping", c, scenes[0], edit=edit_gravity)] + \
        bad_input_cases(c, scenes[0], "hazard", body_edits)


def records_cases(config: str) -> list[Case]:
    """The regression of the streaming kernel with the impulses in the records (the cases of
    ``cocotb_tests/test_kernel_impulses_in_records.py`` as harness runs, and the streaming kernel's others): cold
    and warm-started, interleaved (warm), random gaps and backpressure on every stream (the impulse-out stream
    included), the 10 independent manifolds (each pass waits for its predecessor's writes), the pybullet order,
    the 217-body pile, other integration registers, spin, a spread of body masses and inertias, the body indices
    spread over the whole index range, and the bad-input edits (the constraint stream's TLAST
    errors as a moved TLAST: the harness pairs every record with its slot and pass)."""
    c = config
    return [
        Case(f"{c}-pile-hazard-zcu102-stalls", c, "pile", stalls=150),
        Case(f"{c}-pile-hazard-zcu102", c, "pile"),
        Case(f"{c}-pile-hazard-zcu102-warm", c, "pile", job_edit=warm_start),
        Case(f"{c}-pile-hazard-zcu102-interleaved-warm-stalls", c, "pile", stalls=200, interleaved=True,
             job_edit=warm_start),
        Case(f"{c}-stack-independent-zcu102", c, "stack", job_edit=independent_manifolds),
        Case(f"{c}-stack-independent-ideal-stalls", c, "stack", dma="ideal", stalls=300,
             job_edit=independent_manifolds),
        Case(f"{c}-stack-pybullet-zcu102-interleaved", c, "stack", "pybullet", interleaved=True),
        Case(f"{c}-incline-hazard-zcu102", c, "incline"),
        Case(f"{c}-pile217-hazard-zcu102", c, "pile217"),
        Case(f"{c}-stack-gravity-dt-damping", c, "stack", edit=edit_gravity),
        Case(f"{c}-stack-spin", c, "stack", "pybullet", edit=edit_spin),
        Case(f"{c}-pile-mass-spread", c, "pile", edit=edit_mass_spread),
        Case(f"{c}-stack-wide-index", c, "stack", edit=edit_wide_index),
        *stimulus_cases(c, "stack"),
    ] + bad_input_cases(c, "stack", "hazard", RECORDS_BAD_INPUT_EDITS)


def window_records_cases(config: str) -> list[Case]:
    """The regression of the one-lane window kernel with the impulses in the records (the fitting window designs):
    the sweep order of its README rows and the hazard order, 4, 2 and 1 passes per fetch (2, 4 and 8 fetches),
    cold and warm-started, stalls on every stream (the impulse-out stream included), interleaved passes (a fetch
    per pass), the 217-body pile, other integration registers, spin, a spread of masses and inertias, the body
    indices over the whole index range, and the records design's and the window's bad-input edits."""
    c = config
    return [
        Case(f"{c}-pile-sweep-zcu102-stalls", c, "pile", "sweep", stalls=150),
        Case(f"{c}-pile-hazard-ideal-fetch2-warm", c, "pile", dma="ideal", fetch_passes=2, job_edit=warm_start),
        Case(f"{c}-pile-hazard-zcu102-fetch1-warm-stalls", c, "pile", stalls=200, fetch_passes=1,
             job_edit=warm_start),
        Case(f"{c}-stack-sweep-zcu102-fetch2-stalls", c, "stack", "sweep", stalls=300, fetch_passes=2),
        Case(f"{c}-stack-pybullet-zcu102-interleaved", c, "stack", "pybullet", interleaved=True, fetch_passes=1),
        *window_scene_cases(c),
    ] + bad_input_cases(c, "stack", "sweep", WINDOW_RECORDS_BAD_INPUT_EDITS)


def friction_coefficient_cases(config: str) -> list[Case]:
    """The regression of the friction coefficient per manifold (MU_W = 1, the 6-word inverse inertia): the
    rotated boxes and the mixed shapes world, both orders, with stalls and without, other integration registers,
    the bad-input edits."""
    c = config
    return [
        Case(f"{c}-rotated-hazard-zcu102-stalls", c, "rotated", stalls=200),
        Case(f"{c}-rotated-pybullet-zcu102-interleaved", c, "rotated", "pybullet", interleaved=True),
        Case(f"{c}-mixed-hazard-zcu102", c, "mixed"),
        Case(f"{c}-mixed-pybullet-ideal-stalls", c, "mixed", "pybullet", dma="ideal", stalls=300),
        Case(f"{c}-mixed-gravity-dt-damping", c, "mixed", edit=edit_gravity),
    ] + bad_input_cases(c, "mixed", "hazard", BAD_INPUT_EDITS)


# configuration -> its regression (a new configuration: its row in CONFIGURATIONS and its cases here)
CASES_OF: dict[str, list[Case]] = {
    "stream-fp16-records": records_cases("stream-fp16-records"),
    "stream-fp16-records-b256": records_cases("stream-fp16-records-b256"),
    "stream-fp32-records": records_cases("stream-fp32-records"),
    "stream-fp32": streaming_cases("stream-fp32") + [
        Case("stream-fp32-stack-wide-index", "stream-fp32", "stack", edit=edit_wide_index)],
    "stream-fp16": streaming_cases("stream-fp16"),
    "stream-fp32-records-tangents": records_cases("stream-fp32-records-tangents"),
    "stream-fp32-records-tangents-b256": records_cases("stream-fp32-records-tangents-b256"),
    "stream-fp32-soft": records_cases("stream-fp32-soft") + [
        Case("stream-fp32-soft-pile-hazard-zcu102-rigid-call", "stream-fp32-soft", "pile", job_edit=rigid_call)],
    "window-fp32-l2": window_cases("window-fp32-l2"),
    "window-fp16-l4": window_cases("window-fp16-l4"),
    "window-fp32-records": window_records_cases("window-fp32-records"),
    "window-fp16-records-l2": window_records_cases("window-fp16-records-l2") + [
        Case("window-fp16-records-l2-pile-bad-lanes_collide", "window-fp16-records-l2", "pile", "sweep",
             edit=edit_lanes_collide)],
    "stream-fp32-inertia1": inertia_cases("stream-fp32-inertia1", ("stack", "pile")),
    "stream-fp32-inertia6": inertia_cases("stream-fp32-inertia6", ("rotated", "pile")),
    "stream-fp32-mu": friction_coefficient_cases("stream-fp32-mu"),
}
CASES: list[Case] = [case for config in CONFIGURATIONS for case in CASES_OF[config.name]]


@dataclass(frozen=True)
class SharedCase:
    """A run outside the kernel harness whose coverage counts for every configuration of ``fmt`` (None: for
    every configuration): the same RTL with the same parameters."""

    label: str
    fmt: NumberFormat | None

    def counts_for(self, config: Configuration) -> bool:
        return self.fmt is None or self.fmt == config.fmt


REGISTER_CASE = SharedCase("pgs_control_s_axi-register-test", None)
# the operator vectors (random pairs, every special pair, directed ties / flush / overflow cases, every 16-bit
# sqrt input) through every rtl/fp operator, in the formats of the configurations
FP_OPERATOR_CASES = [SharedCase(f"fp-operators-{fmt.name}", fmt) for fmt in (FP32, FP16)]


def case_dir(out: Path, label: str) -> Path:
    """Where a run keeps its inputs and its coverage.dat."""
    return out / "runs" / label
