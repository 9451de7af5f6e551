"""One step for the kernel: the body table and constraints rounded to the kernel's format, the manifold schedule,
the solver and integration parameters, and (for the window kernel) the record-window plan.

Every consumer of a step builds one: the RTL harness run (``sim.drive.kernel_step``), the cycle model
(``models.timing.cycle_model``), the cocotb benches and the HLS C simulation.

    job = KernelJob.from_frame(frame, FP32, SolverParams(4), schedule="hazard", window=181)
    job.windowed(16384, lanes=2)  # the same step on the window kernel
    job.impulses_travelling(initial)  # the streaming kernel whose impulses travel with the records (a warm start)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from models.kernel import stream_format as sf
from models.kernel.body_banks import default_body_banks
from models.kernel.delay_lines import default_delay_block_min_depth
from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.golden.contact_solver import Impulses, SolverParams, pass_sequence
from models.formats.frame import Frame
from models.golden.integrator import IntegrationParams
from models.formats.number_format import NumberFormat
from models.kernel.record_window import WindowPlan, plan_window
from models.order.manifold_schedule import make_schedule
from models.golden.shock_propagation import shock_step
from models.setup.tangent_basis import derive_tangents
from models.kernel import record_window
from models.order import manifold_schedule


@dataclass
class KernelJob:
    """One step for the kernel: body table and constraints already rounded to ``fmt``, schedule, parameters."""

    fmt: NumberFormat
    bodies: BodyTable
    cons: ConstraintSet
    schedule: np.ndarray
    params: SolverParams
    iparams: IntegrationParams
    record_window: WindowPlan | None = None  # the window kernel's plan; None: the streaming kernel
    impulses_in_records: bool = False  # the streaming kernel without the impulse RAM (IMPULSES_IN_RECORDS)
    initial: Impulses | None = None  # per manifold, values of fmt: the impulses the step starts from (None: zeros)
    tangents_on_chip: bool = False  # the friction records omit t0, t1; cons.tangent holds the kernel's derived ones
    record_bits: sf.RecordBits | None = None  # mixed storage's record sizes (models/sizing/mixed_layout.py; no RTL)
    # the kernel's lanes: one datapath for both passes (SHARED_DATAPATH = 1, every configuration's default: the area
    # of one datapath at the cycles of two) or a contact and a friction pipe each (0)
    shared_datapath: bool = True
    # every fp_add of the pipes in its DSP48E2 form (ADD_SHIFT_DSP = 1: the same results and cycles, another design's
    # resources), else in LUTs and carry chains (0, the default)
    add_dsp: bool = False
    # the body record's inverse-inertia words as few as the scene needs (IINV_W = 1 where every dynamic body is
    # isotropic, ``sf.kernel_inertia_words``), else the default build's 3 (6 for the full matrix)
    scene_inertia: bool = False

    def __post_init__(self) -> None:
        if self.initial is None:
            return
        m = self.cons.num_manifolds
        if not self.impulses_in_records:
            raise ValueError("initial impulses need the kernel whose impulses travel with the records (the on-chip "
                             "impulse RAM starts every step from zeros)")
        if self.initial.normal.shape != (m, 4) or self.initial.friction.shape != (m, 2):
            raise ValueError(f"initial impulses must be ({m},4) and ({m},2), got {self.initial.normal.shape} and "
                             f"{self.initial.friction.shape}")
        vals = np.concatenate([self.initial.normal, self.initial.friction], axis=1)
        if not np.all(np.isfinite(vals)):
            raise ValueError("initial impulses must be finite (the kernel does not check its impulse words)")
        if not np.array_equal(self.fmt.round(vals), vals):
            raise ValueError(f"initial impulses must already be values of {self.fmt.name} (round them first)")

    @staticmethod
    def from_frame(frame: Frame, fmt: NumberFormat, params: SolverParams, schedule: str = "hazard",
                   window: int = 64) -> "KernelJob":
        """The step of ``frame`` in ``fmt``, its manifolds ordered by ``make_schedule(schedule, ..., window)``."""
        bodies = body_table(frame)
        cons = setup_constraints(frame, bodies)
        order = make_schedule(schedule, cons, bodies.dynamic, window=window)
        return KernelJob(fmt, bodies.rounded(fmt), cons.rounded(fmt), order, params,
                         IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity)))

    def windowed(self, depth: int, ctx: int = 8, fetch_passes: int | None = None, lanes: int = 1) -> "KernelJob":
        """This step on the window kernel with a ring of ``depth`` records of ``lanes`` slots
        (``models.kernel.record_window.plan_window``; with the impulses in the records every fetch serves passes of one
        kind)."""
        plan = plan_window(self.cons, self.bodies.dynamic, self.schedule, self.params, depth, ctx, fetch_passes,
                           lanes, one_kind=self.impulses_in_records,
                           banks=default_body_banks(self.fmt, self.impulses_in_records, True, lanes))
        if self.params.shock_contact or self.params.shock_friction:
            raise ValueError("a shock pass is marked in its records' headers, and the window kernel reads a record "
                             "once for several passes: shock propagation runs on the streaming kernel")
        if self.tangents_on_chip:
            raise ValueError("the window kernel streams the friction tangents: no tangents derived on chip")
        if self.record_bits is not None:
            raise ValueError("mixed storage is a record layout of the streaming kernel")
        return dataclasses.replace(self, record_window=plan)

    def with_datapath(self, shared: bool) -> "KernelJob":
        """This step on lanes of one shared datapath (``shared``) or of a contact and a friction pipe each."""
        return dataclasses.replace(self, shared_datapath=shared)

    def with_adders(self, dsp: bool) -> "KernelJob":
        """This step on pipes whose adders take the DSP48E2 form (``dsp``) or the fabric's."""
        return dataclasses.replace(self, add_dsp=dsp)

    def with_inertia(self, scene: bool) -> "KernelJob":
        """This step on the build whose body records carry the inverse-inertia words the scene needs (``scene``: 1
        for isotropic bodies) or the default build's (3, or 6 for the full matrix)."""
        return dataclasses.replace(self, scene_inertia=scene)

    def impulses_travelling(self, initial: Impulses | None = None) -> "KernelJob":
        """This step on the kernel whose impulses travel with the records, starting from ``initial`` (per manifold,
        rounded to the format; None: zeros, the same solve as the on-chip kernel's): the streaming kernel, or the
        window kernel whose fetches each serve passes of one kind (plan it with :meth:`windowed` after this, or
        before with such fetches)."""
        plan = self.record_window
        out = dataclasses.replace(self, impulses_in_records=True, initial=initial, record_window=None)
        if plan is None:
            return out
        # planned again: its fetches must serve one kind each, and its lanes fit the build's body banks
        return out.windowed(plan.depth, plan.ctx, plan.fetch_passes, plan.lanes)

    def tangents_derived(self) -> "KernelJob":
        """This step with the friction tangents derived from the normals in the job's format
        (``models.setup.tangent_basis``: the record layout without t0, t1, the kernel built with TANGENTS_ON_CHIP; the
        golden model then solves with the derived tangents, bit for bit the kernel's)."""
        if self.record_window is not None:
            raise ValueError("tangents derived on chip are a record layout of the streaming kernel")
        return dataclasses.replace(self, cons=derive_tangents(self.cons, self.fmt), tangents_on_chip=True)

    def shocked(self, linear: bool = False, friction: bool = False, impulses: str = "keep",
                passes: int = 1, window: int = 0) -> "KernelJob":
        """This step with shock propagation (``models/golden/shock_propagation.py``): the shock rows and the ground-up
        layer order of this step's contact graph (``window`` > 0: each layer pair in the hazard order of that
        window), the last ``passes`` contact passes (and with ``friction`` the last friction passes) shock passes,
        their frozen rows' impulses kept or returned (``SolverParams``). The streaming kernel reads the shock
        passes' records with the frozen-body bits in their headers."""
        if self.record_window is not None:
            raise ValueError("shock propagation runs on the streaming kernel (a window record serves several passes)")
        if self.tangents_on_chip:
            raise ValueError("take the shock rows before the tangents are derived (KernelJob.shocked first)")
        cons, order = shock_step(self.cons, self.bodies, self.schedule, self.fmt, linear, window)
        params = dataclasses.replace(self.params, shock_contact=True, shock_friction=friction,
                                     shock_impulses=impulses, shock_passes=passes)
        return dataclasses.replace(self, cons=cons, schedule=order, params=params)

    def unshocked(self) -> "KernelJob":
        """This step without its shock passes: the same records, schedule and start, the shock flags of its
        parameters clear (what a shocked step is told apart from)."""
        return dataclasses.replace(self, params=dataclasses.replace(self.params, shock_contact=False,
                                                                    shock_friction=False))

    def stored_as(self, record_bits: sf.RecordBits) -> "KernelJob":
        """This step with its records in the sizes of a mixed storage (``models/sizing/mixed_layout.py``: the cycle and
        resource models know it, the golden model's values are ``models/sizing/mixed_storage.py``'s, no RTL)."""
        if self.record_window is not None:
            raise ValueError("mixed storage is a record layout of the streaming kernel")
        return dataclasses.replace(self, record_bits=record_bits)

    @property
    def start_impulses(self) -> Impulses:
        """The impulses the step starts from, per manifold (zeros unless a warm start was given)."""
        return self.initial if self.initial is not None else Impulses.zeros(self.cons.num_manifolds)

    def record_checks(self) -> list[bool] | None:
        """Per pass (``pass_sequence`` order), whether the kernel reads the pass's records with their impulse words
        from memory and checks them (``contact_solver.solve``): every pass of the streaming kernel whose impulses
        travel with the records, the first pass of each fetch of such a window kernel (its later passes take the
        impulses from the ring); None where the impulses stay on chip (never read back from a record)."""
        if not self.impulses_in_records:
            return None
        passes = len(pass_sequence(self.params))
        per_fetch = self.record_window.fetch_passes if self.record_window is not None else 1
        return [p % per_fetch == 0 for p in range(passes)]

    def stream_layout(self, cons_bits: int = sf.DEFAULT_CONS_BEAT_BITS) -> sf.StreamLayout:
        """The record sizes this step streams with constraint beats of ``cons_bits``."""
        return sf.StreamLayout(self.fmt, cons_beat_bits=cons_bits, inertia_words=self.inertia_words,
                               impulses_in_records=self.impulses_in_records, friction_words=self.friction_words,
                               tangents_on_chip=self.tangents_on_chip, record_bits=self.record_bits)

    def ddr_read_share(self, cons_bits: int = sf.DEFAULT_CONS_BEAT_BITS) -> float:
        """The share of the DDR bandwidth this step's constraint reads get beside its impulse writes
        (``StreamLayout.ddr_read_share``: per pass, or per fetch of the window kernel)."""
        plan = self.record_window
        return self.stream_layout(cons_bits).ddr_read_share(self.params, plan.fetch_passes if plan else 0)

    @property
    def block_kinds(self) -> list[int]:
        """The pass kind of each block of the constraint stream whose impulses travel with the records: a pass of
        the streaming kernel, a fetch of the window kernel (each serving passes of one kind)."""
        plan = self.record_window
        if plan is None:
            return [kind for kind, _ in pass_sequence(self.params)]
        return [int(k) for k in record_window.window_fetch_kinds(self.params, plan.fetch_passes, one_kind=True) if k is not None]

    @property
    def inertia_words(self) -> int:
        """Inverse-inertia words per body of the kernel build that runs this step (``sf.kernel_inertia_words``)."""
        return sf.kernel_inertia_words(self.bodies, self.scene_inertia)

    @property
    def body_banks(self) -> int:
        """Body-velocity banks of the kernel build that runs this step (``models.kernel.body_banks``: 0 the multiport
        memory)."""
        plan = self.record_window
        return default_body_banks(self.fmt, self.impulses_in_records, plan is not None, plan.lanes if plan else 1)

    @property
    def delay_block_min_depth(self) -> int:
        """The depth from which the build's delay lines are in block RAM (``models.kernel.delay_lines``: 0 none)."""
        plan = self.record_window
        return default_delay_block_min_depth(self.fmt, self.impulses_in_records, plan is not None,
                                             plan.lanes if plan else 1, self.shared_datapath)

    @property
    def friction_words(self) -> int:
        """Friction-coefficient words per friction record of the kernel build that runs this step
        (``ConstraintSet.friction_words``: 1 where the manifolds carry their own coefficient)."""
        return self.cons.friction_words

    @property
    def slots(self) -> np.ndarray:
        """The kernel's manifold slots in order (-1: an empty lane of the window kernel)."""
        if self.record_window is not None:
            return self.record_window.slots
        return manifold_schedule.schedule_manifolds(self.schedule)

    @property
    def manifolds(self) -> int:
        """The manifolds the kernel solves (its slots less the window kernel's empty lanes)."""
        return int(np.count_nonzero(self.slots >= 0))

    @property
    def manifold_passes(self) -> int:
        return self.manifolds * len(pass_sequence(self.params))

    @property
    def lanes(self) -> int:
        """Lanes of the kernel build that runs this step (the streaming kernel has one)."""
        return self.record_window.lanes if self.record_window is not None else 1

    @property
    def compute_floor_cycles(self) -> float:
        """The roofline's compute floor: each lane issues one manifold-pass a cycle (II = 1), and the body load and
        store take a cycle a body."""
        return self.manifold_passes / self.lanes + 2 * self.bodies.num_bodies
